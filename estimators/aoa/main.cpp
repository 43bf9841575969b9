// ips-aoa: subscribes to BLE_AOA, publishes POSE_AOA per tag.
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "core/message_clock.hpp"
#include "estimators/aoa/aoa_estimator.hpp"

namespace {
constexpr const char* kProgram = "ips-aoa";
}

int main(int argc, char** argv) {
  CLI::App app{"ips-aoa: positions BLE tags from the angles of arrival that u-blox XPLR-AOA "
               "anchors measure (BLE_AOA) and publishes their positions with covariance "
               "(POSE_AOA).",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  std::string method;
  app.add_option("--method", method,
                 "override the site's estimators.aoa method: ekf, or a per-epoch solver "
                 "(lm, gauss_newton, steepest_descent, bearing_lines)");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  std::optional<ips::aoa::AoaSolver> solver;
  if (!method.empty() && method != "ekf") {
    solver = ips::aoa::parse_aoa_solver(method);
    if (!solver) {
      ips::print_fatal(kProgram, "--method: expected ekf, lm, gauss_newton, steepest_descent or "
                                 "bearing_lines, got '" + method + "'");
      return 2;
    }
  }
  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string out_channel = opts.channel(ips::channel::kPoseAoa);
    ips::aoa::AoaEstimator est([&](const ips::pose_t& p) { node.publish(out_channel, p); });
    if (!method.empty())
      est.override_method(solver ? ips::aoa::AoaMethod::kPerEpoch : ips::aoa::AoaMethod::kEkf,
                          solver);
    ips::provide_site(node, "ble_aoa", [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    // The events' own clock, carried forward by the host clock while the bus is quiet: an epoch
    // closes when its window has passed in the events' time, also for a log played back.
    ips::MessageClock event_clock;
    node.subscribe<ips::ble_aoa_t>(
        opts.channel(ips::channel::kBleAoa), [&](const ips::ble_aoa_t& m, const std::string&) {
          if (!tag_filter.pass(m.tag_id)) return;
          est.on_event(m);
          // The newest time the estimator took (a stamp far ahead is not taken: time_guard.hpp).
          event_clock.saw(est.newest_event_utime());
        });
    // Events that gave no pose, by reason, in HEALTH once a second; gated angles and multipath
    // duplicates are counted in drops without marking the process degraded.
    ips::DropHealth drop_health;
    // The angle innovations against their assumed noise, per anchor (core/consistency.hpp).
    ips::ConsistencyHealth consistency_health;
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons());
      consistency_health.report(node, est.consistency());
    });
    node.add_timer(0.02, [&] {
      if (const ips::utime_t now = event_clock.now()) est.flush(now);
    });
    return node.run();
  });
}
