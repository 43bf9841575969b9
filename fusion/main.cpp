// ips-fuse: one best estimate per tag from every sensor (POSE_FUSED): UWB ranges and TDoA
// blinks, foot-INS or PDR displacements, the tag's gyro, barometric heights and other
// estimators' poses (fuse_estimator.hpp).
#include <spdlog/spdlog.h>

#include <algorithm>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/message_clock.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/tag_filter.hpp"
#include "fusion/fuse_estimator.hpp"

namespace {
constexpr const char* kProgram = "ips-fuse";
}

int main(int argc, char** argv) {
  CLI::App app{
      "ips-fuse: hybrid per-tag fusion. One EKF per tag takes UWB two-way ranges (UWB_RANGE) "
      "and TDoA blinks (UWB_RX, with ips-uwb-tdoa's clock synchronisation) and BLE angles of "
      "arrival (BLE_AOA, with ips-aoa's calibration), tightly coupled; a dead-reckoning source's displacements as its motion (INS_MODULE, POSE_INS or "
      "STEP, with the source's heading bias estimated), the tag's gyro (IMU) turning it between "
      "them; barometric heights (ALTITUDE); other estimators' poses (POSE_TDOA and POSE_AOA "
      "until blinks and angles come). Each update is gated, late messages are fused in time order; publishes "
      "POSE_FUSED with covariance, its source naming what contributed. Parameters: the site's "
      "estimators.fuse (and estimators.uwb_tdoa for the clocks, estimators.aoa for the "
      "angles).",
      kProgram};
  ips::CommonOptions opts;
  // ips-fuse reads its bus itself where the kernel grants the receive buffer: at 100 tags it then
  // took 29 to 34 % of a core against liblcm's receiver's 56 to 66 %, and added a p99 of 0.3 to
  // 0.5 ms against 2.0 to 2.5 ms (docs/development.md#the-bus-at-scale).
  opts.lcm_receiver = "auto";
  ips::add_common_options(app, opts, {.tags = true});
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors(kProgram, [&] {
    ips::Node node(kProgram, opts);
    // --tags/--shard: other tags' messages skipped before the estimator (core/tag_filter.hpp).
    ips::TagFilter tag_filter(node, opts);
    const std::string out = opts.channel(ips::channel::kPoseFused);
    ips::fusion::FuseEstimator est([&](const ips::pose_t& p) { node.publish(out, p); });
    // A tag's second dead-reckoning source, left unused on purpose: one info line, no fault.
    est.set_note_sink([](const std::string& text) { spdlog::info("{}: {}", kProgram, text); });
    ips::provide_site(node, [&](const ips::Site& site) {
      tag_filter.set_site(site);
      est.set_site(site);
    });
    // Inputs that were not fused, by reason, in HEALTH (drops, last_error) once a second.
    ips::DropHealth drop_health;
    ips::ConsistencyHealth consistency_health;
    // A track's estimates that were off, and why, in HEALTH's last_error when its counter grew:
    //  - a track restarted after a gap (the process stopped, the machine swapped, the tag out
    //    of reach), the pose flagged REINITIALISED;
    //  - a start from the site's start pose or a dead-reckoning position that the first ranges
    //    or angles refuted (this process started mid-walk);
    //  - a running track that had lost its tag (gating ranges that agreed on another place);
    //  - a dead-reckoning source that restarted from a new origin (its jump not taken).
    struct Reported {
      int64_t seen = 0;
      bool grew(int64_t now) { return now > seen ? (seen = now, true) : false; }
    } gap_restarts, prior_refuted, lost_restarts, source_restarts;
    node.add_timer(1.0, [&] {
      drop_health.report(node, est.drop_reasons());
      consistency_health.report(node, est.consistency());
      const ips::fusion::FuseStats& s = est.stats();
      if (gap_restarts.grew(s.gap_restarts)) node.report_error(est.last_gap());
      if (prior_refuted.grew(s.prior_refuted))
        node.report_error(std::to_string(s.prior_refuted) +
                          " track start(s) from a prior (the site's start pose or a "
                          "dead-reckoning position) refuted by the first measurements; started "
                          "afresh");
      if (lost_restarts.grew(s.lost_restarts)) node.report_error(est.last_lost());
      if (source_restarts.grew(s.source_restarts)) node.report_error(est.last_source_restart());
    });
    node.subscribe<ips::uwb_range_t>(opts.channel(ips::channel::kUwbRange),
                                     [&](const ips::uwb_range_t& m, const std::string&) {
                                       if (tag_filter.pass(m.tag_id)) est.on_range(m);
                                     });
    node.subscribe<ips::uwb_rx_t>(opts.channel(ips::channel::kUwbRx),
                                  [&](const ips::uwb_rx_t& m, const std::string&) {
                                    // A sync master's broadcast serves every tag: it always passes.
                                    if (m.is_sync || tag_filter.pass(m.sender_id)) est.on_rx(m);
                                  });
    node.subscribe<ips::uwb_tdoa_t>(opts.channel("UWB_TDOA"),  // docs/channels.md
                                    [&](const ips::uwb_tdoa_t& m, const std::string&) {
                                      if (tag_filter.pass(m.tag_id)) est.on_pair(m);
                                    });
    // An advertisement's angles are fused when its epoch closes: at the next event, or when the
    // bus has been quiet for the epoch window (message time estimated from the host's monotonic
    // clock, which a step of the wall clock does not move).
    ips::MessageClock angle_clock;
    node.subscribe<ips::ble_aoa_t>(opts.channel(ips::channel::kBleAoa),
                                   [&](const ips::ble_aoa_t& m, const std::string&) {
                                     if (!tag_filter.pass(m.tag_id)) return;
                                     est.on_aoa(m);
                                     // The newest time taken (a stamp far ahead is not).
                                     angle_clock.saw(est.newest_angle_utime());
                                   });
    node.add_timer(0.02, [&] {
      if (const ips::utime_t now = angle_clock.now()) est.flush_angles(now);
    });
    node.subscribe<ips::imu_t>(opts.channel(ips::channel::kImu),
                               [&](const ips::imu_t& m, const std::string&) {
                                 if (tag_filter.pass(m.device_id)) est.on_imu(m);
                               });
    node.subscribe<ips::pose_t>(opts.channel(ips::channel::kInsModule),
                                [&](const ips::pose_t& m, const std::string&) {
                                  if (tag_filter.pass(m.tag_id)) est.on_ins_module(m);
                                });
    node.subscribe<ips::pose_t>(opts.channel(ips::channel::kPoseIns),
                                [&](const ips::pose_t& m, const std::string&) {
                                  if (tag_filter.pass(m.tag_id)) est.on_pose_ins(m);
                                });
    node.subscribe<ips::step_t>(opts.channel(ips::channel::kStep),
                                [&](const ips::step_t& m, const std::string&) {
                                  if (tag_filter.pass(m.tag_id)) est.on_step(m);
                                });
    node.subscribe<ips::altitude_t>(opts.channel(ips::channel::kAltitude),
                                    [&](const ips::altitude_t& m, const std::string&) {
                                      if (tag_filter.pass(m.tag_id)) est.on_altitude(m);
                                    });
    for (const char* kind : {ips::channel::kPoseTdoa, ips::channel::kPoseAoa}) {
      const std::string name = kind;
      node.subscribe<ips::pose_t>(opts.channel(kind),
                                  [&, name](const ips::pose_t& m, const std::string&) {
                                    if (!tag_filter.pass(m.tag_id)) return;
                                    est.on_pose(m, name == ips::channel::kPoseTdoa ? "tdoa" : "aoa");
                                  });
    }
    return node.run();
  });
}
