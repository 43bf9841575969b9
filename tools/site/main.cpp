// ips-site: owns the site file and publishes it on SITE, at start and every --period seconds,
// and answers SITE_REQUEST; re-reads the file when it changes (inotify on its directory) or on
// SIGHUP. A version that does not load is not published: the previous site stays on the bus and
// the error is in HEALTH (degraded, last_error) until the file loads again.
#include <cerrno>
#include <cstring>
#include <fstream>
#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/text_escape.hpp"
#include "tools/site/reload_triggers.hpp"
#include "tools/site/site_keeper.hpp"

namespace {

namespace st = ips::site_tool;

constexpr const char* kProgram = "ips-site";
// From the last inotify event of a save to the reading (FileWatch).
constexpr double kSettleS = 0.2;

// The file's text, at most one byte more than a site may have (SiteKeeper refuses the rest).
std::string read_site_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ips::ConfigError(path + ": cannot read: " + std::strerror(errno));
  std::string text(st::kMaxSiteFileBytes + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (in.bad()) throw ips::ConfigError(path + ": cannot read: " + std::strerror(errno));
  text.resize(static_cast<size_t>(in.gcount()));
  return text;
}

std::string summary(const ips::Site& s) {
  return fmt::format("site '{}' ({} anchors, {} tags)", ips::printable(s.name), s.anchors.size(),
                     s.tags.size());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-site: publishes a site file on SITE, at start and every --period seconds, for "
               "every process started without --site. Re-reads the file when it changes or on "
               "SIGHUP; a version that does not load is not published (the previous site stays) "
               "and its error, with file and line, is in HEALTH and on stderr.",
               kProgram};
  app.footer(
      "Example (one machine of the lab owns the file; the others run without --site):\n"
      "  ips-site /etc/ips/lab.yaml --period 2\n"
      "  ips-uwb-twr            # on any machine of the bus: takes the site from SITE\n"
      "  $EDITOR /etc/ips/lab.yaml   # saved: checked, then published within a second\n"
      "  kill -HUP <pid>        # re-read now (e.g. a file behind a symlink)\n"
      "See docs/deployment.md#the-site-one-file-one-publisher.");
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  std::string path;
  double period_s = 2.0;
  app.add_option("FILE", path, "the site file (YAML; docs/site-file.md)")->required();
  app.add_option("--period", period_s, "seconds between SITE messages")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors(kProgram, [&] {
    st::SiteKeeper keeper(path);
    // A file that does not load at start stops the process (status 2), as --site does.
    if (const auto first = keeper.offer_text(read_site_file(path));
        first.kind == st::SiteOutcome::Kind::kRejected)
      throw ips::ConfigError(first.text);
    ips::Node node(kProgram, opts);
    const std::string site_channel = opts.channel(ips::channel::kSite);
    ips::site_t msg = ips::site_to_msg(keeper.site(), ips::wall_utime_now(), kProgram);
    auto publish = [&] {
      msg.utime = ips::wall_utime_now();
      node.publish(site_channel, msg);
    };
    // A process that starts (or restarts) asks on SITE_REQUEST and is answered at once.
    ips::answer_site_requests(node, [&]() -> const ips::site_t* { return &msg; });

    const std::string kFileKey = "site file";
    auto reload = [&](const char* why) {
      st::SiteOutcome o;
      try {
        o = keeper.offer_text(read_site_file(path));
      } catch (const ips::ConfigError& e) {
        o = keeper.offer_read_error(e.what());
      }
      switch (o.kind) {
        case st::SiteOutcome::Kind::kFirst:
        case st::SiteOutcome::Kind::kReplaced:
          msg = ips::site_to_msg(keeper.site(), ips::wall_utime_now(), kProgram);
          publish();
          spdlog::info("{}: {} ({}): {} replaced: {}; published on {}", kProgram,
                       ips::printable(path), why, summary(keeper.site()), ips::printable(o.text),
                       site_channel);
          break;
        case st::SiteOutcome::Kind::kUnchanged:
          if (o.error_cleared)
            spdlog::info("{}: {} ({}): loads again, as the {} already published", kProgram,
                         ips::printable(path), why, summary(keeper.site()));
          else
            spdlog::debug("{}: {} ({}): unchanged", kProgram, ips::printable(path), why);
          break;
        case st::SiteOutcome::Kind::kRejected:
          ++node.counters().parse_errors;
          node.report_lasting_error(kFileKey, "not published, the previous site stays: " + o.text);
          return;
      }
      node.end_lasting_error(kFileKey);
    };
    st::HangupHandler hangup(node, [&] {
      spdlog::info("{}: SIGHUP: reading {} again", kProgram, ips::printable(path));
      reload("SIGHUP");
    });
    st::FileWatch watch(
        node, path, kSettleS, [&] { reload("changed"); },
        [&](const std::string& why) {
          node.report_lasting_error("watch", why + "; the file is read again on SIGHUP only");
        });

    publish();
    node.add_timer(period_s, publish);
    spdlog::info("{}: publishing {} from {} on {} every {} s{}", kProgram, summary(keeper.site()),
                 ips::printable(path), site_channel, period_s,
                 watch.watching() ? "; watching " + ips::printable(watch.directory()) + " for changes"
                                  : "");
    return node.run();
  });
}
