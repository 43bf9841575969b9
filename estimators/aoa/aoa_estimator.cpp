#include "estimators/aoa/aoa_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "core/geometry.hpp"
#include "estimators/aoa/models/aoa_bearing.hpp"

namespace ips::aoa {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

std::optional<DuplicatePolicy> parse_duplicate_policy(const std::string& name) {
  if (name == "strongest") return DuplicatePolicy::kStrongest;
  if (name == "first") return DuplicatePolicy::kFirst;
  if (name == "weakest") return DuplicatePolicy::kWeakest;
  if (name == "nearest") return DuplicatePolicy::kNearest;
  return std::nullopt;
}

AoaParams parse_aoa_params(const YamlField& s) {
  AoaParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of aoa parameters");
  s.check_keys({"method", "solver", "mode", "warm_start", "azimuth_sigma_deg",
                "elevation_sigma_deg", "edge_sigma_gain", "epoch_window_s", "duplicate", "motion",
                "accel_psd", "random_walk_psd", "initial_sigma_m", "initial_velocity_sigma_mps",
                "gate_sigma", "min_anchors", "max_fix_sigma_m", "reinit_after_rejections", "max_coast_s",
                "disagree_window_s", "single_anchor_s", "max_outside_m", "max_below_m",
                "near_anchor_m", "multi_start", "min_anchor_distance_m", "learn_noise",
                "publish_period_s", "reorder_tolerance_s", "max_tags", "max_iterations",
                "converged_step_m", "diverged_step_m", "lm_lambda0", "lm_factor", "lm_lambda_max",
                "steepest_step", "calibration"});
  // Every parameter is bounded: a SITE message on the bus is outside input.
  auto bounded = [&](const char* key, double& v, double lo, double hi) {
    v = s.get_double(key, v);
    if (!(v >= lo && v <= hi))
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  };
  auto bounded_int = [&](const char* key, int& v, int lo, int hi) {
    const int64_t got = s.get_int(key, v);
    if (got < lo || got > hi)
      s[key].fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    v = static_cast<int>(got);
  };
  const std::string method = s.get_string("method", "ekf");
  if (method == "ekf") p.method = AoaMethod::kEkf;
  else if (method == "per_epoch") p.method = AoaMethod::kPerEpoch;
  else s["method"].fail("expected ekf or per_epoch, got '" + method + "'");
  const std::string solver = s.get_string("solver", "lm");
  const auto parsed = parse_aoa_solver(solver);
  if (!parsed) s["solver"].fail("expected bearing_lines, gauss_newton, steepest_descent or lm");
  p.solver = *parsed;
  const std::string mode = s.get_string("mode", "auto");
  if (mode != "auto" && mode != "3d")
    s["mode"].fail("expected auto (2D when the tag height is known) or 3d");
  p.force_3d = mode == "3d";
  p.warm_start = s.get_bool("warm_start", p.warm_start);
  bounded("azimuth_sigma_deg", p.azimuth_sigma_deg, 0.01, 90);
  bounded("elevation_sigma_deg", p.elevation_sigma_deg, 0.01, 90);
  bounded("edge_sigma_gain", p.edge_sigma_gain, 0, 100);
  bounded("epoch_window_s", p.epoch_window_s, 0.001, 10);
  const std::string dup = s.get_string("duplicate", "strongest");
  const auto policy = parse_duplicate_policy(dup);
  if (!policy) s["duplicate"].fail("expected strongest, first, weakest or nearest");
  p.duplicate = *policy;
  const std::string motion = s.get_string("motion", "constant_velocity");
  if (motion == "constant_velocity") p.motion = AoaMotion::kConstantVelocity;
  else if (motion == "random_walk") p.motion = AoaMotion::kRandomWalk;
  else s["motion"].fail("expected constant_velocity or random_walk, got '" + motion + "'");
  bounded("accel_psd", p.accel_psd, 1e-6, 1e4);
  bounded("random_walk_psd", p.random_walk_psd, 1e-6, 1e4);
  bounded("initial_sigma_m", p.initial_sigma_m, 1e-3, 1e4);
  bounded("initial_velocity_sigma_mps", p.initial_velocity_sigma_mps, 1e-3, 1e3);
  bounded("gate_sigma", p.gate_sigma, 0.5, 1e6);
  bounded_int("min_anchors", p.min_anchors, 2, 1000);
  bounded("max_fix_sigma_m", p.max_fix_sigma_m, 1e-3, 1e6);
  bounded_int("reinit_after_rejections", p.reinit_after_rejections, 1, 1000000);
  bounded("max_coast_s", p.max_coast_s, 0.01, 1e6);
  bounded("disagree_window_s", p.disagree_window_s, 0.01, 1e6);
  bounded("single_anchor_s", p.single_anchor_s, 0, 1e6);
  bounded("max_outside_m", p.max_outside_m, 0, 1e6);
  bounded("max_below_m", p.max_below_m, 0, 1e6);
  bounded("min_anchor_distance_m", p.min_anchor_distance_m, 0, 100);
  bounded("near_anchor_m", p.solve.near_anchor_m, 0, 100);
  p.solve.multi_start = s.get_bool("multi_start", p.solve.multi_start);
  p.learn_noise = s.get_bool("learn_noise", p.learn_noise);
  bounded("publish_period_s", p.publish_period_s, 0, 1e6);
  bounded("reorder_tolerance_s", p.reorder_tolerance_s, 0, 1e6);
  bounded_int("max_tags", p.max_tags, 1, 100000);
  bounded_int("max_iterations", p.solve.max_iterations, 1, 100000);
  bounded("converged_step_m", p.solve.converged_step_m, 1e-9, 1e3);
  bounded("diverged_step_m", p.solve.diverged_step_m, 1e-3, 1e7);
  bounded("lm_lambda0", p.solve.lm_lambda0, 1e-12, 1e12);
  bounded("lm_factor", p.solve.lm_factor, 1.0001, 1e6);
  bounded("lm_lambda_max", p.solve.lm_lambda_max, 1e-12, 1e15);
  bounded("steepest_step", p.solve.steepest_step, 1e-9, 1e6);
  return p;
}

AoaEstimator::AoaEstimator(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)),
      source_(std::move(source_name)),
      grouper_(AoaParams{}.epoch_window_s, [this](Epoch& e) { on_epoch(e); }) {}

void AoaEstimator::override_method(AoaMethod method, std::optional<AoaSolver> solver) {
  method_override_ = method;
  solver_override_ = solver;
  params_.method = method;
  if (solver) params_.solver = *solver;
}

void AoaEstimator::set_site(const Site& site) {
  const YamlField section = site.estimator_params("aoa");
  AoaParams params = parse_aoa_params(section);
  const auto calibration = parse_calibration(section["calibration"]);
  for (const auto& [id, cal] : calibration) {
    const Anchor* a = site.find_anchor(id);
    if (!a || a->kind != "ble_aoa")
      section["calibration"][id].fail("no ble_aoa anchor '" + id + "' in the site");
  }
  if (method_override_) params.method = *method_override_;
  if (solver_override_) params.solver = *solver_override_;
  // Epochs still open belong to the old site: they are used with it.
  grouper_.flush_all();
  params_ = params;
  grouper_ = EpochGrouper(params_.epoch_window_s, [this](Epoch& e) { on_epoch(e); });
  frames_.clear();
  usable_.clear();
  calibration_.clear();
  anchor_index_.clear();
  double height_sum = 0;
  int n = 0;
  box_min_.setConstant(std::numeric_limits<double>::infinity());
  box_max_.setConstant(-std::numeric_limits<double>::infinity());
  for (const auto& a : site.anchors) {
    anchor_index_.try_emplace(a.id, frames_.size());  // the first of an id, as a search finds
    frames_.push_back(anchor_frame(a));
    const bool usable = a.kind == "ble_aoa" && a.enabled;
    usable_.push_back(usable);
    const auto it = calibration.find(a.id);
    calibration_.push_back(it == calibration.end() ? AnchorCalibration{} : it->second);
    if (usable) {
      height_sum += a.position.z();
      ++n;
      box_min_ = box_min_.cwiseMin(a.position);
      box_max_ = box_max_.cwiseMax(a.position);
    }
  }
  default_height_m_ = n > 0 ? height_sum / n : 0.0;
  ConsistencyOptions co;
  co.learn = params_.learn_noise;
  consistency_ = ConsistencyMonitor(co);
  azimuth_setting_ = setting_text("azimuth_sigma_deg", params_.azimuth_sigma_deg);
  elevation_setting_ = setting_text("elevation_sigma_deg", params_.elevation_sigma_deg);
  site_ = site;
  tracks_.clear();
}

void AoaEstimator::on_event(const ble_aoa_t& m) {
  ++stats_.events_in;
  if (!site_) {
    ++stats_.dropped_no_site;
    return;
  }
  if (!plausible_utime(m.utime) || m.tag_id.empty() || !std::isfinite(m.azimuth_deg) ||
      std::abs(m.azimuth_deg) > 90 || (!std::isnan(m.elevation_deg) && std::abs(m.elevation_deg) > 90)) {
    ++stats_.dropped_invalid;
    return;
  }
  // A stamp far from its anchor's timeline waits for confirmation (core/time_guard.hpp); an
  // anchor whose clock went back restarts the tags' tracks.
  if (!guard_.admit(m.anchor_id, m.utime, [this, m] { on_event(m); }, [this] { tracks_.clear(); })) {
    --stats_.events_in;  // counted when handed over again, or dropped as a time jump
    return;
  }
  const auto found = anchor_index_.find(m.anchor_id);
  const size_t index = found == anchor_index_.end() ? site_->anchors.size() : found->second;
  if (index == site_->anchors.size() || !usable_[index]) {
    const bool none = std::find(usable_.begin(), usable_.end(), true) == usable_.end();
    ++(none ? stats_.dropped_no_anchors : stats_.dropped_unknown_anchor);
    return;
  }
  const AnchorCalibration& cal = calibration_[index];
  const auto az = cal.azimuth.apply(m.azimuth_deg);
  // A missing elevation only matters to 3D tracks, which then skip this anchor's elevation.
  const auto el = std::isnan(m.elevation_deg) ? std::optional<double>(kNaN)
                                               : cal.elevation.apply(m.elevation_deg);
  if (!az || !el) {
    ++stats_.dropped_outside_calibration;
    return;
  }
  if (tracks_.find(m.tag_id) == tracks_.end()) {
    if (static_cast<int>(tracks_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    tracks_.try_emplace(m.tag_id);
  }
  AoaEvent e;
  e.utime = m.utime;
  e.anchor = index;
  e.azimuth_deg = *az;
  e.elevation_deg = *el;
  e.rssi_dbm = std::isfinite(m.rssi_dbm) ? m.rssi_dbm : -1000.0;
  e.order = order_++;
  grouper_.add(m.tag_id, e);
}

void AoaEstimator::flush(utime_t now) { grouper_.flush(now); }

bool AoaEstimator::inside_site(const Eigen::Vector3d& p) const {
  if (!(box_min_.x() <= box_max_.x())) return true;  // no anchors: nothing to bound by
  // A 2D track's height is the site's tag height: only its horizontal position is checked.
  // The horizontal distance outside the anchors' box, and the height within its band.
  const double dx = std::max({box_min_.x() - p.x(), 0.0, p.x() - box_max_.x()});
  const double dy = std::max({box_min_.y() - p.y(), 0.0, p.y() - box_max_.y()});
  return std::hypot(dx, dy) <= params_.max_outside_m &&
         p.z() >= box_min_.z() - params_.max_below_m && p.z() <= box_max_.z() + params_.max_outside_m;
}

void AoaEstimator::finish() { grouper_.flush_all(); }

double AoaEstimator::sigma_rad(double base_deg, double az_deg, double el_deg) const {
  // The angle off the normal of a direction at azimuth az and elevation el.
  const double el = std::isfinite(el_deg) ? el_deg : 0.0;
  const double c = std::cos(deg_to_rad(az_deg)) * std::cos(deg_to_rad(el));
  const double off = rad_to_deg(std::acos(std::clamp(c, -1.0, 1.0))) / 90.0;
  return deg_to_rad(base_deg * (1.0 + params_.edge_sigma_gain * off * off));
}

void AoaEstimator::pick_angles(const Epoch& epoch, const Track* track,
                               std::vector<AoaEvent>& out) {
  out.clear();
  std::optional<Eigen::Vector3d> predicted;
  if (params_.duplicate == DuplicatePolicy::kNearest && track && track->initialised) {
    if (params_.motion == AoaMotion::kConstantVelocity) {
      const double dt = utime_to_s(epoch.utime - track->filter_utime);
      predicted = track->planar ? site_point<2>(Vec<2>(track->cv2.x.head<2>() +
                                                       dt * track->cv2.x.tail<2>()),
                                                track->height_m)
                                : Eigen::Vector3d(track->cv3.x.head<3>() +
                                                  dt * track->cv3.x.tail<3>());
    } else {
      predicted = track->planar ? site_point<2>(track->rw2.x, track->height_m)
                                : Eigen::Vector3d(track->rw3.x);
    }
  }
  auto better = [&](const AoaEvent& a, const AoaEvent& b) {  // a preferred to b
    switch (params_.duplicate) {
      case DuplicatePolicy::kFirst: return a.order < b.order;
      case DuplicatePolicy::kWeakest:
        return a.rssi_dbm != b.rssi_dbm ? a.rssi_dbm < b.rssi_dbm : a.order < b.order;
      case DuplicatePolicy::kNearest:
        if (predicted) {
          const double pa = predict_angle(frames_[a.anchor], *predicted, AngleKind::kAzimuth)
                                .angle_rad;
          const double da = std::abs(wrap_angle(deg_to_rad(a.azimuth_deg) - pa));
          const double db = std::abs(wrap_angle(deg_to_rad(b.azimuth_deg) - pa));
          if (da != db) return da < db;
          return a.order < b.order;
        }
        [[fallthrough]];
      case DuplicatePolicy::kStrongest:
        return a.rssi_dbm != b.rssi_dbm ? a.rssi_dbm > b.rssi_dbm : a.order < b.order;
    }
    return false;
  };
  for (const AoaEvent& e : epoch.events) {
    auto same = std::find_if(out.begin(), out.end(),
                             [&](const AoaEvent& o) { return o.anchor == e.anchor; });
    if (same == out.end()) {
      out.push_back(e);
      continue;
    }
    ++stats_.duplicates;
    if (better(e, *same)) *same = e;
  }
  // Site order: the sequential updates do not depend on the anchors' report order.
  std::sort(out.begin(), out.end(),
            [](const AoaEvent& a, const AoaEvent& b) { return a.anchor < b.anchor; });
}

void AoaEstimator::observations(const std::vector<AoaEvent>& events,
                                std::vector<BearingObservation>& obs) const {
  obs.clear();
  for (const AoaEvent& e : events) {
    BearingObservation o;
    o.frame = &frames_[e.anchor];
    o.azimuth_rad = deg_to_rad(e.azimuth_deg);
    o.elevation_rad = deg_to_rad(e.elevation_deg);
    o.azimuth_sigma_rad = sigma_rad(params_.azimuth_sigma_deg, e.azimuth_deg, e.elevation_deg);
    o.elevation_sigma_rad =
        sigma_rad(params_.elevation_sigma_deg, e.azimuth_deg, e.elevation_deg);
    obs.push_back(o);
  }
}

void AoaEstimator::set_epoch_sink(EpochSink sink, bool track) {
  epoch_sink_ = std::move(sink);
  track_ = track;
}

void AoaEstimator::on_epoch(Epoch& epoch) {
  ++stats_.epochs;
  auto it = tracks_.find(epoch.tag_id);
  if (it == tracks_.end()) return;  // the site changed since the events came
  Track& t = it->second;
  if (t.filter_utime == 0 && t.last_fix_utime == 0) {
    const Tag* tag = site_->find_tag(epoch.tag_id);
    t.planar = !params_.force_3d && tag && std::isfinite(tag->height_m);
    t.height_m = t.planar ? tag->height_m : default_height_m_;
  }
  const utime_t newest = std::max(t.filter_utime, t.last_fix_utime);
  if (newest != 0 && epoch.utime < newest - s_to_utime(params_.reorder_tolerance_s)) {
    stats_.dropped_late += static_cast<int64_t>(epoch.events.size());
    return;
  }
  pick_angles(epoch, &t, picked_);
  if (epoch_sink_) {
    observations(picked_, angles_);
    epoch_sink_({&epoch.tag_id, epoch.utime, &picked_, &angles_});
  }
  if (!track_) return;
  if (params_.method == AoaMethod::kPerEpoch) {
    per_epoch(t, epoch.tag_id, epoch.utime, picked_);
    return;
  }
  if (t.initialised &&
      epoch.utime - t.last_accept_utime > s_to_utime(params_.max_coast_s)) {
    t.initialised = false;  // lost: start again from a fix
  }
  if (!t.initialised) {
    if (initialise(t, epoch.utime, picked_)) {
      if (params_.motion == AoaMotion::kConstantVelocity) {
        if (t.planar) publish_filter(t, t.cv2, epoch.tag_id, epoch.utime);
        else publish_filter(t, t.cv3, epoch.tag_id, epoch.utime);
      } else {
        if (t.planar) publish_filter(t, t.rw2, epoch.tag_id, epoch.utime);
        else publish_filter(t, t.rw3, epoch.tag_id, epoch.utime);
      }
    }
    return;
  }
  if (params_.motion == AoaMotion::kConstantVelocity) {
    if (t.planar) filter_epoch(t, t.cv2, epoch.tag_id, epoch.utime, picked_);
    else filter_epoch(t, t.cv3, epoch.tag_id, epoch.utime, picked_);
  } else {
    if (t.planar) filter_epoch(t, t.rw2, epoch.tag_id, epoch.utime, picked_);
    else filter_epoch(t, t.rw3, epoch.tag_id, epoch.utime, picked_);
  }
}

std::optional<AoaSolution> AoaEstimator::fix(const Track& t, const std::vector<AoaEvent>& events,
                                             const std::optional<Eigen::Vector3d>& start) {
  if (static_cast<int>(events.size()) < params_.min_anchors) {
    ++stats_.epochs_too_few_anchors;
    return std::nullopt;
  }
  AoaSolveOptions o = params_.solve;
  o.solver = params_.solver;
  o.three_d = !t.planar;
  o.height_m = t.height_m;
  o.initial = start;
  observations(events, angles_);
  const std::vector<BearingObservation>& obs = angles_;
  AoaSolution s = solve_aoa(obs, o);
  if (!s.ok && o.initial) {  // a bad warm start must not lose the tag: start from the lines
    o.initial.reset();
    s = solve_aoa(obs, o);
  }
  if (!s.ok) {
    ++stats_.solve_failures;
    return std::nullopt;
  }
  const double var_h = s.covariance(0, 0) + s.covariance(1, 1);
  if (!(var_h <= params_.max_fix_sigma_m * params_.max_fix_sigma_m)) {
    ++stats_.fixes_poor_geometry;
    return std::nullopt;
  }
  Eigen::Vector3d p = s.position;
  if (t.planar) p.z() = std::clamp(p.z(), box_min_.z(), box_max_.z());  // 2D: height given
  if (!inside_site(p)) {
    ++stats_.fixes_outside;
    return std::nullopt;
  }
  return s;
}

void AoaEstimator::per_epoch(Track& t, const std::string& tag_id, utime_t utime,
                             const std::vector<AoaEvent>& events) {
  const auto found = fix(t, events, params_.warm_start ? t.last_fix : std::nullopt);
  if (!found) return;
  const AoaSolution& s = *found;
  stats_.angles_used += static_cast<int64_t>(events.size());
  if (!t.last_fix) ++stats_.initialisations;
  t.last_fix = s.position;
  t.last_fix_utime = utime;
  if (!t.tally.due(utime, params_.publish_period_s)) return;
  pose_t p;
  p.utime = utime;
  p.source = source_;
  p.tag_id = tag_id;
  for (int k = 0; k < 3; ++k) {
    p.position[k] = s.position(k);
    p.velocity[k] = kNaN;
    for (int j = 0; j < 3; ++j) p.position_cov[3 * k + j] = s.covariance(k, j);
  }
  p.heading_rad = kNaN;
  for (size_t i = 0; i < events.size(); ++i) t.tally.add(s.rms_residual_m);
  emit(t, p, utime);
}

bool AoaEstimator::initialise(Track& t, utime_t utime, const std::vector<AoaEvent>& events) {
  const auto found = fix(t, events, std::nullopt);
  if (!found) return false;
  const AoaSolution& s = *found;
  const double p0 = params_.initial_sigma_m * params_.initial_sigma_m;
  const double v0 = params_.initial_velocity_sigma_mps * params_.initial_velocity_sigma_mps;
  if (t.planar) {
    t.cv2.x << s.position.x(), s.position.y(), 0, 0;
    t.cv2.P = Mat<4>::Identity() * p0;
    t.cv2.P.bottomRightCorner<2, 2>() = Mat<2>::Identity() * v0;
    t.rw2.x = s.position.head<2>();
    t.rw2.P = Mat<2>::Identity() * p0;
  } else {
    t.cv3.x << s.position, Eigen::Vector3d::Zero();
    t.cv3.P = Mat<6>::Identity() * p0;
    t.cv3.P.bottomRightCorner<3, 3>() = Mat<3>::Identity() * v0;
    t.rw3.x = s.position;
    t.rw3.P = Mat<3>::Identity() * p0;
  }
  if (t.filter_utime != 0) t.tally.reinitialised = true;
  t.initialised = true;
  t.filter_utime = utime;
  t.last_accept_utime = utime;
  t.verdicts.clear();
  t.observable_utime = utime;
  stats_.angles_used += static_cast<int64_t>(events.size());
  for (size_t i = 0; i < events.size(); ++i) t.tally.add(s.rms_residual_m);
  ++stats_.initialisations;
  return true;
}

template <class F>
Eigen::Vector3d AoaEstimator::track_position(const Track& t, const F& f) const {
  constexpr int D = F::N == 4 || F::N == 2 ? 2 : 3;
  return site_point<D>(Vec<D>(f.x.template head<D>()), t.height_m);
}

template <class F>
void AoaEstimator::filter_epoch(Track& t, F& f, const std::string& tag_id, utime_t utime,
                                const std::vector<AoaEvent>& events) {
  constexpr int D = F::N == 4 || F::N == 2 ? 2 : 3;
  const double dt = utime_to_s(utime - t.filter_utime);
  if (dt > 0) {
    f.predict(dt, params_.motion == AoaMotion::kConstantVelocity ? params_.accel_psd
                                                                  : params_.random_walk_psd);
    t.filter_utime = utime;
  }
  bool any_accepted = false;
  for (const AoaEvent& e : events) {
    const AnchorFrame& frame = frames_[e.anchor];
    const Eigen::Vector3d rel = track_position(t, f) - frame.position;
    const double distance = rel.norm();
    for (int k = 0; k < (D == 3 ? 2 : 1); ++k) {
      const AngleKind kind = k == 0 ? AngleKind::kAzimuth : AngleKind::kElevation;
      const double z = deg_to_rad(k == 0 ? e.azimuth_deg : e.elevation_deg);
      if (!std::isfinite(z)) continue;
      // Next to the anchor its bearing is undefined: the angle fades out (aoa_solvers.hpp).
      const double sigma = near_anchor_sigma(
          sigma_rad(k == 0 ? params_.azimuth_sigma_deg : params_.elevation_sigma_deg,
                    e.azimuth_deg, e.elevation_deg),
          k == 0 ? rel.head<2>().norm() : distance, params_.solve.near_anchor_m);
      // The anchor's learned angle variance (a scale on the configured one, core/consistency.hpp).
      const char* monitor_kind = k == 0 ? "ANGLE" : "ELEVATION";
      const std::string& anchor_id = site_->anchors[e.anchor].id;
      const double r_cfg = sigma * sigma;
      const double r_use = consistency_.variance(monitor_kind, anchor_id, r_cfg);
      const AngleUpdate u = angle_update<D, F::N>(f.x, f.P, frame, t.height_m, kind, z,
                                                  std::sqrt(r_use), params_.gate_sigma);
      if (!u.valid) continue;
      consistency_.add_scalar(monitor_kind, anchor_id, utime_to_s(utime), u.innovation_rad, u.hph,
                              r_cfg, !u.accepted, k == 0 ? azimuth_setting_ : elevation_setting_);
      t.verdicts.push_back({utime, e.anchor, u.accepted});
      if (u.accepted) {
        ++stats_.angles_used;
        t.tally.add(u.innovation_rad * distance);
        any_accepted = true;
      } else {
        ++stats_.rejected_gate;
      }
    }
  }
  if (any_accepted) t.last_accept_utime = utime;
  keep_off_anchors(t, f, events);
  const utime_t window = s_to_utime(params_.disagree_window_s);
  while (!t.verdicts.empty() && t.verdicts.front().utime < utime - window) t.verdicts.pop_front();
  int accepted = 0, rejected = 0;
  size_t first_anchor = SIZE_MAX;
  bool two_anchors = false;
  for (const auto& v : t.verdicts) {
    if (!v.accepted) {
      ++rejected;
      continue;
    }
    ++accepted;
    if (first_anchor == SIZE_MAX) first_anchor = v.anchor;
    else if (v.anchor != first_anchor) two_anchors = true;
  }
  if (two_anchors) t.observable_utime = utime;
  const char* restart = nullptr;
  if (!inside_site(track_position(t, f))) {
    restart = "outside";
    ++stats_.reinit_outside;
  } else if (rejected >= params_.reinit_after_rejections && rejected > accepted) {
    // Most recent angles disagree with the track: it is wrong (a multipath burst pulled it off,
    // or the tag moved faster than the model allows).
    restart = "disagree";
    ++stats_.reinit_disagree;
  } else if (utime - t.observable_utime > s_to_utime(params_.max_coast_s)) {
    restart = "unobservable";  // one bearing line only, for too long
    ++stats_.reinit_unobservable;
  }
  if (restart) {
    // Start again from this epoch's fix; without one the track is lost until the next.
    t.initialised = false;
    if (initialise(t, utime, events)) publish_filter(t, f, tag_id, utime);
    return;
  }
  publish_filter(t, f, tag_id, utime);
}

template <class F>
void AoaEstimator::keep_off_anchors(Track& t, F& f, const std::vector<AoaEvent>& events) {
  constexpr int D = F::N == 4 || F::N == 2 ? 2 : 3;
  const double r = params_.min_anchor_distance_m;
  if (!(r > 0)) return;
  for (size_t a = 0; a < frames_.size(); ++a) {
    if (!usable_[a]) continue;
    const AnchorFrame& frame = frames_[a];
    const Eigen::Vector3d p = track_position(t, f);
    Eigen::Vector3d rel = p - frame.position;
    if constexpr (D == 2) rel.z() = 0;  // 2D: the anchor's vertical axis
    if (rel.norm() >= r) continue;
    // The direction: the anchor's own measured bearing in this epoch, else away from it as the
    // state already is, else its antenna normal.
    Eigen::Vector3d dir = rel;
    for (const AoaEvent& e : events) {
      if (e.anchor != a) continue;
      const double az = deg_to_rad(e.azimuth_deg);
      const double el = D == 3 && std::isfinite(e.elevation_deg) ? deg_to_rad(e.elevation_deg) : 0;
      dir = frame.site_from_anchor *
            Eigen::Vector3d(std::cos(el) * std::cos(az), -std::cos(el) * std::sin(az), std::sin(el));
    }
    if constexpr (D == 2) dir.z() = 0;
    if (!(dir.norm() > 1e-9)) dir = frame.site_from_anchor.col(0);
    if constexpr (D == 2) dir.z() = 0;
    if (!(dir.norm() > 1e-9)) continue;
    const Eigen::Vector3d moved = frame.position + r * dir.normalized();
    f.x.template head<D>() = moved.head<D>();
    ++stats_.moved_off_anchor;
  }
}

template <class F>
void AoaEstimator::publish_filter(Track& t, const F& f, const std::string& tag_id,
                                  utime_t utime) {
  if (!t.tally.due(utime, params_.publish_period_s)) return;
  pose_t p;
  p.utime = utime;
  p.source = source_;
  p.tag_id = tag_id;
  if constexpr (F::N == 4 || F::N == 6) {
    fill_pose_from_cv<F::N / 2>(f, t.height_m, p);
  } else {
    constexpr int D = F::N;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    cov.topLeftCorner<D, D>() = f.P;
    const Eigen::Vector3d pos = track_position(t, f);
    for (int k = 0; k < 3; ++k) {
      p.position[k] = pos(k);
      p.velocity[k] = kNaN;  // a random walk has no velocity
      for (int j = 0; j < 3; ++j) p.position_cov[3 * k + j] = cov(k, j);
    }
    p.heading_rad = kNaN;
  }
  emit(t, p, utime);
}

void AoaEstimator::emit(Track& t, pose_t& p, utime_t utime) {
  t.tally.finish(p, t.planar, utime);
  if (params_.method == AoaMethod::kEkf && t.observable_utime != 0 &&
      utime - t.observable_utime > s_to_utime(params_.single_anchor_s)) {
    p.status &= ~pose_t::STATUS_OK;  // one anchor's bearing only: a line, not a position
    ++stats_.poses_not_ok;
  }
  ++stats_.poses_out;
  sink_(p);
}

}  // namespace ips::aoa
