#include "core/cli.hpp"

#include <algorithm>
#include <cstdio>
#include <iostream>

#include "core/channels.hpp"
#include "core/lcm_url.hpp"
#include "core/yaml_fields.hpp"
#include "core/logging.hpp"
#include "core/tag_selector.hpp"
#include "core/version.hpp"

namespace ips {

std::string CommonOptions::channel(const std::string& kind) const {
  std::string result = kind;
  for (const auto& o : channel_overrides) {
    auto eq = o.find('=');
    if (eq != std::string::npos && o.substr(0, eq) == kind) result = o.substr(eq + 1);
  }
  return result;
}

void add_common_options(CLI::App& app, CommonOptions& opts, CommonFlags flags) {
  if (flags.lcm) {
    app.add_option("--lcm-url", opts.lcm_url,
                   "LCM URL, e.g. udpm://239.255.76.67:7667?ttl=0 (default: LCM_DEFAULT_URL or "
                   "LCM's own default)");
    app.add_option("--lcm-queue", opts.lcm_queue,
                   "messages liblcm may hold per subscription while this process is busy; more "
                   "are dropped and counted in HEALTH queue_drops (0: no limit)")
        ->check(CLI::Range(0, 10000000))
        ->capture_default_str();
    app.add_option("--lcm-recv-buf", opts.lcm_recv_buf,
                   "kernel receive buffer (bytes) asked for when the URL has no recv_buf_size; the "
                   "kernel caps it at net.core.rmem_max (docs/networking.md#loss)")
        ->check(CLI::Range(0, 1 << 30))
        ->capture_default_str();
    app.add_option("--lcm-receiver", opts.lcm_receiver,
                   "who reads a udpm:// bus: liblcm (its receive thread, --lcm-queue per "
                   "subscription), direct (this process's loop reads the socket: one wake-up "
                   "and two system calls less per message) or auto (direct when the kernel "
                   "grants the receive buffer asked for, at least 4 MiB, else liblcm; "
                   "docs/networking.md#receivers)")
        ->check(CLI::IsMember({"liblcm", "direct", "auto"}))
        ->capture_default_str();
    app.add_option("--busy-poll-us", opts.busy_poll_us,
                   "after each message, poll the bus this long (us) without sleeping: the next "
                   "message is taken at once instead of after a wake-up, at the cost of a core "
                   "while messages come; needs the direct receiver (0: sleep at once; "
                   "docs/networking.md#latency)")
        ->check(CLI::Range(0, 10000000))
        ->capture_default_str();
  }
  if (flags.site) {
    app.add_option("--site", opts.site_path,
                   "site file (YAML); without it the site is taken from the first SITE message");
  }
  if (flags.channels) {
    app.add_option("--channel", opts.channel_overrides,
                   "rename a channel, KIND=NAME (e.g. --channel POSE_UWB=POSE_UWB_TEST); "
                   "repeatable")
        ->type_name("KIND=NAME");
  }
  if (flags.tags) {
    app.add_option("--tags", opts.tags,
                   "handle only these tags: ids and globs (* any run, ? one character), "
                   "comma-separated, e.g. T1,T2 or 'T1*'; messages of other tags are skipped and "
                   "counted (in HEALTH's note; in ips-replay's summary) (default: every tag)")
        ->type_name("PATTERN");
    app.add_option("--shard", opts.shard,
                   "handle only shard K of N (1 <= K <= N <= 1024): the tags whose FNV-1a 64 hash "
                   "of the id, mod N, plus 1, is K; N instances with 1/N .. N/N split the tags "
                   "(docs/networking.md#splitting-a-big-site)")
        ->type_name("K/N");
  }
  app.add_option("--log-level", opts.log_level, "trace, debug, info, warn, error or off")
      ->capture_default_str();
  // The name is read when the flag is given: the program may name the app after this call.
  app.set_version_flag(
      "--version", [&app] { return version_line(app.get_name()); },
      "print the program, its version, the git commit and build type it was built from, and exit");
}

void print_fatal(const std::string& program, const std::string& what) {
  std::fprintf(stderr, "%s: error: %s\n", program.c_str(), what.c_str());
  std::fflush(stderr);
}

int run_reporting_errors(const std::string& program, const std::function<int()>& body) {
  try {
    return body();
  } catch (const ConfigError& e) {
    print_fatal(program, e.what());
    return 2;
  } catch (const LcmOpenError& e) {
    print_fatal(program, e.what());
    return 1;
  }
}

bool parse_command_line(CLI::App& app, const CommonOptions& opts, int argc, char** argv,
                        int& exit_code) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    std::cout << app.help();
    exit_code = 0;
    return false;
  } catch (const CLI::CallForAllHelp&) {
    std::cout << app.help("", CLI::AppFormatMode::All);
    exit_code = 0;
    return false;
  } catch (const CLI::CallForVersion& e) {
    std::cout << e.what() << "\n";
    exit_code = 0;
    return false;
  } catch (const CLI::ParseError& e) {
    print_fatal(app.get_name(), std::string(e.what()) + " (see --help)");
    exit_code = 2;
    return false;
  }
  if (!set_log_level(opts.log_level)) {
    print_fatal(app.get_name(), "--log-level: unknown level '" + opts.log_level + "'");
    exit_code = 2;
    return false;
  }
  for (const auto& o : opts.channel_overrides) {
    auto eq = o.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == o.size()) {
      print_fatal(app.get_name(), "--channel: expected KIND=NAME, got '" + o + "'");
      exit_code = 2;
      return false;
    }
    const std::string kind = o.substr(0, eq);
    if (std::find(std::begin(channel::kAllKinds), std::end(channel::kAllKinds), kind) ==
        std::end(channel::kAllKinds)) {
      std::string kinds;
      for (const char* k : channel::kAllKinds) kinds += (kinds.empty() ? "" : ", ") + std::string(k);
      print_fatal(app.get_name(), "--channel: unknown kind '" + kind + "' (" + kinds + ")");
      exit_code = 2;
      return false;
    }
    if (!channel::valid_channel_name(o.substr(eq + 1))) {
      print_fatal(app.get_name(), "--channel: bad channel name '" + o.substr(eq + 1) +
                                      "' (1 to 63 letters, digits or _)");
      exit_code = 2;
      return false;
    }
  }
  if (!opts.tags.empty() || !opts.shard.empty()) {
    std::string error;
    if (!TagSelector::parse(opts.tags, opts.shard, error)) {
      print_fatal(app.get_name(), error);
      exit_code = 2;
      return false;
    }
  }
  exit_code = 0;
  return true;
}

}  // namespace ips
