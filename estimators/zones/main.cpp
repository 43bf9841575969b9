// ips-zones: subscribes to a pose channel (POSE_FUSED), ALTITUDE and HEALTH; publishes the tags'
// zone entries, exits and dwells on ZONE_EVENT and the site's alerts on ALERT
// (estimators/zones/zone_monitor.hpp).
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "core/text_escape.hpp"
#include "estimators/zones/zone_monitor.hpp"

namespace {

constexpr const char* kProgram = "ips-zones";
using Steady = std::chrono::steady_clock;

// A clock of the monitor's as last moved by a message, and when (wall time): live, the clock
// goes on at the wall's pace from there until the next message.
struct ClockMark {
  int64_t utime = 0;
  Steady::time_point at;
  void follow(int64_t now_utime) {
    if (now_utime == utime) return;
    utime = now_utime;
    at = Steady::now();
  }
  int64_t projected() const {
    if (utime == 0) return 0;
    return utime +
           std::chrono::duration_cast<std::chrono::microseconds>(Steady::now() - at).count();
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-zones: which zone of the site each tag is in, from a pose channel and "
      "ALTITUDE (a zone on a floor counts only on it), with hysteresis at the borders; "
      "publishes ENTER, LEAVE and DWELL on ZONE_EVENT, and on ALERT the zone events the "
      "site marks, tags silent, processes degraded or without HEALTH (the site's "
      "zones: and alerts:).",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  std::string pose_channel = ips::channel::kPoseFused;
  app.add_option("--pose-channel", pose_channel,
                 "the poses to watch (TRUTH, POSE_UWB, ...); its name is in every event")
      ->capture_default_str();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (!ips::channel::valid_channel_name(pose_channel)) {
    ips::print_fatal(kProgram, "--pose-channel: '" + ips::printable(pose_channel) +
                                   "' is not a channel name (1 to 63 of A-Z a-z 0-9 _)");
    return 2;
  }

  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string event_channel = opts.channel(ips::channel::kZoneEvent);
    const std::string alert_channel = opts.channel(ips::channel::kAlert);
    ips::zones::ZoneMonitorOptions mo;
    mo.source = kProgram;
    mo.pose_channel = pose_channel;
    mo.self_host = node.host();
    mo.self_pid = static_cast<int32_t>(getpid());
    ips::zones::ZoneMonitor monitor(
        mo, [&](const ips::zone_event_t& e) { node.publish(event_channel, e); },
        [&](const ips::alert_t& a) {
          node.publish(alert_channel, a);
          if (a.state == ips::alert_t::STATE_RAISED) {
            spdlog::warn("alert {}: {}", a.id, ips::printable(a.text));
          } else {
            spdlog::info("alert {} cleared: {}", a.id, ips::printable(a.text));
          }
        });
    ClockMark tags_mark, processes_mark;
    auto follow = [&] {
      tags_mark.follow(monitor.tags_clock());
      processes_mark.follow(monitor.processes_clock());
    };
    ips::provide_site(node, [&](const ips::Site& site) {
      tag_filter.set_site(site);
      monitor.set_site(site);
      follow();
    });
    node.subscribe<ips::pose_t>(pose_channel, [&](const ips::pose_t& m, const std::string&) {
      if (!tag_filter.pass(m.tag_id)) return;
      monitor.on_pose(m);
      follow();
    });
    node.subscribe<ips::altitude_t>(opts.channel(ips::channel::kAltitude),
                                    [&](const ips::altitude_t& m, const std::string&) {
                                      if (!tag_filter.pass(m.tag_id)) return;
                                      monitor.on_altitude(m);
                                      follow();
                                    });
    node.subscribe<ips::health_t>(opts.channel(ips::channel::kHealth),
                                  [&](const ips::health_t& m, const std::string&) {
                                    monitor.on_health(m);
                                    follow();
                                  });
    ips::DropHealth drop_health;
    node.add_timer(1.0, [&] {
      // Silence is noticed when nothing arrives: the clocks go on at the wall's pace.
      monitor.advance_clocks(tags_mark.projected(), processes_mark.projected());
      follow();
      drop_health.report(node, monitor.drop_reasons());
      const auto open = monitor.open_alerts();
      if (open.empty()) {
        node.end_note("alerts");
      } else {
        std::string text = std::to_string(open.size()) +
                           (open.size() == 1 ? " alert open: " : " alerts open: ") + open.front();
        if (open.size() > 1) text += "; ...";
        node.report_note("alerts", text);
      }
    });
    return node.run();
  });
}
