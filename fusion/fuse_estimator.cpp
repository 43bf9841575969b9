// FuseEstimator (fuse_estimator.hpp): its parameters and site, its output (POSE_FUSED) and its
// account of what was not fused. The inputs, one file per measurement model: fuse_ranges.cpp,
// fuse_tdoa.cpp, fuse_angles.cpp, fuse_displacements.cpp, fuse_gyro.cpp, fuse_heights.cpp,
// fuse_poses.cpp; the tracks and their start: fuse_tracks.cpp; the history that fuses late
// messages in order: fuse_history.cpp.
#include "fusion/fuse_estimator.hpp"

#include <cmath>
#include <limits>

#include "core/geometry.hpp"

namespace ips::fusion {

FuseParams parse_fuse_params(const YamlField& s) {
  FuseParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of fuse parameters");
  s.check_keys({"force_3d", "range_sigma_m", "gate_sigma", "tdoa_gate_sigma", "angle_gate_sigma", "nlos_gate_sigma",
                "nlos_downweight_sigma", "accel_psd", "displacement", "gyro_turns", "displacement_sigma_per_m",
                "displacement_sigma_min_m", "heading_bias_sigma_deg",
                "heading_bias_walk_deg_per_sqrt_s", "start_sigma_m", "height_gate_sigma",
                "pose_gate_sigma", "pose_cov_scale", "epoch_window_s", "max_delay_s", "max_gap_s", "reinit_after_rejections",
                "publish_period_s", "max_tags", "learn_noise", "nlos_power_db", "nlos_power_los_db", "nlos_power_var_scale",
                "range_bias_m", "range_bias_per_m"});
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  p.force_3d = s.get_bool("force_3d", p.force_3d);
  p.range_sigma_m = s.get_double_in("range_sigma_m", p.range_sigma_m, 1e-4, 100);
  p.gate_sigma = s.get_double_in("gate_sigma", p.gate_sigma, 0.5, 1e6);
  p.tdoa_gate_sigma = s.get_double_in("tdoa_gate_sigma", p.tdoa_gate_sigma, 0.5, 1e6);
  p.angle_gate_sigma = s.get_double_in("angle_gate_sigma", p.angle_gate_sigma, 0.5, 1e6);
  p.nlos_gate_sigma = s.get_double_in("nlos_gate_sigma", p.nlos_gate_sigma, 0.5, 1e6);
  p.nlos_downweight_sigma =
      s.get_double_in("nlos_downweight_sigma", p.nlos_downweight_sigma, 0.1, 1e6);
  p.nlos_power_db = s.get_double_in("nlos_power_db", p.nlos_power_db, 0, 100);
  p.nlos_power_los_db = s.get_double_in("nlos_power_los_db", p.nlos_power_los_db, 0, 100);
  p.nlos_power_var_scale =
      s.get_double_in("nlos_power_var_scale", p.nlos_power_var_scale, 1, 1e6);
  p.range_bias_m = s.get_double_in("range_bias_m", p.range_bias_m, -10, 10);
  p.range_bias_per_m = s.get_double_in("range_bias_per_m", p.range_bias_per_m, -0.1, 0.1);
  p.accel_psd = s.get_double_in("accel_psd", p.accel_psd, 1e-6, 1000);
  const std::string d = s.get_string("displacement", "auto");
  if (d == "auto") p.displacement = DisplacementSource::kAuto;
  else if (d == "ins_module") p.displacement = DisplacementSource::kInsModule;
  else if (d == "pose_ins") p.displacement = DisplacementSource::kPoseIns;
  else if (d == "step") p.displacement = DisplacementSource::kStep;
  else if (d == "none") p.displacement = DisplacementSource::kNone;
  else s["displacement"].fail("expected auto, ins_module, pose_ins, step or none");
  p.gyro_turns = s.get_bool("gyro_turns", p.gyro_turns);
  p.displacement_sigma_per_m =
      s.get_double_in("displacement_sigma_per_m", p.displacement_sigma_per_m, 0, 10);
  p.displacement_sigma_min_m =
      s.get_double_in("displacement_sigma_min_m", p.displacement_sigma_min_m, 1e-6, 100);
  p.heading_bias_sigma_deg =
      s.get_double_in("heading_bias_sigma_deg", p.heading_bias_sigma_deg, 0, 180);
  p.heading_bias_walk_deg_per_sqrt_s = s.get_double_in(
      "heading_bias_walk_deg_per_sqrt_s", p.heading_bias_walk_deg_per_sqrt_s, 0, 100);
  p.start_sigma_m = s.get_double_in("start_sigma_m", p.start_sigma_m, 1e-4, 1e4);
  p.height_gate_sigma = s.get_double_in("height_gate_sigma", p.height_gate_sigma, 0.5, 1e6);
  p.pose_gate_sigma = s.get_double_in("pose_gate_sigma", p.pose_gate_sigma, 0.5, 1e6);
  p.pose_cov_scale = s.get_double_in("pose_cov_scale", p.pose_cov_scale, 0.01, 1e6);
  p.epoch_window_s = s.get_double_in("epoch_window_s", p.epoch_window_s, 0.001, 60);
  p.max_delay_s = s.get_double_in("max_delay_s", p.max_delay_s, 0, 60);
  p.max_gap_s = s.get_double_in("max_gap_s", p.max_gap_s, 0.1, 3600);
  p.reinit_after_rejections =
      static_cast<int>(s.get_int_in("reinit_after_rejections", p.reinit_after_rejections, 1,
                                    1000000));
  p.publish_period_s = s.get_double_in("publish_period_s", p.publish_period_s, 0, 3600);
  p.max_tags = static_cast<int>(s.get_int_in("max_tags", p.max_tags, 1, 100000));
  return p;
}

FuseEstimator::FuseEstimator(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)),
      source_(std::move(source_name)),
      tdoa_([this](const pose_t& p) { on_hosted_fix(p); }, [](const clock_t&) {}, source_),
      aoa_([this](const pose_t& p) { on_hosted_fix(p); }, source_) {
  tdoa_.set_epoch_sink([this](const uwb_tdoa::TdoaEpoch& e) { on_tdoa_epoch(e); }, true);
  aoa_.set_epoch_sink([this](const aoa::AoaEpochAngles& e) { on_aoa_epoch(e); }, true);
}

void FuseEstimator::set_site(const Site& site) {
  // The ranging noise is the UWB system's: estimators.uwb_twr's unless estimators.fuse says.
  FuseParams params = parse_fuse_params(site.estimator_params("fuse"));
  const YamlField fuse = site.estimator_params("fuse");
  const YamlField twr = site.estimator_params("uwb_twr");
  if (!fuse["range_sigma_m"].defined() && twr["range_sigma_m"].defined())
    params.range_sigma_m = twr.get_double_in("range_sigma_m", params.range_sigma_m, 1e-4, 100);
  // The same device's NLOS indicator and range bias: estimators.uwb_twr's unless fuse says.
  const auto from_twr = [&](const char* key, double& value, double lo, double hi) {
    if (!fuse[key].defined() && twr[key].defined()) value = twr.get_double_in(key, value, lo, hi);
  };
  from_twr("nlos_power_db", params.nlos_power_db, 0, 100);
  from_twr("nlos_power_los_db", params.nlos_power_los_db, 0, 100);
  from_twr("nlos_power_var_scale", params.nlos_power_var_scale, 1, 1e6);
  from_twr("range_bias_m", params.range_bias_m, -10, 10);
  from_twr("range_bias_per_m", params.range_bias_per_m, -0.1, 0.1);
  if (params.nlos_power_db > 0 && params.nlos_power_los_db >= params.nlos_power_db)
    throw ConfigError("estimators.fuse.nlos_power_los_db must be below nlos_power_db");
  // The radios' per-pair offsets (configured, learned): estimators.uwb_twr's settings.
  radio_ = uwb_twr::parse_twr_params(twr);
  // TDoA blinks: the clock synchronisation of ips-uwb-tdoa with its parameters; BLE angles:
  // ips-aoa's calibration and grouping with its.
  tdoa_.set_site(site);
  aoa_.set_site(site);
  frames_.clear();
  for (const Anchor& a : site.anchors) frames_.push_back(aoa::anchor_frame(a));
  params_ = params;
  ConsistencyOptions co;
  co.learn = params_.learn_noise;
  consistency_ = ConsistencyMonitor(co);
  // Ranges learn their anchor's noise; angles, heights and poses come with their own sigma,
  // which is their source's to get right: checked, not scaled.
  consistency_.monitor_only("ANGLE");
  consistency_.monitor_only("HEIGHT");
  consistency_.monitor_only("POSE");
  range_setting_ = setting_text("range_sigma_m", params_.range_sigma_m);
  site_ = site;
  tracks_.clear();
}

std::optional<FuseFilter> FuseEstimator::filter(const std::string& tag_id) const {
  const auto it = tracks_.find(tag_id);
  if (it == tracks_.end() || !it->second.initialised) return std::nullopt;
  return it->second.state.filter;
}

double FuseEstimator::tag_height(const std::string& tag_id) const {
  const Tag* tag = site_->find_tag(tag_id);
  return tag ? tag->height_m : std::numeric_limits<double>::quiet_NaN();
}

bool FuseEstimator::planar_for(const std::string& tag_id) const {
  return !params_.force_3d && std::isfinite(tag_height(tag_id));
}

void FuseEstimator::maybe_publish(const std::string& tag_id, Track& t) {
  // A start from a prior that the first absolute measurement gated: not published until one
  // agrees with it or enough refute it (count_absolute), so that no estimate says 0.3 m around a
  // position metres off.
  if (t.state.prior_only && t.state.rejections > 0) return;
  // Nor, for its first second, while no fix of the ranges has checked it (check_against_ranges):
  // a process restarted mid-walk would publish the site's start pose. (A tag without ranges, or
  // with too few for a checked fix, is published after that second.)
  constexpr utime_t kPriorUncheckedS = 1'000'000;
  if (t.prior_unchecked && t.state.t - t.started_at < kPriorUncheckedS) return;
  if (!t.tally.due(t.state.t, params_.publish_period_s)) return;
  const FuseFilter& f = t.state.filter;
  pose_t p;
  p.utime = t.state.t;
  std::string names;
  auto name = [&](uint32_t bit, const char* text) {
    if (t.sources & bit) names += (names.empty() ? "" : "+") + std::string(text);
  };
  // The dead-reckoning source moves the state between all the other messages.
  if (t.dr_bit != 0 && t.have_last_dr && t.state.t - t.last_dr_t <= s_to_utime(1.0))
    t.sources |= t.dr_bit;
  name(kSrcRange, "uwb_range");
  name(kSrcTdoa, "uwb_tdoa");
  name(kSrcAngles, "ble_aoa");
  name(kSrcInsModule, "ins_module");
  name(kSrcPoseIns, "pose_ins");
  name(kSrcStep, "step");
  name(kSrcAltitude, "altitude");
  for (const auto& k : t.pose_kinds) names += (names.empty() ? "" : "+") + k;
  p.source = names.empty() ? source_ : source_ + ":" + names;
  p.tag_id = tag_id;
  for (int i = 0; i < 3; ++i) {
    p.position[i] = f.x(i);
    p.velocity[i] = f.x(kVel + i);
    for (int j = 0; j < 3; ++j) p.position_cov[3 * i + j] = f.P(i, j);
  }
  // A consistent fix of the ranges far from the track, not yet confirmed by the next ones
  // (check_against_ranges): the tag may be there. Until the track restarts there or a fix agrees
  // with it again (at most kFarFixSpan), the published covariance holds both places, so that no
  // pose claims 0.1 m while the ranges say the tag is metres away.
  if (t.lost_checks > 0 && t.state.t - t.last_far_fix <= kFarFixSpan) {
    const Eigen::Matrix2d spread = t.far_fix_offset * t.far_fix_offset.transpose();
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) p.position_cov[3 * i + j] += spread(i, j);
    ++stats_.poses_doubted;
  }
  const double speed = std::hypot(f.x(kVel), f.x(kVel + 1));
  p.heading_rad = speed > 0.2 ? std::atan2(f.x(kVel + 1), f.x(kVel))
                              : std::numeric_limits<double>::quiet_NaN();
  t.tally.finish(p, f.planar, t.state.t);
  t.sources = 0;
  t.pose_kinds.clear();
  ++stats_.poses_out;
  sink_(p);
}

DropReasons FuseEstimator::drop_reasons() const {
  const FuseStats& s = stats_;
  DropReasons d;
  d.add(DropReason::kNoSite, s.dropped_no_site);
  d.add(DropReason::kInvalid, s.dropped_invalid);
  d.add(DropReason::kNoReference, s.dropped_relative_height);
  d.add(DropReason::kUnknownAnchor, s.dropped_unknown_anchor);
  d.add(DropReason::kSurveyRange, s.anchor_pair_ranges);
  d.add(DropReason::kLate, s.dropped_late + s.dropped_imu_late + s.dropped_dr_late);
  d.add(DropReason::kDuplicate,
        s.dropped_imu_repeated + s.dropped_dr_repeated + s.dropped_range_repeated);
  d.add(DropReason::kReordered, s.dropped_imu_reordered + s.dropped_dr_reordered);
  d.add(DropReason::kTimeJump, guard_.dropped());
  d.add(DropReason::kTooManyTags, s.dropped_too_many_tags);
  d.add(DropReason::kSuperseded, s.poses_superseded);
  d.add(DropReason::kInitialising, s.waiting_start);
  d.add(DropReason::kGated, s.ranges_rejected + s.tdoa_epochs_rejected + s.angles_rejected +
                                s.heights_rejected + s.poses_rejected);
  // The receptions the hosted blink and angle grouping refused; how its own trackers fare (gated,
  // no fix yet) is theirs, not the fusion's.
  for (const DropReasons& hosted : {tdoa_.drop_reasons(), aoa_.drop_reasons()}) {
    for (size_t i = 0; i < DropReasons::kNumReasons; ++i) {
      const auto r = static_cast<DropReason>(i);
      if (r == DropReason::kGated || r == DropReason::kInitialising ||
          r == DropReason::kTooFewAnchors || r == DropReason::kNoFix)
        continue;
      d.add(r, hosted.count(r));
    }
  }
  return d;
}

bool FuseEstimator::have_site_for_raw() {
  if (site_) return true;
  ++stats_.messages_in;
  ++stats_.dropped_no_site;
  return false;
}

}  // namespace ips::fusion
