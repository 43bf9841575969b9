#include "estimators/ins/ins_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/geometry.hpp"
#include "estimators/ins/models/zero_velocity.hpp"

namespace ips::ins {

namespace {
// A setting or duration as a user writes it: "0.01", "5.2".
std::string format_setting(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}
std::string format_seconds(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f", v);
  return b;
}
// Beyond any MEMS IMU's range (16 g, 2000 deg/s is typical): a corrupt sample, not a motion.
constexpr double kMaxAccelMps2 = 1000.0;
constexpr double kMaxRateRps = 100.0;
// The filter's yaw is relative to the start heading, so it starts (nearly) exact: OpenShoe's
// sigma_initial_att. Yaw is unobservable from ZUPTs; given a larger variance (the start
// heading's uncertainty, 1 deg) the ZUPTs rotate the track by whatever velocity error the
// swing left (on foot-openshoe: the loop's end 1.04 m from its start instead of 0.44 m).
const double kRelativeYawSigmaRad = deg_to_rad(0.1);
constexpr double kZuptNisPeriodS = 0.05;
}  // namespace

InsParams parse_ins_params(const YamlField& s) {
  InsParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of ins parameters");
  s.check_keys({"gravity_mps2", "detector_window_samples", "detector_accel_sigma_mps2",
                "detector_gyro_sigma_dps", "detector_threshold", "min_stance_s", "alignment_s",
                "accel_noise_mps2", "gyro_noise_dps", "zupt_sigma_mps", "initial_position_sigma_m",
                "initial_velocity_sigma_mps", "initial_tilt_sigma_deg", "initial_heading_sigma_deg",
                "min_swing_s", "min_swing_rate_dps", "max_swing_s", "stance_timeout_s", "max_gap_s", "publish_period_s", "max_tags", "foot_imus"});
  // Every parameter is bounded: a SITE message on the bus is outside input.
  auto bounded = [&](const char* key, double v, double lo, double hi) {
    v = s.get_double(key, v);
    if (!(v >= lo && v <= hi))
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
  };
  auto bounded_int = [&](const char* key, int v, int lo, int hi) {
    const int64_t got = s.get_int(key, v);
    if (got < lo || got > hi)
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return static_cast<int>(got);
  };
  p.gravity_mps2 = bounded("gravity_mps2", p.gravity_mps2, 9.7, 9.9);
  p.detector.gravity_mps2 = p.gravity_mps2;
  p.detector.window_samples = bounded_int("detector_window_samples", p.detector.window_samples, 1,
                                          StanceDetector::kMaxWindow);
  p.detector.accel_sigma_mps2 =
      bounded("detector_accel_sigma_mps2", p.detector.accel_sigma_mps2, 1e-5, 100);
  p.detector.gyro_sigma_rps = deg_to_rad(
      bounded("detector_gyro_sigma_dps", rad_to_deg(p.detector.gyro_sigma_rps), 1e-5, 1000));
  p.detector.threshold = bounded("detector_threshold", p.detector.threshold, 1e-6, 1e15);
  p.min_stance_s = bounded("min_stance_s", p.min_stance_s, 0, 10);
  p.alignment_s = bounded("alignment_s", p.alignment_s, 0.001, 3600);
  p.min_swing_s = bounded("min_swing_s", p.min_swing_s, 0, 10);
  p.min_swing_rate_dps = bounded("min_swing_rate_dps", p.min_swing_rate_dps, 0, 10000);
  p.max_swing_s = bounded("max_swing_s", p.max_swing_s, 0.01, 3600);
  p.stance_timeout_s = bounded("stance_timeout_s", p.stance_timeout_s, 0.01, 3600);
  p.accel_noise_mps2 = bounded("accel_noise_mps2", p.accel_noise_mps2, 1e-6, 100);
  p.gyro_noise_rps =
      deg_to_rad(bounded("gyro_noise_dps", rad_to_deg(p.gyro_noise_rps), 1e-6, 1000));
  p.zupt_sigma_mps = bounded("zupt_sigma_mps", p.zupt_sigma_mps, 1e-5, 10);
  p.initial_position_sigma_m =
      bounded("initial_position_sigma_m", p.initial_position_sigma_m, 1e-6, 1e4);
  p.initial_velocity_sigma_mps =
      bounded("initial_velocity_sigma_mps", p.initial_velocity_sigma_mps, 1e-6, 100);
  p.initial_tilt_sigma_deg = bounded("initial_tilt_sigma_deg", p.initial_tilt_sigma_deg, 1e-6, 90);
  p.initial_heading_sigma_deg =
      bounded("initial_heading_sigma_deg", p.initial_heading_sigma_deg, 1e-6, 180);
  p.max_gap_s = bounded("max_gap_s", p.max_gap_s, 1e-4, 60);
  p.publish_period_s = bounded("publish_period_s", p.publish_period_s, 0, 3600);
  p.max_tags = bounded_int("max_tags", p.max_tags, 1, 100000);
  if (const YamlField feet = s["foot_imus"]; feet.defined()) {
    if (!feet.is_sequence()) feet.fail("expected a list of IMU device ids, e.g. [foot1, foot2]");
    if (feet.size() > 100000) feet.fail("at most 100000 ids");
    for (size_t i = 0; i < feet.size(); ++i) p.foot_imus.push_back(feet[i].as_string());
  }
  return p;
}

InsEstimator::InsEstimator(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)), source_(std::move(source_name)) {}

void InsEstimator::set_site(const Site& site) {
  InsParams params = parse_ins_params(site.estimator_params("ins"));
  params_ = params;
  site_ = site;
  tracks_.clear();
  consistency_ = ConsistencyMonitor();
  zupt_setting_ = setting_text("zupt_sigma_mps", params_.zupt_sigma_mps);
}

std::optional<InsTrackSummary> InsEstimator::track(const std::string& tag_id) const {
  const auto it = tracks_.find(tag_id);
  if (it == tracks_.end()) return std::nullopt;
  const Track& t = it->second;
  InsTrackSummary s;
  s.navigating = t.phase == Phase::kNavigating;
  s.strides = t.strides;
  s.distance_m = t.distance_m;
  s.position = t.filter.position();
  s.velocity = t.filter.velocity();
  s.heading_rad = t.filter.heading_rad();
  s.gyro_bias_rps = t.gyro_bias;
  s.in_stance = t.in_stance;
  return s;
}

void InsEstimator::on_imu(const imu_t& m) {
  ++stats_.samples_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  const Eigen::Vector3d f(m.accel[0], m.accel[1], m.accel[2]);
  const Eigen::Vector3d w_raw(m.gyro[0], m.gyro[1], m.gyro[2]);
  if (!plausible_utime(m.utime) || m.device_id.empty() || !f.allFinite() || !w_raw.allFinite() ||
      f.norm() > kMaxAccelMps2 || w_raw.norm() > kMaxRateRps) {
    ++stats_.dropped_invalid;
    return;
  }
  // A stamp far from the device's timeline waits for confirmation (core/time_guard.hpp); a clock
  // that went back restarts the device's track.
  if (!guard_.admit(m.device_id, m.utime, [this, m] { on_imu(m); },
                    [this, &m] { tracks_.erase(m.device_id); })) {
    --stats_.samples_in;  // counted when handed over again, or dropped as a time jump
    return;
  }
  auto it = tracks_.find(m.device_id);
  if (it == tracks_.end()) {
    if (static_cast<int>(tracks_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.device_id).first;
    Track& fresh = it->second;
    fresh.detector = StanceDetector(params_.detector);
    fresh.first_utime = m.utime;
    const Tag* tag = site_->find_tag(m.device_id);
    if (tag && tag->has_start()) {
      fresh.start.position_m = tag->start_position;
      if (std::isfinite(tag->start_heading_rad)) fresh.start.heading_rad = tag->start_heading_rad;
    } else {
      ++stats_.tags_without_start_pose;
    }
  }
  Track& t = it->second;
  if (t.last_utime != 0 && m.utime <= t.last_utime) {
    count_out_of_turn(m.utime, t.last_utime, s_to_utime(params_.max_gap_s), stats_.dropped_repeated,
                      stats_.dropped_reordered, stats_.dropped_out_of_order);
    return;
  }
  const double dt = t.last_utime != 0 ? utime_to_s(m.utime - t.last_utime) : 0.0;
  const bool gap = t.last_utime != 0 && dt > params_.max_gap_s;
  t.last_utime = m.utime;
  if (gap) ++stats_.gaps;

  const Eigen::Vector3d w = w_raw - t.gyro_bias;
  const bool stance = t.detector.add(f, w);
  if (stance) ++stats_.stance_samples;

  if (t.phase == Phase::kAligning || t.refining) {
    t.in_stance = stance;
    if (stance) {
      if (t.still_samples == 0) t.still_since = m.utime;
      t.accel_sum += f;
      t.gyro_sum += w_raw;
      ++t.still_samples;
      ++stats_.samples_used;
      if (t.phase == Phase::kAligning &&
          m.utime - t.still_since >= s_to_utime(params_.alignment_s)) {
        t.phase = Phase::kNavigating;
        t.refining = true;
        ++stats_.alignments;
      }
      if (t.phase == Phase::kAligning) ++stats_.samples_aligning;
      if (t.refining) {
        // Still at the start: the longer the still period, the better the bias and the tilt.
        align(t);
        t.tally.add(0.0);  // a still sample is a zero-velocity measurement
        publish(t, m.device_id, m.utime);
      }
      return;
    }
    if (t.phase == Phase::kAligning) {
      ++stats_.samples_aligning;
      if (t.still_samples > 0) ++stats_.alignment_restarts;
      t.accel_sum.setZero();
      t.gyro_sum.setZero();
      t.still_samples = 0;
      return;
    }
    // The foot moves: navigation proper starts from this sample. The still start is a believed
    // stance (a break shorter than min_swing_s continues it).
    t.refining = false;
    t.in_stance = false;
    t.stance_since = t.still_since;
    t.stance_counted = true;
    t.stance_believed = true;
    t.last_believed_utime = t.last_stance_utime = m.utime;
    t.swing_peak_rps = 0;
    t.have_stance_position = true;
    t.last_stance_position = t.filter.position();
  }
  if (gap) {
    // Samples are missing: integrating across the gap would invent a motion. The next stance
    // corrects the velocity.
    t.in_stance = false;
    return;
  }
  navigate(t, m, f, w, dt, stance);
}

void InsEstimator::align(Track& t) {
  const double n = static_cast<double>(t.still_samples);
  const Eigen::Vector3d f_mean = t.accel_sum / n;
  t.gyro_bias = t.gyro_sum / n;
  // Roll and pitch: the rotation that takes the mean specific force to +z (the same tilt as
  // 001's atan formulas, without their axis conventions); yaw: the start heading of the body's
  // y axis.
  const Eigen::Quaterniond tilt =
      Eigen::Quaterniond::FromTwoVectors(f_mean, Eigen::Vector3d::UnitZ());
  StrapdownFilter probe;
  probe.set_attitude(tilt);
  const double yaw = wrap_angle(t.start.heading_rad - probe.heading_rad());
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())) * tilt;
  ErrorCov P0 = ErrorCov::Zero();
  const double sp = params_.initial_position_sigma_m, sv = params_.initial_velocity_sigma_mps;
  const double st = deg_to_rad(params_.initial_tilt_sigma_deg);
  const double sh = deg_to_rad(params_.initial_heading_sigma_deg);
  for (int i = 0; i < 3; ++i) {
    P0(kPos + i, kPos + i) = sp * sp;
    P0(kVel + i, kVel + i) = sv * sv;
  }
  P0(kAtt, kAtt) = P0(kAtt + 1, kAtt + 1) = st * st;
  (void)sh;  // the start heading's uncertainty is added to the published covariance instead
  P0(kAtt + 2, kAtt + 2) = kRelativeYawSigmaRad * kRelativeYawSigmaRad;
  t.filter.reset(q, t.start.position_m, P0);
}

void InsEstimator::navigate(Track& t, const imu_t& m, const Eigen::Vector3d& f,
                            const Eigen::Vector3d& w, double dt, bool stance) {
  t.filter.propagate(f, w, dt, params_.gravity_mps2, params_.accel_noise_mps2,
                     params_.gyro_noise_rps);
  ++stats_.samples_used;
  if (stance) {
    if (!t.in_stance) {
      t.in_stance = true;
      // A break shorter than min_swing_s (the detector flickering at the edge of its threshold,
      // a heel roll) continues the stance; a step's swing lasts ~0.4 s.
      const bool blip = t.stance_counted &&
                        m.utime - t.last_stance_utime <= s_to_utime(params_.min_swing_s);
      if (blip) {
        t.swing_peak_rps = 0;
      } else {
        t.stance_since = m.utime;
        t.stance_counted = false;
      }
    }
    t.last_stance_utime = m.utime;
    if (m.utime - t.stance_since >= s_to_utime(params_.min_stance_s)) {
      const ZeroVelocityResult r = zero_velocity_update(t.filter, params_.zupt_sigma_mps);
      // The ZUPT noise is the foot's own velocity in stance (micro-motion, heel roll), which the
      // IMU sees: innovations far above it say zupt_sigma_mps is too small. At most one NIS per
      // kZuptNisPeriodS, so that the monitor's window spans seconds, not the last 0.4 s at 820 Hz.
      if (m.utime - t.last_nis_utime >= s_to_utime(kZuptNisPeriodS)) {
        t.last_nis_utime = m.utime;
        consistency_.add_nis("ZUPT", m.device_id, utime_to_s(m.utime), r.nis, 3, false,
                             zupt_setting_);
      }
      if (r.accepted) {
        ++stats_.zupts;
        t.tally.add(r.position_correction_m);
      } else {
        ++stats_.zupts_failed;
      }
      if (!t.stance_counted) {
        t.stance_counted = true;
        // Believed when the swing before it turned the foot as a stride does.
        t.stance_believed = t.swing_peak_rps >= deg_to_rad(params_.min_swing_rate_dps);
        if (!t.stance_believed) ++stats_.weak_swings;
        t.swing_peak_rps = 0;
        ++t.strides;
        const Eigen::Vector3d& p = t.filter.position();
        t.distance_m += horizontal_distance(p, t.last_stance_position);
        t.last_stance_position = p;
      }
      // A foot that stands still long enough is a foot at rest whatever came before.
      if (m.utime - t.stance_since >= s_to_utime(params_.alignment_s)) t.stance_believed = true;
      if (t.stance_believed) t.last_believed_utime = m.utime;
    }
  } else {
    t.in_stance = false;
    t.swing_peak_rps = std::max(t.swing_peak_rps, w.norm());
  }
  publish(t, m.device_id, m.utime);
}

bool InsEstimator::gait_believed(const Track& t) const {
  if (t.refining) return true;
  if (!t.stance_believed) return false;  // the last stance came after a weak swing
  if (t.in_stance && t.stance_counted) return true;
  return t.last_utime - t.last_believed_utime <= s_to_utime(params_.max_swing_s);
}

std::string InsEstimator::problems() const { return problems_of(true, false); }
std::string InsEstimator::foot_problems() const { return problems_of(false, true); }
std::string InsEstimator::other_imu_notes() const { return problems_of(false, false); }

std::string InsEstimator::problems_of(bool all, bool foot) const {
  std::string out;
  const utime_t limit = s_to_utime(params_.stance_timeout_s);
  for (const auto& [id, t] : tracks_) {
    if (!all && foot != (std::find(params_.foot_imus.begin(), params_.foot_imus.end(), id) !=
                         params_.foot_imus.end()))
      continue;
    std::string p;
    if (t.phase == Phase::kAligning) {
      if (t.last_utime - t.first_utime > limit)
        p = id + ": never still for alignment_s " + format_setting(params_.alignment_s) +
            " in " + format_seconds(utime_to_s(t.last_utime - t.first_utime)) +
            " s of IMU data (not a foot-mounted IMU, or never at rest?); no POSE_INS";
    } else if (!t.refining && t.last_utime - t.last_believed_utime > limit) {
      p = id + ": no foot stance phase for " +
          format_seconds(utime_to_s(t.last_utime - t.last_believed_utime)) +
          " s (the IMU moves but never rests like a foot between strides: hand-held or in a "
          "pocket?); no POSE_INS";
    }
    if (p.empty()) continue;
    if (!out.empty()) out += "; ";
    out += p;
  }
  return out;
}

void InsEstimator::publish(Track& t, const std::string& tag_id, utime_t utime) {
  if (!t.tally.due(utime, params_.publish_period_s)) return;
  if (!gait_believed(t)) {
    // Not a foot's gait: an unaided or wrongly aided INS is confident nonsense. Said in
    // problems() after stance_timeout_s.
    pose_t withheld;
    t.tally.finish(withheld, false, utime);
    ++stats_.poses_withheld;
    return;
  }
  pose_t p;
  p.utime = utime;
  p.source = source_;
  p.tag_id = tag_id;
  const Eigen::Vector3d& pos = t.filter.position();
  const Eigen::Vector3d& vel = t.filter.velocity();
  const ErrorCov& P = t.filter.covariance();
  for (int k = 0; k < 3; ++k) {
    p.position[k] = pos(k);
    p.velocity[k] = vel(k);
    for (int j = 0; j < 3; ++j) p.position_cov[3 * k + j] = P(kPos + k, kPos + j);
  }
  // The start heading's uncertainty: a rotation of the whole track about its start.
  const double sh = deg_to_rad(params_.initial_heading_sigma_deg);
  const Eigen::Vector3d d = pos - t.start.position_m;
  const double jx = -d.y() * sh, jy = d.x() * sh;
  p.position_cov[0] += jx * jx;
  p.position_cov[1] += jx * jy;
  p.position_cov[3] += jx * jy;
  p.position_cov[4] += jy * jy;
  p.heading_rad = t.filter.heading_rad();
  t.tally.finish(p, false, utime);
  ++stats_.poses_out;
  sink_(p);
}

}  // namespace ips::ins
