#include "estimators/pdr/pdr_estimator.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "core/geometry.hpp"
#include "core/text_escape.hpp"

namespace ips::pdr {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Samples per second needed per hertz of step-filter cut-off (Nyquist is 2; 4 leaves the filter
// a usable transition band): 12 Hz for 002's 3 Hz.
constexpr double kMinRatePerCutoff = 4.0;
// Samples kept while aligning: 10 minutes at 100 Hz (the longest max_align_s is an hour, but a
// phone that rests aligns within init_still_s).
constexpr size_t kMaxPending = 60000;

Eigen::Vector3d vec(const double (&v)[3]) { return {v[0], v[1], v[2]}; }
}  // namespace

PdrParams parse_pdr_params(const YamlField& s) {
  PdrParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of pdr parameters");
  s.check_keys({"detector", "filter_order", "filter_cutoff_hz", "peak_threshold_mps2",
                "adaptive_threshold", "adaptive_k", "adaptive_hysteresis_k",
                "adaptive_floor_mps2", "adaptive_window_s", "gravity_window_s",
                "zero_crossing_threshold_mps2", "min_step_interval_s", "cadence_fill",
                "cadence_window_s", "cadence_min_corr", "cadence_tolerance", "signal", "step_model",
                "step_k", "step_k2", "body_height_m", "levi_s0_m", "levi_f0_hz",
                "levi_m_per_hz", "step_min_m", "step_max_m", "use_magnetometer",
                "mag_field_ut", "mag_inclination_deg", "mag_declination_deg",
                "mag_norm_tolerance", "mag_dip_tolerance_deg", "mag_update_period_s", "mag_update_distance_m", "mag_gate_chi2",
                "mag_static_window_m", "mag_static_heading_deg", "mag_static_norm_ut",
                "mag_static_dip_deg", "mag_correlation_m",
                "mag_heading_sigma_deg", "phone_yaw_offset_deg", "gyro_noise_rad_s",
                "gyro_bias_walk_rad_s2", "init_still_s", "max_align_s", "still_gyro_rad_s",
                "still_accel_mps2", "still_window_s", "step_length_sigma_m", "max_gap_s",
                "max_tags", "learn_noise"});
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  auto bounded = [&](const char* key, double& v, double lo, double hi) {
    v = s.get_double(key, v);
    if (!(v >= lo && v <= hi))
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  const std::string det = s.get_string("detector", "peak");
  if (det == "peak") p.detector.kind = StepDetectorKind::kPeak;
  else if (det == "zero_crossing") p.detector.kind = StepDetectorKind::kZeroCrossing;
  else s["detector"].fail("expected peak or zero_crossing, got '" + det + "'");
  double order = p.detector.filter_order;
  bounded("filter_order", order, 1, 12);
  p.detector.filter_order = static_cast<int>(order);
  if (p.detector.filter_order != order) s["filter_order"].fail("must be an integer");
  bounded("filter_cutoff_hz", p.detector.filter_cutoff_hz, 0.1, 20);
  bounded("peak_threshold_mps2", p.detector.peak_threshold, 0, 50);
  // A site that sets 002's fixed threshold means it, unless it asks for the adaptive one too.
  p.detector.adaptive =
      s.get_bool("adaptive_threshold", !s["peak_threshold_mps2"].defined());
  bounded("adaptive_k", p.detector.adaptive_k, 0, 10);
  bounded("adaptive_hysteresis_k", p.detector.adaptive_hysteresis_k, -10, 10);
  bounded("adaptive_floor_mps2", p.detector.adaptive_floor_mps2, 0, 50);
  bounded("adaptive_window_s", p.detector.adaptive_window_s, 0.1, 600);
  bounded("gravity_window_s", p.gravity_window_s, 0.1, 3600);
  bounded("zero_crossing_threshold_mps2", p.detector.zero_crossing_threshold, 0, 50);
  bounded("min_step_interval_s", p.detector.min_step_interval_s, 0.05, 5);
  p.detector.cadence_fill = s.get_bool("cadence_fill", p.detector.cadence_fill);
  bounded("cadence_window_s", p.detector.cadence_window_s, 1, 60);
  bounded("cadence_min_corr", p.detector.cadence_min_corr, 0, 1);
  bounded("cadence_tolerance", p.detector.cadence_tolerance, 0, 0.5);
  const std::string sig = s.get_string("signal", "vertical");
  if (sig == "vertical") p.signal = StepSignal::kVertical;
  else if (sig == "norm") p.signal = StepSignal::kNorm;
  else s["signal"].fail("expected vertical or norm, got '" + sig + "'");
  const std::string model = s.get_string("step_model", "modified_weinberg");
  const auto m = parse_step_model(model);
  if (!m)
    s["step_model"].fail(
        "expected static, weinberg, modified_weinberg, kang, kim, scarlett, tian or levi");
  p.length.model = *m;
  if (p.length.model == StepModel::kStatic) p.length.k = 0.415;  // 002 (3.1), men
  bounded("step_k", p.length.k, -100, 100);
  bounded("step_k2", p.length.k2, -100, 100);
  bounded("body_height_m", p.length.height_m, 0.5, 2.5);
  bounded("levi_s0_m", p.length.s0_m, 0, 3);
  bounded("levi_f0_hz", p.length.f0_hz, 0.1, 5);
  bounded("levi_m_per_hz", p.length.m_per_hz, -5, 5);
  bounded("step_min_m", p.length.min_m, 0, 3);
  bounded("step_max_m", p.length.max_m, p.length.min_m, 5);
  p.use_magnetometer = s.get_bool("use_magnetometer", p.use_magnetometer);
  bounded("mag_field_ut", p.field.magnitude_ut, 1, 1000);
  bounded("mag_inclination_deg", p.field.inclination_deg, -90, 90);
  bounded("mag_declination_deg", p.field.declination_deg, -180, 180);
  bounded("mag_norm_tolerance", p.mag_norm_tolerance, 0, 10);
  bounded("mag_dip_tolerance_deg", p.mag_dip_tolerance_deg, 0, 180);
  bounded("mag_update_period_s", p.mag_update_period_s, 0, 100);
  bounded("mag_update_distance_m", p.mag_update_distance_m, 0, 1000);
  if (s["mag_gate_chi2"].defined()) bounded("mag_gate_chi2", p.mag_gate_chi2, 0.1, 1e6);
  bounded("mag_static_window_m", p.mag_static_window_m, 0, 100);
  bounded("mag_static_heading_deg", p.mag_static_heading_deg, 0, 180);
  bounded("mag_static_norm_ut", p.mag_static_norm_ut, 0, 1000);
  bounded("mag_static_dip_deg", p.mag_static_dip_deg, 0, 180);
  bounded("mag_correlation_m", p.mag_correlation_m, 0, 1000);
  double mag_sigma_deg = rad_to_deg(p.noise.mag_heading_sigma_rad);
  bounded("mag_heading_sigma_deg", mag_sigma_deg, 0.01, 180);
  p.noise.mag_heading_sigma_rad = deg_to_rad(mag_sigma_deg);
  bounded("phone_yaw_offset_deg", p.phone_yaw_offset_deg, -360, 360);
  bounded("gyro_noise_rad_s", p.noise.gyro_noise_rad_s, 1e-6, 10);
  bounded("gyro_bias_walk_rad_s2", p.noise.bias_walk_rad_s2, 0, 10);
  bounded("init_still_s", p.init_still_s, 0.05, 600);
  bounded("max_align_s", p.max_align_s, p.init_still_s, 3600);
  bounded("still_gyro_rad_s", p.still_gyro_rad_s, 0, 10);
  bounded("still_accel_mps2", p.still_accel_mps2, 0, 10);
  bounded("still_window_s", p.still_window_s, 0.01, 10);
  bounded("step_length_sigma_m", p.step_length_sigma_m, 0, 10);
  bounded("max_gap_s", p.max_gap_s, 0.001, 60);
  double max_tags = p.max_tags;
  bounded("max_tags", max_tags, 1, 10000);
  p.max_tags = static_cast<int>(max_tags);
  return p;
}

PdrEstimator::PdrEstimator(StepSink steps, PoseSink poses, std::string source_name)
    : step_sink_(std::move(steps)), pose_sink_(std::move(poses)), source_(std::move(source_name)) {}

void PdrEstimator::set_site(const Site& site) {
  params_ = parse_pdr_params(site.estimator_params("pdr"));
  site_ = site;
  tracks_.clear();
  // The magnetometer's heading noise is learned from its innovations (never below
  // mag_heading_sigma_deg): a building whose field is disturbed more than the setting says gets
  // less say over the heading.
  ConsistencyOptions co;
  co.learn = params_.learn_noise;
  consistency_ = ConsistencyMonitor(co);
  mag_setting_ =
      setting_text("mag_heading_sigma_deg", rad_to_deg(params_.noise.mag_heading_sigma_rad));
}

void PdrEstimator::on_imu(const imu_t& m) {
  ++stats_.samples_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  const Eigen::Vector3d a = vec(m.accel), g = vec(m.gyro);
  const bool has_gyro = g.allFinite();
  if (!plausible_utime(m.utime) || !a.allFinite() || m.device_id.empty() || a.norm() > 1000 ||
      (has_gyro && g.norm() > 100)) {
    ++stats_.dropped_invalid;
    return;
  }
  // A stamp far from the device's timeline waits for confirmation (core/time_guard.hpp): one
  // sample stamped ahead made every later one "out of order"; a clock that went back restarts.
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
    it = tracks_.emplace(m.device_id, Track{}).first;
    it->second.first_utime = m.utime;
    it->second.rest_start = m.utime;
    it->second.accel_only = !has_gyro;
    if (!has_gyro) ++stats_.accel_only_tracks;
  } else if (m.utime <= it->second.last_utime) {
    count_out_of_turn(m.utime, it->second.last_utime, s_to_utime(params_.max_gap_s),
                      stats_.dropped_repeated, stats_.dropped_reordered, stats_.dropped_time);
    return;
  }
  Track& t = it->second;
  if (!t.accel_only && !has_gyro) {  // a device with a gyroscope lost it for this sample
    ++stats_.dropped_invalid;
    return;
  }
  const Sample sample{m.utime, a, t.accel_only ? Eigen::Vector3d::Zero() : g,
                      t.accel_only ? Eigen::Vector3d::Constant(kNaN) : vec(m.mag_ut)};
  const double dt = t.last_utime ? utime_to_s(m.utime - t.last_utime) : 0.0;
  t.last_utime = m.utime;
  if (dt > params_.max_gap_s) ++stats_.gaps;
  const bool usable_dt = dt > 0 && dt <= params_.max_gap_s;

  if (!t.aligned) {
    // Kept for the replay once aligned (bounded: a refused IMU keeps waiting).
    if (t.pending.size() < kMaxPending) t.pending.push_back(sample);
    else ++stats_.samples_aligning;
    t.all_a += a;
    t.all_norm += a.norm();
    ++t.n_all;
    if (sample.mag.allFinite()) {
      t.all_m += sample.mag;
      ++t.n_all_mag;
    }
    // Rest: gravity-sized specific force and a small rate; anything else restarts the window.
    const bool rest = std::abs(a.norm() - params_.gravity_mps2) < params_.still_accel_mps2 &&
                      sample.g.norm() < params_.still_gyro_rad_s;
    if (!rest) {
      t.sum_a.setZero();
      t.sum_g.setZero();
      t.sum_m.setZero();
      t.sum_norm = 0;
      t.n = t.n_mag = 0;
      t.rest_start = m.utime;
    } else {
      t.sum_a += a;
      t.sum_g += sample.g;
      t.sum_norm += a.norm();
      if (sample.mag.allFinite()) {
        t.sum_m += sample.mag;
        ++t.n_mag;
      }
      ++t.n;
    }
    if (usable_dt) {
      t.sum_dt += dt;
      ++t.n_dt;
    }
    if (t.n > 0 && utime_to_s(m.utime - t.rest_start) >= params_.init_still_s && t.n_dt > 0) {
      align(t, m.device_id, true);
    } else if (utime_to_s(m.utime - t.first_utime) >= params_.max_align_s && t.n_dt > 0) {
      // No rest long enough (a restart mid-walk): tilt from the mean specific force of the
      // whole window, in which the walk's accelerations average out; no gyro bias yet (learned
      // at the next rest); a looser attitude.
      t.sum_a = t.all_a;
      t.sum_g.setZero();
      t.sum_norm = t.all_norm;
      t.n = t.n_all;
      t.sum_m = t.all_m;
      t.n_mag = t.n_all_mag;
      align(t, m.device_id, false);
    }
    if (!t.aligned) return;
    // Aligned on this sample: replay the window's samples (this one included) through the
    // step detector with the attitude just found.
    std::vector<Sample> pending;
    pending.swap(t.pending);
    utime_t prev = 0;
    for (const Sample& p : pending) {
      const double pdt = prev ? utime_to_s(p.utime - prev) : 0.0;
      prev = p.utime;
      if (!(pdt > 0 && pdt <= params_.max_gap_s)) continue;  // the first, or after a gap
      ++stats_.samples_replayed;
      walk(t, m.device_id, p, pdt, true);
    }
    return;
  }
  if (!usable_dt) {
    ++stats_.dropped_gap;
    return;
  }
  walk(t, m.device_id, sample, dt, false);
}

std::vector<std::string> PdrEstimator::accel_only_devices() const {
  std::vector<std::string> out;
  for (const auto& [id, t] : tracks_)
    if (t.accel_only) out.push_back(id);
  return out;
}

std::string PdrEstimator::problems() const {
  std::string devices;
  for (const std::string& d : accel_only_devices())
    devices += (devices.empty() ? "" : ", ") + printable(d);
  if (devices.empty()) return {};
  return "no gyroscope on " + devices +
         ": steps only, heading unknown (STEP heading_known false), no POSE_PDR";
}

void PdrEstimator::align(Track& t, const std::string& tag_id, bool rested) {
  // The step filter needs a sample rate well above its cut-off (a Butterworth low-pass exists
  // only below Nyquist); a slower IMU cannot be used: say so and keep waiting.
  const double rate_hz = t.n_dt / t.sum_dt;
  if (!(rate_hz >= kMinRatePerCutoff * params_.detector.filter_cutoff_hz)) {
    ++stats_.alignments_too_slow;
    stats_.samples_aligning += static_cast<int64_t>(t.pending.size());
    const utime_t now = t.last_utime;
    const bool accel_only = t.accel_only;
    t = Track{};  // a fresh alignment window from this sample
    t.first_utime = t.rest_start = t.last_utime = now;
    t.accel_only = accel_only;
    return;
  }
  const Tag* tag = site_->find_tag(tag_id);
  const double offset = deg_to_rad(params_.phone_yaw_offset_deg);
  double start_heading = 0.0;
  if (tag && std::isfinite(tag->start_heading_rad)) start_heading = tag->start_heading_rad;
  // The initial heading: the site's start heading when it gives one (surveyed; the field at
  // one spot indoors is off by the building's disturbance, several degrees, and a heading error
  // at the start grows into the largest position error of the walk), else the field (TRIAD).
  const bool site_heading = tag && std::isfinite(tag->start_heading_rad);
  const Eigen::Vector3d mag = params_.use_magnetometer && t.n_mag > 0 && !site_heading
                                  ? Eigen::Vector3d(t.sum_m / t.n_mag)
                                  : Eigen::Vector3d::Constant(kNaN);
  // From the site's heading, the device x axis points at the walking heading + offset - 90 deg.
  if (!t.accel_only)
    t.ekf.initialise(t.sum_a / t.n, t.sum_g / t.n, mag, params_.field,
                     start_heading + offset - M_PI / 2, rested ? 0.002 : 0.05);
  // The phone's own gravity: accelerometers read 1 to 3 % off 9.81 (scale, offsets).
  t.gravity = t.sum_norm / t.n;
  t.detector = std::make_unique<StepDetector>(params_.detector, t.n_dt / t.sum_dt);
  if (tag && tag->has_start()) {
    t.position = tag->start_position.head<2>();
    t.z = tag->start_position.z();
  } else {
    ++stats_.no_start_pose;
    t.z = tag && std::isfinite(tag->height_m) ? tag->height_m : 0.0;
  }
  if (tag && std::isfinite(tag->height_m)) t.z = tag->height_m;
  t.aligned = true;
  ++stats_.alignments;
  if (!rested) ++stats_.alignments_without_rest;
}

void PdrEstimator::walk(Track& t, const std::string& tag_id, const Sample& m, double dt,
                        bool replay) {
  const Eigen::Vector3d& a = m.a;
  if (t.accel_only) {
    // Gravity: the running mean of |a| (walking adds a little; the detector's own running
    // mean takes out what remains).
    t.gravity += std::min(1.0, dt / params_.gravity_window_s) * (a.norm() - t.gravity);
    const auto step = t.detector->add(m.utime, a.norm() - t.gravity);
    if (step)  // with the step the walk's cadence says the peaks missed (step_detector.hpp)
      for (const DetectedStep& s : with_missed(*step)) emit_step(t, tag_id, s, kNaN);
    return;
  }
  const Eigen::Vector3d& g = m.g;
  const Eigen::Vector3d& mag = m.mag;
  if (!replay) {
    t.ekf.predict(g, dt, params_.noise);
    const bool still_now = std::abs(a.norm() - t.gravity) < params_.still_accel_mps2 &&
                           (g - t.ekf.bias()).norm() < params_.still_gyro_rad_s;
    t.still_s = still_now ? t.still_s + dt : 0.0;
    const bool still = t.still_s >= params_.still_window_s;
    t.ekf.update_gravity(a, still ? params_.noise.gravity_sigma_still
                                  : params_.noise.gravity_sigma_moving);
    if (still) {
      t.ekf.update_zero_rate(g, params_.noise.zero_rate_sigma_rad_s);
      t.gravity += std::min(1.0, dt / params_.gravity_window_s) * (a.norm() - t.gravity);
    }
    if (params_.use_magnetometer && mag.allFinite()) {
      // The field in the world frame, averaged over the update period.
      t.sum_mw += t.ekf.q() * mag;
      ++t.n_mw;
      t.sum_check += t.ekf.q() * mag;
      ++t.n_check;
      t.sum_seg += t.ekf.q() * mag;
      ++t.n_seg;
    }
    if (t.n_check > 0 &&
        utime_to_s(m.utime - t.last_mag_check) >= params_.mag_update_period_s) {
      // The consistency check: the heading innovation of the field over this period, against
      // the assumed sigma, whether or not it is used.
      t.last_mag_check = m.utime;
      const MagUpdate c = t.ekf.update_mag_heading_world(
          t.sum_check / t.n_check, params_.field, params_.mag_norm_tolerance,
          deg_to_rad(params_.mag_dip_tolerance_deg), params_.noise.mag_heading_sigma_rad,
          kNoGate, true);
      t.sum_check.setZero();
      t.n_check = 0;
      // Evidence about the magnetometer only while the filter knows its heading at least as
      // well as the magnetometer is assumed to (after the field has been refused for a while
      // the innovation is mostly the filter's own uncertainty; the per-step check in
      // update_mag covers that time).
      if (c.field_ok && c.hph <= c.r)
        consistency_.add_scalar("MAG", tag_id, utime_to_s(m.utime), c.innovation, c.hph, c.r,
                                false, mag_setting_);
    }
  }
  const double heading =
      t.ekf.heading_of(Eigen::Vector3d::UnitY()) - deg_to_rad(params_.phone_yaw_offset_deg);
  t.sum_cos += std::cos(heading);
  t.sum_sin += std::sin(heading);

  const Eigen::Vector3d a_world = t.ekf.q() * a;
  const double signal = params_.signal == StepSignal::kVertical ? a_world.z() - t.gravity
                                                                : a.norm() - t.gravity;
  const auto step = t.detector->add(m.utime, signal);
  if (!step) return;
  const double theta = std::atan2(t.sum_sin, t.sum_cos);
  t.sum_cos = t.sum_sin = 0;
  for (const DetectedStep& s : with_missed(*step)) emit_step(t, tag_id, s, theta);
  if (!replay) update_mag(t, tag_id, m.utime);
}

void PdrEstimator::update_mag(Track& t, const std::string& tag_id, utime_t now) {
  // Called once per step. The building's disturbance of the field is a function of place, not
  // time: at one spot every reading carries the same error, and a heading "corrected" by it
  // twice a second at rest is pulled to the local field (up to 15 deg on walk-square). So the
  // heading is updated at most once per mag_update_distance_m walked, never while standing,
  // only where the field is quasi-static over the last mag_static_window_m (a field that varies
  // along the walk is disturbed, however plausible its norm and dip), and with its variance
  // inflated for the error it shares with the previous update (mag_correlation_m).
  const double step_m = t.mag_distance_m - t.seg_mark_m;
  t.seg_mark_m = t.mag_distance_m;
  t.since_accepted_m += step_m;
  const bool check_static = params_.mag_static_window_m > 0;
  double covered = 0;  // the distance the kept steps cover
  if (check_static) {
    const bool new_segment = t.n_seg > 0;
    if (new_segment) t.segments.emplace_back(t.sum_seg / t.n_seg, step_m);
    else if (!t.segments.empty()) t.segments.back().second += step_m;
    t.sum_seg.setZero();
    t.n_seg = 0;
    // Keep the steps covering the window: drop the oldest while the rest still covers it.
    for (const auto& sgm : t.segments) covered += sgm.second;
    while (t.segments.size() > 1 &&
           covered - t.segments.front().second >= params_.mag_static_window_m) {
      covered -= t.segments.front().second;
      t.segments.erase(t.segments.begin());
    }
    // The consistency check that does not depend on the filter's own heading: this step's
    // field heading against the window's earlier steps, both turned by the gyro (over a few
    // metres its error is far below the magnetometer's), as a heading innovation with the
    // earlier steps' mean counted as 1 / (K - 1) of a measurement's variance.
    const size_t k = t.segments.size();
    if (new_segment && k >= 3 && covered >= params_.mag_static_window_m) {
      Eigen::Vector3d before = Eigen::Vector3d::Zero();
      for (size_t i = 0; i + 1 < k; ++i) before += t.segments[i].first;
      const Eigen::Vector3d& last = t.segments.back().first;
      const double r =
          wrap_angle(std::atan2(last.y(), last.x()) - std::atan2(before.y(), before.x()));
      const double scale = 1.0 + 1.0 / static_cast<double>(k - 1);
      const double sigma = params_.noise.mag_heading_sigma_rad;
      consistency_.add_scalar("MAG", tag_id, utime_to_s(now), r / std::sqrt(scale), 0.0,
                              sigma * sigma, false, mag_setting_);
    }
  }
  if (t.n_mw == 0 || t.mag_distance_m < params_.mag_update_distance_m ||
      utime_to_s(now - t.last_mag_update) < params_.mag_update_period_s)
    return;
  const double sigma_cfg = params_.noise.mag_heading_sigma_rad;
  double var = consistency_.variance("MAG", tag_id, sigma_cfg * sigma_cfg);
  if (params_.mag_correlation_m > 0) {
    const double rho = std::exp(-t.since_accepted_m / params_.mag_correlation_m);
    var *= std::min((1.0 + rho) / std::max(1.0 - rho, 1e-6), 1e4);
  }
  Eigen::Vector3d field = t.sum_mw / t.n_mw;
  if (check_static) {
    if (covered < params_.mag_static_window_m) return;  // too few steps yet
    std::vector<Eigen::Vector3d> means;
    for (const auto& sgm : t.segments) means.push_back(sgm.first);
    const QuasiStaticField qs = check_quasi_static(
        means, deg_to_rad(params_.mag_static_heading_deg), params_.mag_static_norm_ut,
        deg_to_rad(params_.mag_static_dip_deg));
    if (qs.ok) {
      field = qs.mean;
    } else if (t.ekf.yaw_variance() < var) {
      // Refused while the filter knows its heading better than the magnetometer is assumed to
      // (a disturbed field would only spoil it); tried again at the next step (the window
      // slides), counted once per step. A filter less sure than that (no rest to learn the
      // gyro bias, a long refusal) still takes the field, with its learned, inflated variance:
      // the heading's sigma never grows far beyond the magnetometer's while there is a field.
      ++stats_.mag_not_static;
      return;
    }
  }
  t.last_mag_update = now;
  const MagUpdate u = t.ekf.update_mag_heading_world(
      field, params_.field, params_.mag_norm_tolerance,
      deg_to_rad(params_.mag_dip_tolerance_deg), std::sqrt(var), params_.mag_gate_chi2);
  t.sum_mw.setZero();
  t.n_mw = 0;
  t.mag_distance_m = t.seg_mark_m = 0;
  if (u.field_ok) {
    if (!u.accepted)  // refused by mag_gate_chi2 (the checks above see every period)
      consistency_.add_scalar("MAG", tag_id, utime_to_s(now), u.innovation, u.hph, u.r, true,
                              mag_setting_);
    ++stats_.mag_updates;
    if (!u.accepted) ++stats_.mag_gated;
    else t.since_accepted_m = 0;
  } else {
    ++stats_.mag_rejected;
  }
}

std::string PdrEstimator::mag_summary() const {
  if (!params_.use_magnetometer) return "MAG: off (use_magnetometer false)";
  const int64_t used = stats_.mag_updates - stats_.mag_gated;
  char buf[200];
  std::snprintf(buf, sizeof buf,
                "MAG: %lld heading updates used, refused: %lld field not static, %lld norm/dip, "
                "%lld gated",
                static_cast<long long>(used), static_cast<long long>(stats_.mag_not_static),
                static_cast<long long>(stats_.mag_rejected),
                static_cast<long long>(stats_.mag_gated));
  return buf;
}

std::string PdrEstimator::run_notes() const {
  int64_t cadence = 0;
  bool with_gyro = false;
  for (const auto& [id, t] : tracks_) {
    if (t.detector) cadence += t.detector->missed_steps();
    with_gyro = with_gyro || !t.accel_only;
  }
  std::string s = std::to_string(stats_.steps) + " steps (" + std::to_string(cadence) +
                  " counted from the walk's cadence)";
  if (with_gyro) s += "; " + mag_summary();
  return s;
}

void PdrEstimator::emit_step(Track& t, const std::string& tag_id, const DetectedStep& step,
                             double theta) {
  const double sl = step_length(params_.length, step);
  ++t.steps;
  ++stats_.steps;
  step_t s;
  s.utime = step.utime;
  s.source = source_;
  s.tag_id = tag_id;
  s.index = t.steps;
  s.length_m = sl;
  s.heading_known = std::isfinite(theta);
  s.heading_rad = s.heading_known ? theta : kNaN;
  s.cadence_hz = step.interval_s > 0 ? 1.0 / step.interval_s : 0.0;
  if (!std::isfinite(theta)) {  // heading unknown: the step alone, no position
    ++stats_.steps_heading_unknown;
    step_sink_(s);
    return;
  }
  const Eigen::Vector2d dir(std::cos(theta), std::sin(theta));
  t.position += sl * dir;
  t.mag_distance_m += sl;
  // Along the step: the length's noise; across it: the heading's.
  const double along = params_.step_length_sigma_m * params_.step_length_sigma_m;
  const double across = sl * sl * std::max(t.ekf.yaw_variance(), 0.0);
  const Eigen::Vector2d perp(-dir.y(), dir.x());
  t.cov += along * dir * dir.transpose() + across * perp * perp.transpose();
  step_sink_(s);

  pose_t p;
  p.utime = step.utime;
  p.source = source_;
  p.tag_id = tag_id;
  p.position[0] = t.position.x();
  p.position[1] = t.position.y();
  p.position[2] = t.z;
  for (double& c : p.position_cov) c = 0.0;
  p.position_cov[0] = t.cov(0, 0);
  p.position_cov[1] = p.position_cov[3] = t.cov(0, 1);
  p.position_cov[4] = t.cov(1, 1);
  for (int k = 0; k < 2; ++k) p.velocity[k] = s.cadence_hz * sl * dir(k);
  p.velocity[2] = 0.0;
  if (s.cadence_hz == 0) p.velocity[0] = p.velocity[1] = kNaN;
  p.heading_rad = theta;
  p.num_used = 1;
  p.residual_m = kNaN;
  p.status = pose_t::STATUS_OK;
  p.status |= pose_t::STATUS_2D;
  pose_sink_(p);
}

}  // namespace ips::pdr
