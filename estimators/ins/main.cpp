// ips-ins: subscribes to IMU (foot-mounted), publishes POSE_INS per tag.
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/consistency.hpp"
#include "core/drop_reasons.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "estimators/ins/ins_estimator.hpp"

namespace {
constexpr const char* kProgram = "ips-ins";
}

int main(int argc, char** argv) {
  CLI::App app{
      "ips-ins: a foot-mounted ZUPT-aided strapdown INS. Integrates the IMU samples of "
      "a foot-mounted IMU (IMU), corrects them with a zero-velocity update in every "
      "stance phase, and publishes each tag's position with covariance, velocity and "
      "heading (POSE_INS). Start poses and parameters: the site's estimators.ins.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.tags = true});
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string out_channel = opts.channel(ips::channel::kPoseIns);
    ips::ins::InsEstimator est([&](const ips::pose_t& p) { node.publish(out_channel, p); });
    ips::provide_site(node, [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    node.subscribe<ips::imu_t>(
        opts.channel(ips::channel::kImu),
        [&](const ips::imu_t& m, const std::string&) {
          if (tag_filter.pass(m.device_id)) est.on_imu(m);
        });
    // Samples that gave no pose, by reason, in HEALTH (drops, last_error) once a second.
    // A tag whose IMU shows no stance phases (not on a foot) gets no POSE_INS: said while it
    // lasts. ZUPT innovations against zupt_sigma_mps: HEALTH's consistency.
    ips::DropHealth drop_health;
    ips::ConsistencyHealth consistency_health;
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons());
      // An IMU the site declares on a foot (estimators.ins.foot_imus) without stance phases is a
      // fault; any other is most likely a phone, said as a note (HEALTH stays OK).
      const std::string stance = est.foot_problems();
      if (stance.empty())
        node.end_lasting_error("ins-stance");
      else
        node.report_lasting_error("ins-stance", stance);
      const std::string other = est.other_imu_notes();
      if (other.empty())
        node.end_note("ins-not-a-foot");
      else
        node.report_note("ins-not-a-foot", other);
      consistency_health.report(node, est.consistency());
    });
    return node.run();
  });
}
