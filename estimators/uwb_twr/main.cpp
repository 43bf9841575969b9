// ips-uwb-twr: subscribes to UWB_RANGE, publishes POSE_UWB per tag (and, when the site asks,
// the plain per-epoch least-squares fixes on POSE_UWB_EPOCH).
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ips-uwb-twr: tracks UWB tags from two-way ranges (UWB_RANGE) and publishes their "
               "positions with covariance (POSE_UWB).",
               "ips-uwb-twr"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors("ips-uwb-twr", [&] {
    ips::Node node("ips-uwb-twr", opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string out_channel = opts.channel(ips::channel::kPoseUwb);
    const std::string epoch_channel = opts.channel(ips::channel::kPoseUwbEpoch);
    ips::uwb_twr::TwrEstimator est(
        [&](const ips::pose_t& p) { node.publish(out_channel, p); });
    // Only when the site asks for them (estimators.uwb_twr.epoch_fixes).
    est.set_epoch_sink([&](const ips::pose_t& p) { node.publish(epoch_channel, p); });
    ips::provide_site(node, "uwb", [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    node.subscribe<ips::uwb_range_t>(
        opts.channel(ips::channel::kUwbRange),
        [&](const ips::uwb_range_t& m, const std::string&) {
          if (tag_filter.pass(m.tag_id)) est.on_range(m);
        });
    // Ranges that gave no pose, by reason, in HEALTH (drops, last_error) once a second.
    ips::DropHealth drop_health;
    ips::ConsistencyHealth consistency_health;
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons());
      consistency_health.report(node, est.consistency());
    });
    return node.run();
  });
}
