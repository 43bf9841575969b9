// ips-uwb-twr: subscribes to UWB_RANGE, publishes POSE_UWB per tag.
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ips-uwb-twr: tracks UWB tags from two-way ranges (UWB_RANGE) and publishes their "
               "positions with covariance (POSE_UWB).",
               "ips-uwb-twr"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts);
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors("ips-uwb-twr", [&] {
    ips::Node node("ips-uwb-twr", opts);
    const std::string out_channel = opts.channel(ips::channel::kPoseUwb);
    ips::uwb_twr::TwrEstimator est(
        [&](const ips::pose_t& p) { node.publish(out_channel, p); });
    ips::provide_site(node, [&](const ips::Site& site) { est.set_site(site); });
    int64_t reported_drops = 0;
    node.subscribe<ips::uwb_range_t>(
        opts.channel(ips::channel::kUwbRange), [&](const ips::uwb_range_t& m, const std::string&) {
          est.on_range(m);
          const auto& s = est.stats();
          const int64_t drops = s.dropped_invalid + s.dropped_unknown_anchor + s.dropped_late +
                                s.dropped_too_many_tags;
          if (drops != reported_drops) {
            node.counters().drops += drops - reported_drops;
            reported_drops = drops;
            node.report_error("dropped ranges: " + std::to_string(s.dropped_invalid) +
                              " invalid, " + std::to_string(s.dropped_unknown_anchor) +
                              " unknown anchor, " + std::to_string(s.dropped_late) + " late, " +
                              std::to_string(s.dropped_too_many_tags) + " beyond max_tags");
          }
        });
    return node.run();
  });
}
