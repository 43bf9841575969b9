#include "fusion/fuse_estimator.hpp"

#include <cstdio>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/geometry.hpp"
#include "core/multilateration.hpp"
#include "core/device_text.hpp"
#include "core/text_escape.hpp"
#include "estimators/aoa/models/aoa_bearing.hpp"
#include "estimators/uwb_twr/models/uwb_range.hpp"
#include "fusion/models/height.hpp"
#include "fusion/models/position.hpp"
#include "fusion/models/tdoa.hpp"

namespace ips::fusion {

namespace {
constexpr double kMaxRangeM = 1000.0;
constexpr double kMaxCoordinateM = 1e5;
constexpr double kPlanarVar = 1e-12;  // z and vz in 2D: known
constexpr size_t kMaxHistory = 10000;  // per tag, whatever max_delay_s allows

bool finite_position(const pose_t& m) {
  for (double v : m.position)
    if (!std::isfinite(v) || std::abs(v) > kMaxCoordinateM) return false;
  return true;
}

// A pose's position covariance, or nullopt when it has none usable (NaN, not positive).
std::optional<Eigen::Matrix3d> pose_covariance(const pose_t& m, bool horizontal_only) {
  Eigen::Matrix3d c;
  for (int i = 0; i < 9; ++i) c(i / 3, i % 3) = m.position_cov[i];
  const int n = horizontal_only ? 2 : 3;
  if (!c.topLeftCorner(n, n).allFinite()) return std::nullopt;
  for (int i = 0; i < n; ++i)
    if (!(c(i, i) > 0)) return std::nullopt;
  return c;
}

const char* displacement_channel(DisplacementSource s) {
  switch (s) {
    case DisplacementSource::kInsModule: return "INS_MODULE";
    case DisplacementSource::kPoseIns: return "POSE_INS";
    case DisplacementSource::kStep: return "STEP";
    case DisplacementSource::kAuto:
    case DisplacementSource::kNone: break;
  }
  return "none";
}

// "T1: using INS_MODULE for displacements, ignoring STEP" (count 0: the note when it starts), or
// with the count, "..., ignored 60 STEP"; a configured `none` uses no source.
std::string ignored_text(const std::string& tag_id, DisplacementSource used,
                         DisplacementSource ignored, int64_t count = 0) {
  std::string s = printable(tag_id) + ": ";
  s += used == DisplacementSource::kNone
           ? std::string("no displacements (estimators.fuse.displacement: none)")
           : std::string("using ") + displacement_channel(used) + " for displacements";
  s += count == 0 ? std::string(", ignoring ")
                  : ", ignored " + std::to_string(count) + " ";
  return s + displacement_channel(ignored);
}
}  // namespace

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

template <class Again>
FuseEstimator::Track* FuseEstimator::track_for(const std::string& tag_id, utime_t t,
                                               Again&& again) {
  if (!site_) {
    ++stats_.messages_in;
    ++stats_.dropped_no_site;
    return nullptr;
  }
  if (tag_id.empty() || !plausible_utime(t)) {
    ++stats_.messages_in;
    ++stats_.dropped_invalid;
    return nullptr;
  }
  // A stamp far from the tag's timeline is held until confirmed (never the tag's newest); a
  // confirmed jump back in time starts the track afresh.
  if (!guard_.admit(tag_id, t, std::forward<Again>(again), [&] { restart_track(tag_id); }))
    return nullptr;
  return find_or_add_track(tag_id, t);
}

FuseEstimator::Track* FuseEstimator::track_for_checked(const std::string& tag_id, utime_t t,
                                                       int64_t hosted_reanchors_back,
                                                       int64_t& seen_reanchors_back) {
  // The hosted estimator's guard went back in time since its last epoch: so does the tag.
  const bool went_back = hosted_reanchors_back != seen_reanchors_back;
  seen_reanchors_back = hosted_reanchors_back;
  if (!guard_.note(tag_id, t, went_back)) {
    ++stats_.messages_in;
    ++stats_.dropped_late;  // old work handed over late (a blink closed after a silence)
    return nullptr;
  }
  if (went_back) restart_track(tag_id);
  guard_.release();  // the tag's messages held meanwhile that this stamp confirmed
  return find_or_add_track(tag_id, t);
}

void FuseEstimator::restart_track(const std::string& tag_id) {
  // Time went back: nothing the track holds is of the new timeline. Its tally stays, so that the
  // next pose is flagged REINITIALISED.
  auto it = tracks_.find(tag_id);
  if (it == tracks_.end()) return;
  Track fresh;
  fresh.tally = it->second.tally;
  fresh.ever_started = it->second.ever_started;
  fresh.absolute_seen = it->second.absolute_seen;
  it->second = std::move(fresh);
}

FuseEstimator::Track* FuseEstimator::find_or_add_track(const std::string& tag_id, utime_t t) {
  ++stats_.messages_in;
  auto it = tracks_.find(tag_id);
  if (it == tracks_.end()) {
    if (static_cast<int>(tracks_.size()) >= params_.max_tags) {
      ++stats_.dropped_too_many_tags;
      return nullptr;
    }
    it = tracks_.try_emplace(tag_id).first;
  }
  Track& track = it->second;
  if (track.initialised && t - track.newest > s_to_utime(params_.max_gap_s)) {
    // Nothing of the tag for longer than any coasting can bridge (the process stopped, the
    // machine swapped, the tag out of reach): extrapolating across would publish a confident
    // guess. The track starts afresh from the next fix, its first pose flagged REINITIALISED.
    track.initialised = false;
    track.history.clear();
    track.snapshots.clear();
    track.init_ranges.clear();
    track.waiting_since = 0;
    track.have_last_dr = false;
    ++stats_.gap_restarts;
    char text[160];
    std::snprintf(text, sizeof text, "%.1f s without input, track restarted from fresh measurements",
                  utime_to_s(t - track.newest));
    last_gap_ = printable(tag_id) + ": " + text;
  }
  // A start pose in the site wins over everything else, for the first start.
  const Tag* tag = site_->find_tag(tag_id);
  if (!track.initialised && !track.ever_started && tag && tag->has_start()) {
    Eigen::Vector3d p = tag->start_position;
    if (!std::isfinite(p.z())) p.z() = std::isfinite(tag->height_m) ? tag->height_m : 0.0;
    start(tag_id, track, t, p, params_.start_sigma_m);
  }
  return &track;
}

void FuseEstimator::start(const std::string& tag_id, Track& t, utime_t time,
                          const Eigen::Vector3d& p, double sigma_m) {
  FuseFilter f;
  f.planar = planar_for(tag_id);
  f.x.head<3>() = p;
  f.P.setZero();
  const double bias_sigma = deg_to_rad(params_.heading_bias_sigma_deg);
  for (int i = 0; i < 3; ++i) {
    f.P(i, i) = sigma_m * sigma_m;
    f.P(kVel + i, kVel + i) = 1.0;
  }
  f.P(kPsi, kPsi) = std::max(bias_sigma * bias_sigma, 1e-12);
  if (f.planar) {
    f.x(2) = tag_height(tag_id);
    f.P(2, 2) = kPlanarVar;
    f.P(kVel + 2, kVel + 2) = kPlanarVar;
  }
  if (t.initialised) ++stats_.restarts;
  t.initialised = true;
  t.ever_started = true;
  t.state = Snapshot{time, time, f, time, 0};
  t.base = t.state;
  t.history.clear();
  t.snapshots.clear();
  t.init_ranges.clear();
  t.waiting_since = 0;
  t.newest = std::max(t.newest, time);
  t.tally.restart(0, 0);
  ++stats_.initialisations;
}

void FuseEstimator::try_start_from_ranges(const std::string& tag_id, Track& t) {
  const utime_t newest = t.init_ranges.back().t;
  while (!t.init_ranges.empty() &&
         t.init_ranges.front().t < newest - s_to_utime(params_.epoch_window_s))
    t.init_ranges.pop_front();
  // The newest range of each anchor.
  std::map<int, double> latest;
  for (const auto& m : t.init_ranges) latest[m.anchor] = m.value;
  const bool planar = planar_for(tag_id);
  const int needed = planar ? 3 : 4;
  // As ips-uwb-twr: for the first second of waiting (and two epochs) one range more than a fix
  // needs, where the site has it, so that one NLOS range shows in the residual and is left out;
  // from the bare minimum nothing tells a 1.3 m long range, and the start would be that far off
  // with the geometry's small sigma.
  if (t.waiting_since == 0) t.waiting_since = t.init_ranges.front().t;
  int required = needed, enabled_uwb_anchors = 0;
  for (const auto& a : site_->anchors) enabled_uwb_anchors += a.enabled && a.kind == "uwb";
  if (newest - t.waiting_since <
      std::max<utime_t>(1'000'000, 2 * s_to_utime(params_.epoch_window_s)))
    required = std::min(needed + 1, enabled_uwb_anchors);
  if (static_cast<int>(latest.size()) < std::max(needed, required)) return;
  std::vector<RangeObservation> obs;
  for (const auto& [a, r] : latest) obs.push_back({site_->anchors[static_cast<size_t>(a)].position, r});
  MultilaterationOptions o;
  o.fixed_height = planar;
  o.height_m = planar ? tag_height(tag_id) : std::numeric_limits<double>::quiet_NaN();
  const double max_residual = 3.0 * params_.range_sigma_m + 0.2;
  const MultilaterationResult fix =
      multilaterate_dropping_one(obs, o, MultilaterationSolver::kLevenbergMarquardt, max_residual);
  if (!fix.ok) return;
  // The residual left (a consistent set still has some) widens the start as the noise does; a
  // start no spare range could check may hold an NLOS range of a metre or more.
  double sigma = std::max(params_.range_sigma_m,
                          std::sqrt(std::max(0.0, fix.covariance_unit.trace())) *
                              std::max(params_.range_sigma_m, fix.residual_rms_m));
  if (static_cast<int>(obs.size()) <= needed)
    sigma = std::max(sigma, uwb_twr::kUncheckedStartSigmaM);
  start(tag_id, t, newest, fix.position, sigma);
}

void FuseEstimator::predict(const Track& t, Snapshot& s, utime_t to) const {
  const double psi_walk = std::pow(deg_to_rad(params_.heading_bias_walk_deg_per_sqrt_s), 2);
  utime_t cursor = s.t;
  if (to <= cursor) return;
  // Constant velocity from a to b, turned by the gyro's turn meanwhile when there is one.
  // A displacement's velocity is its average, the direction it had in its middle: the turn is
  // counted from there.
  auto cv = [&](utime_t a, utime_t b) {
    const utime_t from = std::min(s.velocity_t, a);
    std::optional<double> mid, end;
    if (params_.gyro_turns) {
      mid = t.gyro.turn(from, a + (b - a) / 2);
      end = t.gyro.turn(from, b);
    }
    s.filter.predict_cv(utime_to_s(b - a), params_.accel_psd, psi_walk,
                        mid && end ? *mid : 0.0, mid && end ? *end : 0.0);
    s.velocity_t = b;
  };
  for (const Measurement& d : t.history) {
    if (d.kind != Measurement::Kind::kDisplacement || d.t <= cursor || d.t0 >= to) continue;
    const utime_t a = std::max(d.t0, cursor), b = std::min(d.t, to);
    if (b <= a) continue;
    if (a > cursor) cv(cursor, a);
    const double fraction = static_cast<double>(b - a) / static_cast<double>(d.t - d.t0);
    const Eigen::Vector3d part = fraction * d.vec;
    // The whole displacement's variance, shared out in proportion to time, so that splitting it
    // between other messages adds up to the same.
    const double sigma = std::sqrt(fraction) *
                         std::max(params_.displacement_sigma_min_m,
                                  params_.displacement_sigma_per_m * d.vec.norm());
    s.filter.predict_displacement(part, utime_to_s(b - a), sigma, psi_walk);
    s.velocity_t = d.t0 + (d.t - d.t0) / 2;
    cursor = b;
  }
  if (cursor < to) cv(cursor, to);
  s.t = to;
}

void FuseEstimator::apply(Track& t, Snapshot& s, const Measurement& m, bool live) {
  predict(t, s, m.t);
  FuseFilter& f = s.filter;
  switch (m.kind) {
    case Measurement::Kind::kRange: {
      uwb_twr::RangeNoise noise;
      const double r_cfg = params_.range_sigma_m * params_.range_sigma_m;
      const std::string& anchor_id = site_->anchors[static_cast<size_t>(m.anchor)].id;
      noise.r_var = consistency_.variance("RANGE", anchor_id, r_cfg);
      noise.gate_chi2 = params_.gate_sigma * params_.gate_sigma;
      noise.gate_chi2_positive = params_.nlos_gate_sigma * params_.nlos_gate_sigma;
      noise.downweight_sigma = params_.nlos_downweight_sigma;
      noise.r_var *= params_.nlos_power().variance_scale(m.nlos_p);  // rx - fp: likely NLOS
      // The offset taken off (learned: uncertain, uwb_twr/models/range_bias.hpp).
      if (t.offsets_set) noise.r_var += t.offsets.var_m2(static_cast<size_t>(m.anchor));
      const Eigen::Vector3d& anchor = site_->anchors[static_cast<size_t>(m.anchor)].position;
      const uwb_twr::RangeUpdate u =
          f.planar ? uwb_twr::range_update_state<2, kStateSize>(f.x, f.P, anchor, f.x(2),
                                                                m.value, noise)
                   : uwb_twr::range_update_state<3, kStateSize>(f.x, f.P, anchor, 0.0, m.value,
                                                                noise);
      count_absolute(s, m.t, u.accepted, live);
      if (live) {
        consistency_.add_scalar("RANGE", anchor_id, utime_to_s(m.t), u.innovation_m, u.hph, r_cfg,
                                !u.accepted, range_setting_);
        (u.accepted ? stats_.ranges_used : stats_.ranges_rejected)++;
        if (u.accepted && m.nlos_p > 0.5) ++stats_.ranges_nlos_power;
        if (u.accepted) {
          t.tally.add(u.innovation_m);
          t.sources |= kSrcRange;
        }
      }
      break;
    }
    case Measurement::Kind::kTdoa: {
      const TdoaUpdate u = update_tdoa(f, std::get<TdoaArrivals>(m.group),
                                       params_.tdoa_gate_sigma * params_.tdoa_gate_sigma);
      count_absolute(s, m.t, u.accepted, live);
      if (live) {
        (u.accepted ? stats_.tdoa_epochs_used : stats_.tdoa_epochs_rejected)++;
        if (u.accepted) {
          stats_.tdoa_differences_used += u.used;
          t.tally.add_many(u.used, u.innovation_sq);
          t.sources |= kSrcTdoa;
        }
      }
      break;
    }
    case Measurement::Kind::kAngles: {
      const Angles& a = std::get<Angles>(m.group);
      bool any = false;
      for (int i = 0; i < a.count; ++i) {
        const aoa::AnchorFrame& frame = frames_[static_cast<size_t>(a.anchor[i])];
        const aoa::BearingObservation& o = a.angle[i];
        const double distance = (f.x.head<3>() - frame.position).norm();
        for (int k = 0; k < (f.planar ? 1 : 2); ++k) {
          const aoa::AngleKind kind = k == 0 ? aoa::AngleKind::kAzimuth : aoa::AngleKind::kElevation;
          const double z = k == 0 ? o.azimuth_rad : o.elevation_rad;
          const double sigma = k == 0 ? o.azimuth_sigma_rad : o.elevation_sigma_rad;
          if (!std::isfinite(z)) continue;
          const aoa::AngleUpdate u =
              f.planar ? aoa::angle_update<2, kStateSize>(f.x, f.P, frame, f.x(2), kind, z, sigma,
                                                           params_.angle_gate_sigma)
                       : aoa::angle_update<3, kStateSize>(f.x, f.P, frame, 0.0, kind, z, sigma,
                                                           params_.angle_gate_sigma);
          if (!u.valid) continue;
          any = any || u.accepted;
          if (live) {
            consistency_.add_nis("ANGLE", site_->anchors[static_cast<size_t>(a.anchor[i])].id,
                                 utime_to_s(m.t), u.normalised * u.normalised, 1, !u.accepted,
                                 "the anchor's angle sigma");
            (u.accepted ? stats_.angles_used : stats_.angles_rejected)++;
            if (u.accepted) {
              t.tally.add(u.innovation_rad * distance);
              t.sources |= kSrcAngles;
            }
          }
        }
      }
      // Angles are weak next to ranges: they do not count as gated ranges do (a tag the ranges
      // have lost is not found again by its bearings).
      if (any) s.last_absolute = m.t;
      break;
    }
    case Measurement::Kind::kHeight: {
      if (f.planar) break;
      const UpdateResult u = update_height(f, m.value, m.sigma,
                                           params_.height_gate_sigma * params_.height_gate_sigma);
      if (u.accepted) s.last_absolute = m.t;
      if (live) {
        consistency_.add_nis("HEIGHT", "ALTITUDE", utime_to_s(m.t), u.mahalanobis_sq, 1, !u.accepted,
                             "ips-altitude's height sigma");
        (u.accepted ? stats_.heights_used : stats_.heights_rejected)++;
        if (u.accepted) t.sources |= kSrcAltitude;
      }
      break;
    }
    case Measurement::Kind::kPosition: {
      const UpdateResult u = update_position(f, m.vec, m.cov, m.horizontal_only,
                                             params_.pose_gate_sigma * params_.pose_gate_sigma);
      if (u.accepted) s.last_absolute = m.t;
      if (live) {
        consistency_.add_nis("POSE", m.pose_kind, utime_to_s(m.t), u.mahalanobis_sq,
                             m.horizontal_only || f.planar ? 2 : 3, !u.accepted,
                             setting_text("pose_cov_scale", params_.pose_cov_scale));
        (u.accepted ? stats_.poses_used : stats_.poses_rejected)++;
        if (u.accepted) {
          t.sources |= kSrcPose;
          if (std::find(t.pose_kinds.begin(), t.pose_kinds.end(), m.pose_kind) ==
              t.pose_kinds.end())
            t.pose_kinds.push_back(m.pose_kind);
        }
      }
      break;
    }
    case Measurement::Kind::kDisplacement:
      if (live) {
        ++stats_.displacements_used;
        t.sources |= m.source;
      }
      break;
  }
}

void FuseEstimator::count_absolute(Snapshot& s, utime_t t, bool accepted, bool live) {
  if (accepted) {
    s.last_absolute = t;
    s.rejections = 0;
  } else if (++s.rejections >= params_.reinit_after_rejections) {
    // Gated again and again: the track has lost the tag. Widen it so that the ranges are taken
    // again (a re-acquisition, not a jump past the gate of one range).
    FuseFilter& f = s.filter;
    for (int i = 0; i < (f.planar ? 2 : 3); ++i) f.P(i, i) += 1.0;
    s.rejections = 0;
    if (live) ++stats_.restarts;
  }
}

void FuseEstimator::add(const std::string& tag_id, Track& t, Measurement m) {
  if (!t.initialised) {
    ++stats_.waiting_start;
    return;
  }
  const utime_t from = m.kind == Measurement::Kind::kDisplacement ? m.t0 : m.t;
  const utime_t window = s_to_utime(params_.max_delay_s);
  if (from < t.base.t) {  // before anything the track can roll back to
    ++stats_.dropped_late;
    return;
  }
  t.newest = std::max(t.newest, m.t);
  if (m.kind != Measurement::Kind::kDisplacement) t.absolute_seen = true;
  // In time order into the history.
  auto pos = std::upper_bound(t.history.begin(), t.history.end(), m.t,
                              [](utime_t v, const Measurement& h) { return v < h.t; });
  const size_t index = static_cast<size_t>(pos - t.history.begin());
  t.history.insert(pos, m);
  if (from >= t.state.t && index + 1 == t.history.size()) {
    apply(t, t.state, t.history.back(), true);
    t.snapshots.push_back(t.state);
  } else {
    // Late, or a displacement reaching back over fused messages: from the last snapshot at or
    // before `from`, fuse again in order.
    ++stats_.rollbacks;
    size_t k = 0;  // entries [0, k) keep their snapshots
    while (k < t.snapshots.size() && k < t.history.size() && t.history[k].t <= from &&
           k != index)
      ++k;
    Snapshot s = k == 0 ? t.base : t.snapshots[k - 1];
    t.snapshots.resize(k);
    for (size_t j = k; j < t.history.size(); ++j) {
      apply(t, s, t.history[j], j == index);
      t.snapshots.push_back(s);
    }
    t.state = s;
  }
  // Forget what no late message can reach any more (keeping the base to roll back to).
  while (t.history.size() > 1 &&
         (t.history.front().t < t.newest - window || t.history.size() > kMaxHistory)) {
    t.base = t.snapshots.front();
    t.history.pop_front();
    t.snapshots.pop_front();
  }
  maybe_publish(tag_id, t);
}

void FuseEstimator::maybe_publish(const std::string& tag_id, Track& t) {
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
  const double speed = std::hypot(f.x(kVel), f.x(kVel + 1));
  p.heading_rad = speed > 0.2 ? std::atan2(f.x(kVel + 1), f.x(kVel))
                              : std::numeric_limits<double>::quiet_NaN();
  t.tally.finish(p, f.planar, t.state.t);
  t.sources = 0;
  t.pose_kinds.clear();
  ++stats_.poses_out;
  sink_(p);
}

bool FuseEstimator::accept_displacement(const std::string& tag_id, Track& t,
                                        DisplacementSource src) {
  if (params_.displacement == DisplacementSource::kAuto) {
    if (t.displacement == DisplacementSource::kNone) t.displacement = src;
  } else {
    t.displacement = params_.displacement;
  }
  if (t.displacement == src) return true;
  // One source moves a tag (a second would count the same walk twice): the others are left
  // unused on purpose, which is no fault of the input. Said once per tag and source.
  ++stats_.ignored_other_source;
  IgnoredSource& ignored = ignored_[{tag_id, src}];
  if (ignored.count++ == 0) {
    ignored.used = t.displacement;
    if (note_sink_) note_sink_(ignored_text(tag_id, ignored.used, src));
  }
  return false;
}

std::string FuseEstimator::run_notes() const {
  std::string s;
  for (const auto& [key, ignored] : ignored_) {
    s += s.empty() ? "" : "; ";
    s += ignored_text(key.first, ignored.used, key.second, ignored.count);
  }
  return s;
}

void FuseEstimator::learn_offsets(Track& t, const Measurement& r) {
  if (!radio_.learn_bias) return;
  t.epoch_ranges.push_back(r);
  const utime_t window = s_to_utime(params_.epoch_window_s);
  while (t.epoch_ranges.size() > 64 ||
         (t.epoch_ranges.size() > 1 && r.t - t.epoch_ranges.front().t > window))
    t.epoch_ranges.pop_front();
  // One epoch per ips-uwb-twr epoch window, on a running track.
  if (!t.initialised ||
      (t.last_offsets_t != 0 && r.t - t.last_offsets_t < s_to_utime(radio_.epoch_window_s)))
    return;
  std::map<size_t, std::pair<utime_t, double>> latest;
  for (const auto& e : t.epoch_ranges) latest[static_cast<size_t>(e.anchor)] = {e.t, e.value};
  const FuseFilter& f = t.state.filter;
  const int dims = f.planar ? 2 : 3;
  std::vector<Eigen::Vector3d> positions;
  double r_var = 0;
  for (const auto& a : site_->anchors) {
    positions.push_back(a.position);
    r_var = std::max(r_var, consistency_.variance("RANGE", a.id,
                                                  params_.range_sigma_m * params_.range_sigma_m));
  }
  const Eigen::Vector3d track = f.x.head<3>();
  Eigen::Vector3d v = f.x.segment<3>(kVel);
  if (f.planar) v.z() = 0;
  t.last_offsets_t = r.t;
  uwb_twr::learn_offsets_from_epoch(
      t.offsets, latest, positions, r.t, track, v, f.P.topLeftCorner(dims, dims).trace(), dims,
      params_.range_sigma_m, r_var, 1.0 - 1.0 / radio_.bias_window, radio_.bias_max_m,
      MultilaterationSolver::kLevenbergMarquardt);
}

void FuseEstimator::on_range(const uwb_range_t& m) {
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_range(m); });
  if (!t) return;
  if (!std::isfinite(m.range_m) || m.range_m < 0 || m.range_m > kMaxRangeM) {
    ++stats_.dropped_invalid;
    return;
  }
  const Anchor* a = site_->find_anchor(m.anchor_id);
  if (!a || !a->enabled) {
    ++stats_.dropped_unknown_anchor;
    return;
  }
  Measurement r;
  r.kind = Measurement::Kind::kRange;
  r.t = m.utime;
  r.anchor = static_cast<int>(a - site_->anchors.data());
  if (!t->offsets_set) {  // the prior and the configured scales: as ips-uwb-twr's
    t->offsets = uwb_twr::initial_offsets(radio_, m.tag_id, site_->anchors);
    t->offsets_set = true;
  }
  r.value = t->offsets.unscaled(
      static_cast<size_t>(r.anchor),
      uwb_twr::corrected_range(m.range_m, params_.range_bias_m, params_.range_bias_per_m));
  r.nlos_p = params_.nlos_power().likelihood(m.rx_power_dbm, m.fp_power_dbm);
  r.source = kSrcRange;
  learn_offsets(*t, r);
  // The pair's offset off before use: the gate judges what is left (an antenna delay is not NLOS).
  r.value -= t->offsets.offset_m(static_cast<size_t>(r.anchor));
  if (!t->initialised) {
    t->init_ranges.push_back(r);
    if (t->init_ranges.size() > 64) t->init_ranges.pop_front();
    try_start_from_ranges(m.tag_id, *t);
    if (!t->initialised) ++stats_.waiting_start;
    return;
  }
  add(m.tag_id, *t, r);
}

DropReasons FuseEstimator::drop_reasons() const {
  const FuseStats& s = stats_;
  DropReasons d;
  d.add(DropReason::kNoSite, s.dropped_no_site);
  d.add(DropReason::kInvalid, s.dropped_invalid);
  d.add(DropReason::kNoReference, s.dropped_relative_height);
  d.add(DropReason::kUnknownAnchor, s.dropped_unknown_anchor);
  d.add(DropReason::kLate, s.dropped_late);
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

void FuseEstimator::on_rx(const uwb_rx_t& m) {
  if (have_site_for_raw()) tdoa_.on_rx(m);  // its blinks come back through on_tdoa_epoch
}

void FuseEstimator::on_pair(const uwb_tdoa_t& m) {
  if (!have_site_for_raw()) return;
  // Applied to the track first (as a blink goes before its hosted fix); the hosted pair tracker
  // then counts it (its drops are this process's) and, for a tag without a track, starts one.
  const Anchor* a = site_->find_anchor(m.anchor_a);
  const Anchor* b = site_->find_anchor(m.anchor_b);
  const bool usable = a && b && a != b && a->enabled && b->enabled && a->kind == "uwb_tdoa" &&
                      b->kind == "uwb_tdoa" && std::isfinite(m.diff_m) &&
                      std::abs(m.diff_m) <= (b->position - a->position).norm() + 1.0 &&
                      plausible_utime(m.utime) && valid_device_id(m.tag_id) &&
                      (std::isnan(m.sigma_m) || (m.sigma_m > 0 && m.sigma_m <= 100));
  if (usable) {
    Track* t = track_for_checked(m.tag_id, m.utime, tdoa_.time_stats().reanchors_back,
                                 tdoa_reanchors_back_);
    if (t && t->initialised) {
      const double sigma = std::isnan(m.sigma_m) ? tdoa_.params().pairs.pair_sigma_m
                                                 : static_cast<double>(m.sigma_m);
      Measurement meas;
      meas.kind = Measurement::Kind::kTdoa;
      meas.t = m.utime;
      meas.source = kSrcTdoa;
      meas.group.emplace<TdoaArrivals>(pair_arrivals(a->position, b->position, m.diff_m,
                                                     sigma * sigma));
      t->tight_tdoa = true;
      add(m.tag_id, *t, meas);
    }
  }
  tdoa_.on_pair(m);
}

void FuseEstimator::on_tdoa_epoch(const uwb_tdoa::TdoaEpoch& e) {
  Track* t = track_for_checked(*e.tag_id, e.utime, tdoa_.time_stats().reanchors_back,
                               tdoa_reanchors_back_);
  // A blink says where the tag is only relative to the anchors' hyperboloids: the track starts
  // from something else (ranges, a start pose, POSE_TDOA, or the hosted tracker's fix from the
  // blinks: on_hosted_fix, right after this).
  if (!t || !t->initialised) return;
  // The nearest anchors to the estimate, nearest first (the most likely direct paths).
  std::array<int, uwb_tdoa::kMaxEpochArrivals> order;
  for (int k = 0; k < e.count; ++k) order[k] = k;
  const Eigen::Vector3d p = t->state.filter.x.head<3>();
  std::sort(order.begin(), order.begin() + e.count, [&](int a, int b) {
    return (e.anchor[a] - p).squaredNorm() < (e.anchor[b] - p).squaredNorm();
  });
  Measurement m;
  m.kind = Measurement::Kind::kTdoa;
  m.t = e.utime;
  m.source = kSrcTdoa;
  TdoaArrivals& a = m.group.emplace<TdoaArrivals>();
  a.count = std::min(e.count, kMaxTdoaArrivals);
  for (int k = 0; k < a.count; ++k) {
    a.anchor[k] = e.anchor[order[k]];
    a.range_m[k] = e.range_m[order[k]];
    a.var_m2[k] = e.var_m2[order[k]];
  }
  t->tight_tdoa = true;
  add(*e.tag_id, *t, m);
}

void FuseEstimator::on_aoa(const ble_aoa_t& m) {
  if (have_site_for_raw()) aoa_.on_event(m);  // its epochs come back through on_aoa_epoch
}

void FuseEstimator::on_aoa_epoch(const aoa::AoaEpochAngles& e) {
  Track* t = track_for_checked(*e.tag_id, e.utime, aoa_.time_stats().reanchors_back,
                               aoa_reanchors_back_);
  // Angles start no track here: the hosted tracker's fix from them does (on_hosted_fix), as
  // POSE_AOA can.
  if (!t || !t->initialised || e.picked->empty()) return;
  Measurement m;
  m.kind = Measurement::Kind::kAngles;
  m.t = e.utime;
  m.source = kSrcAngles;
  Angles& a = m.group.emplace<Angles>();
  for (size_t i = 0; i < e.picked->size() && a.count < kMaxAngles; ++i) {
    a.anchor[a.count] = static_cast<int>((*e.picked)[i].anchor);
    a.angle[a.count] = (*e.angles)[i];
    a.angle[a.count].frame = nullptr;
    ++a.count;
  }
  t->tight_aoa = true;
  add(*e.tag_id, *t, m);
}

void FuseEstimator::on_hosted_fix(const pose_t& m) {
  // The epoch went through on_tdoa_epoch / on_aoa_epoch first, so the track exists unless the tag
  // was refused (too many tags).
  const auto it = tracks_.find(m.tag_id);
  if (it == tracks_.end() || it->second.initialised) return;
  const bool horizontal_only = (m.status & pose_t::STATUS_2D) != 0;
  const auto cov = pose_covariance(m, horizontal_only);
  if (!finite_position(m) || !cov) return;
  const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
  start(m.tag_id, it->second, m.utime, p, std::sqrt(std::max(cov->trace() / 3.0, 1e-6)));
  ++stats_.hosted_starts;
}

void FuseEstimator::on_dead_reckoning(const pose_t& m, DisplacementSource src, uint32_t bit) {
  Track* t = track_for(m.tag_id, m.utime, [this, m, src, bit] { on_dead_reckoning(m, src, bit); });
  if (!t) return;
  if (!finite_position(m)) {
    ++stats_.dropped_invalid;
    return;
  }
  if (!accept_displacement(m.tag_id, *t, src)) return;
  const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
  if (!t->have_last_dr || m.utime <= t->last_dr_t) {
    if (t->have_last_dr) {
      ++stats_.dropped_invalid;  // not after the previous one
      return;
    }
    t->have_last_dr = true;
    t->last_dr_t = m.utime;
    t->last_dr_position = p;
    // Its first position starts the track when nothing else has (001: the module starts where
    // the walk does); after a gap, only a track that never had a fix of the site's frame.
    if (!t->initialised && (!t->ever_started || !t->absolute_seen))
      start(m.tag_id, *t, m.utime, p, params_.start_sigma_m);
    return;
  }
  Measurement d;
  d.kind = Measurement::Kind::kDisplacement;
  d.t0 = t->last_dr_t;
  d.t = m.utime;
  d.vec = p - t->last_dr_position;
  d.source = bit;
  t->dr_bit = bit;
  t->last_dr_t = m.utime;
  t->last_dr_position = p;
  if (t->initialised) add(m.tag_id, *t, d);
  else if (!t->ever_started || !t->absolute_seen) start(m.tag_id, *t, m.utime, p, params_.start_sigma_m);
}

void FuseEstimator::on_ins_module(const pose_t& m) {
  on_dead_reckoning(m, DisplacementSource::kInsModule, kSrcInsModule);
}

void FuseEstimator::on_pose_ins(const pose_t& m) {
  on_dead_reckoning(m, DisplacementSource::kPoseIns, kSrcPoseIns);
}

void FuseEstimator::on_step(const step_t& m) {
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_step(m); });
  if (!t) return;
  if (!std::isfinite(m.length_m) || m.length_m < 0 || m.length_m > 5 ||
      !m.heading_known || !std::isfinite(m.heading_rad)) {
    ++stats_.dropped_invalid;
    return;
  }
  if (!accept_displacement(m.tag_id, *t, DisplacementSource::kStep)) return;
  // A step covers the time since the previous one (at most 2 s: a first step, or after a stop).
  const utime_t longest = s_to_utime(2.0);
  const utime_t t0 = t->have_last_dr && m.utime > t->last_dr_t && m.utime - t->last_dr_t < longest
                         ? t->last_dr_t
                         : m.utime - (std::isfinite(m.cadence_hz) && m.cadence_hz > 0.3
                                          ? s_to_utime(1.0 / m.cadence_hz)
                                          : s_to_utime(0.5));
  if (t->have_last_dr && m.utime <= t->last_dr_t) {
    ++stats_.dropped_invalid;
    return;
  }
  t->have_last_dr = true;
  t->last_dr_t = m.utime;
  if (!t->initialised) {  // a step says nothing of where the tag is
    ++stats_.waiting_start;
    return;
  }
  Measurement d;
  d.kind = Measurement::Kind::kDisplacement;
  d.t0 = t0;
  d.t = m.utime;
  d.vec = Eigen::Vector3d(m.length_m * std::cos(m.heading_rad),
                          m.length_m * std::sin(m.heading_rad), 0.0);
  d.source = kSrcStep;
  t->dr_bit = kSrcStep;
  add(m.tag_id, *t, d);
}

void FuseEstimator::on_altitude(const altitude_t& m) {
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_altitude(m); });
  if (!t) return;
  if (!std::isfinite(m.height_m) || std::abs(m.height_m) > kMaxCoordinateM ||
      !(m.height_std_m > 0) || !std::isfinite(m.height_std_m)) {
    ++stats_.dropped_invalid;
    return;
  }
  // A single barometer's heights are relative to its first readings (ips-altitude's relative
  // mode, altitude_t.relative), not the site's z: not fused as absolute heights.
  if (m.relative) {
    ++stats_.dropped_relative_height;
    return;
  }
  Measurement h;
  h.kind = Measurement::Kind::kHeight;
  h.t = m.utime;
  h.value = m.height_m;
  h.sigma = std::max(m.height_std_m, 0.01);
  h.source = kSrcAltitude;
  add(m.tag_id, *t, h);
}

void FuseEstimator::on_imu(const imu_t& m) {
  if (!params_.gyro_turns) return;
  Track* t = track_for(m.device_id, m.utime, [this, m] { on_imu(m); });
  if (!t) return;
  const Eigen::Vector3d gyro(m.gyro[0], m.gyro[1], m.gyro[2]);
  const Eigen::Vector3d accel(m.accel[0], m.accel[1], m.accel[2]);
  if (!t->gyro.add(m.utime, gyro, accel)) {
    ++stats_.dropped_invalid;
    return;
  }
  ++stats_.imu_used;
}

void FuseEstimator::on_pose(const pose_t& m, const std::string& kind) {
  Track* t = track_for(m.tag_id, m.utime, [this, m, kind] { on_pose(m, kind); });
  if (!t) return;
  const bool horizontal_only = (m.status & pose_t::STATUS_2D) != 0;
  const auto cov = pose_covariance(m, horizontal_only);
  if (!finite_position(m) || !cov) {
    ++stats_.dropped_invalid;
    return;
  }
  if ((kind == "tdoa" && t->tight_tdoa) || (kind == "aoa" && t->tight_aoa)) {
    ++stats_.poses_superseded;
    return;
  }
  Measurement p;
  p.kind = Measurement::Kind::kPosition;
  p.t = m.utime;
  p.vec = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  p.cov = params_.pose_cov_scale * *cov;
  p.horizontal_only = horizontal_only;
  p.source = kSrcPose;
  p.pose_kind = kind;
  if (!t->initialised) {
    start(m.tag_id, *t, m.utime, p.vec, std::sqrt(std::max(cov->trace() / 3.0, 1e-6)));
    return;
  }
  add(m.tag_id, *t, p);
}

}  // namespace ips::fusion
