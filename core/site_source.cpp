#include "core/site_source.hpp"

#include <ips/site_t.hpp>
#include <chrono>
#include <memory>
#include <optional>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/text_escape.hpp"

namespace ips {

void answer_site_requests(Node& node, std::function<const site_t*()> current) {
  auto last_answer = std::make_shared<std::chrono::steady_clock::time_point>();
  node.subscribe<site_t>(
      node.options().channel(channel::kSiteRequest),
      [&node, last_answer, current = std::move(current)](const site_t& req, const std::string&) {
        const site_t* site = current();
        if (!site) return;
        const auto now = std::chrono::steady_clock::now();
        // Several processes asking at once (a deployment restarted) get one answer.
        if (*last_answer != std::chrono::steady_clock::time_point{} &&
            now - *last_answer < std::chrono::duration<double>(kSiteAnswerPeriodS))
          return;
        *last_answer = now;
        spdlog::debug("{}: SITE asked for by {}: answered", node.name(), printable(req.source));
        node.publish(node.options().channel(channel::kSite), *site);
      });
}

void provide_site(Node& node, std::function<void(const Site&)> on_site) {
  if (!node.options().site_path.empty()) {
    on_site(load_site_file(node.options().site_path));
    return;
  }
  // Until a site arrives the process is up but cannot do its job: say so in health_t.
  node.set_state(health_t::STATE_STARTING);
  spdlog::info("{}: no --site given, waiting for a SITE message on {}", node.name(),
               node.options().channel(channel::kSite));
  // The SITE message taken last, as it came (the answer to others' requests).
  auto held = std::make_shared<std::optional<site_t>>();
  node.subscribe<site_t>(node.options().channel(channel::kSite),
                         [&node, held, on_site](const site_t& msg, const std::string&) {
                           if (*held && msg.site_yaml == (*held)->site_yaml) return;
                           try {
                             Site site = site_from_msg(msg);
                             *held = msg;
                             spdlog::info("{}: site '{}' from {} ({} anchors)", node.name(),
                                          printable(site.name), printable(msg.source),
                                          site.anchors.size());
                             on_site(site);
                             node.set_state(health_t::STATE_OK);
                           } catch (const SiteError& e) {
                             ++node.counters().parse_errors;
                             node.report_error(e.what());
                           }
                         });
  answer_site_requests(node, [held]() -> const site_t* { return *held ? &**held : nullptr; });
  // Ask now and every second until a site is held: a restarted process is told at once by any
  // process that holds it, instead of waiting for the next periodic SITE.
  auto ask = [&node, held] {
    if (*held) return;
    site_t req{};  // an empty site: no anchors, stations, tags or text
    req.utime = wall_utime_now();
    req.source = node.name();
    req.num_anchors = req.num_baro_stations = req.num_tags = 0;
    node.publish(node.options().channel(channel::kSiteRequest), req);
  };
  ask();
  node.add_timer(kSiteRequestPeriodS, ask);
}

void provide_site(Node& node, const std::string& anchor_kind,
                  std::function<void(const Site&)> on_site) {
  provide_site(node, [&node, anchor_kind, on_site = std::move(on_site)](const Site& site) {
    on_site(site);
    const std::string missing = missing_anchor_kind(site, anchor_kind, node.name());
    if (missing.empty())
      node.end_lasting_error("site-anchor-kind");
    else
      node.report_lasting_error("site-anchor-kind", missing);
  });
}

}  // namespace ips
