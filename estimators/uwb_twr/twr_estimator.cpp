#include "estimators/uwb_twr/twr_estimator.hpp"

#include <cmath>
#include <limits>
#include <vector>

#include "core/multilateration.hpp"

namespace ips::uwb_twr {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
}

TwrParams parse_twr_params(const YamlField& s) {
  TwrParams p;
  if (!s.defined()) return p;
  if (!s.is_map()) s.fail("expected a map of uwb_twr parameters");
  s.check_keys({"mode", "range_sigma_m", "accel_psd", "gate_sigma", "nlos_gate_sigma",
                "epoch_window_s", "init_velocity_sigma_mps", "reinit_after_rejections",
                "max_coast_s", "publish_period_s", "reorder_tolerance_s", "max_range_m",
                "max_tags"});
  // Every parameter is bounded, not just positive: a SITE message on the bus is outside input.
  auto positive = [&](const char* key, double& v) {
    v = s.get_double(key, v);
    if (!(v > 0 && v <= 1e6)) s[key].fail("must be in (0, 1e6]");
  };
  std::string mode = s.get_string("mode", "auto");
  if (mode != "auto" && mode != "3d") s["mode"].fail("expected auto (2D when the tag height is known) or 3d");
  p.force_3d = mode == "3d";
  positive("range_sigma_m", p.range_sigma_m);
  positive("accel_psd", p.accel_psd);
  positive("gate_sigma", p.gate_sigma);
  positive("nlos_gate_sigma", p.nlos_gate_sigma);
  positive("epoch_window_s", p.epoch_window_s);
  positive("init_velocity_sigma_mps", p.init_velocity_sigma_mps);
  positive("max_coast_s", p.max_coast_s);
  positive("publish_period_s", p.publish_period_s);
  positive("reorder_tolerance_s", p.reorder_tolerance_s);
  positive("max_range_m", p.max_range_m);
  p.reinit_after_rejections =
      static_cast<int>(s.get_int("reinit_after_rejections", p.reinit_after_rejections));
  if (p.reinit_after_rejections < 1 || p.reinit_after_rejections > 1000000)
    s["reinit_after_rejections"].fail("must be in [1, 1000000]");
  p.max_tags = static_cast<int>(s.get_int("max_tags", p.max_tags));
  if (p.max_tags < 1 || p.max_tags > 100000) s["max_tags"].fail("must be in [1, 100000]");
  return p;
}

TwrEstimator::TwrEstimator(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)), source_(std::move(source_name)) {}

void TwrEstimator::set_site(const Site& site) {
  params_ = parse_twr_params(site.estimator_params("uwb_twr"));
  site_ = site;
  tracks_.clear();
}

void TwrEstimator::on_range(const uwb_range_t& m) {
  ++stats_.ranges_in;
  if (!site_) return;
  if (!plausible_utime(m.utime) || !std::isfinite(m.range_m) || m.range_m < 0 ||
      m.range_m > params_.max_range_m) {
    ++stats_.dropped_invalid;
    return;
  }
  const Anchor* anchor = site_->find_anchor(m.anchor_id);
  if (!anchor || !anchor->enabled || anchor->kind != "uwb") {
    ++stats_.dropped_unknown_anchor;
    return;
  }
  if (m.tag_id.empty()) {
    ++stats_.dropped_invalid;
    return;
  }
  auto it = tracks_.find(m.tag_id);
  const bool inserted = it == tracks_.end();
  if (inserted) {
    // Tag ids come off an unauthenticated bus: bound the memory they can make us spend. A track
    // silent for 10 coast periods makes room first.
    if (tracks_.size() >= static_cast<size_t>(params_.max_tags)) {
      for (auto old = tracks_.begin(); old != tracks_.end();)
        old = m.utime - old->second.newest_utime > 10 * s_to_utime(params_.max_coast_s)
                  ? tracks_.erase(old)
                  : std::next(old);
    }
    if (tracks_.size() >= static_cast<size_t>(params_.max_tags)) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.tag_id).first;
  }
  Track& t = it->second;
  if (inserted) {
    const Tag* tag = site_->find_tag(m.tag_id);
    t.planar = !params_.force_3d && tag && std::isfinite(tag->height_m);
    t.height_m = t.planar ? tag->height_m : 0.0;
  }
  if (t.newest_utime != 0) {
    const utime_t behind = t.newest_utime - m.utime;
    if (behind > s_to_utime(params_.max_coast_s)) {
      // Time went back further than any reordering explains (a clock step, a replay restarted,
      // or one bogus future stamp before): start this track afresh rather than drop forever.
      ++stats_.time_resets;
      Track fresh;
      fresh.planar = t.planar;
      fresh.height_m = t.height_m;
      t = std::move(fresh);
    } else if (behind > s_to_utime(params_.reorder_tolerance_s)) {
      ++stats_.dropped_late;
      return;
    }
  }
  t.newest_utime = std::max(t.newest_utime, m.utime);
  t.recent.push_back({m.utime, m.anchor_id, m.range_m});
  while (t.recent.size() > 64 ||
         (t.recent.size() > 1 &&
          m.utime - t.recent.front().utime > s_to_utime(params_.epoch_window_s)))
    t.recent.pop_front();

  if (t.initialised && m.utime - t.last_accept_utime > s_to_utime(params_.max_coast_s))
    t.initialised = false;
  if (!t.initialised) {
    try_initialise(t, m.utime);
    return;
  }
  if (t.planar) {
    update<2>(t, t.f2, anchor->position, m);
    publish<2>(t, t.f2, m.tag_id, m.utime);
  } else {
    update<3>(t, t.f3, anchor->position, m);
    publish<3>(t, t.f3, m.tag_id, m.utime);
  }
}

template <int D>
void TwrEstimator::update(Track& t, CvFilter<D>& f, const Eigen::Vector3d& anchor,
                          const uwb_range_t& m) {
  if (m.utime > t.filter_utime) {
    f.predict(utime_to_s(m.utime - t.filter_utime), params_.accel_psd);
    t.filter_utime = m.utime;
  }
  const double r_var = params_.range_sigma_m * params_.range_sigma_m;
  // Asymmetric gate: a long range is probably NLOS, a short one is not.
  double innovation = 0;
  const UpdateResult r = range_update<D>(
      f, anchor, t.height_m, m.range_m, r_var, params_.gate_sigma * params_.gate_sigma,
      params_.nlos_gate_sigma * params_.nlos_gate_sigma, &innovation);
  if (!r.accepted) {
    ++stats_.rejected_gate;
    if (++t.consecutive_rejections >= params_.reinit_after_rejections) t.initialised = false;
    return;
  }
  ++stats_.ranges_used;
  t.consecutive_rejections = 0;
  t.last_accept_utime = std::max(t.last_accept_utime, m.utime);
  ++t.used_since_publish;
  t.sq_innov_since_publish += innovation * innovation;
}

void TwrEstimator::try_initialise(Track& t, utime_t now) {
  // The newest range per anchor within the epoch window.
  std::map<std::string, double> latest;
  for (const auto& e : t.recent)
    if (now - e.utime <= s_to_utime(params_.epoch_window_s)) latest[e.anchor_id] = e.range_m;
  std::vector<RangeObservation> obs;
  for (const auto& [id, r] : latest) obs.push_back({site_->find_anchor(id)->position, r});
  MultilaterationOptions o;
  o.fixed_height = t.planar;
  o.height_m = t.height_m;
  if (static_cast<int>(obs.size()) < (t.planar ? 3 : 4)) return;
  MultilaterationResult res = multilaterate_lm(obs, o);
  // A large residual means an NLOS range in the set: wait for a cleaner epoch.
  if (!res.ok || res.residual_rms_m > 3.0 * params_.range_sigma_m + 0.2) return;

  const double sigma = std::max(params_.range_sigma_m, res.residual_rms_m);
  const double v_var = params_.init_velocity_sigma_mps * params_.init_velocity_sigma_mps;
  auto init = [&](auto& f, int dims) {
    f.x.setZero();
    f.P.setZero();
    for (int k = 0; k < dims; ++k) f.x(k) = res.position(k);
    f.P.topLeftCorner(dims, dims) =
        res.covariance_unit.topLeftCorner(dims, dims) * sigma * sigma +
        Eigen::MatrixXd::Identity(dims, dims) * 0.01;
    f.P.bottomRightCorner(dims, dims) = Eigen::MatrixXd::Identity(dims, dims) * v_var;
  };
  if (t.planar)
    init(t.f2, 2);
  else
    init(t.f3, 3);
  t.initialised = true;
  t.reinitialised = t.last_publish_utime != 0;
  ++stats_.initialisations;
  t.filter_utime = now;
  t.last_accept_utime = now;
  t.consecutive_rejections = 0;
  t.used_since_publish = static_cast<int>(obs.size());
  t.sq_innov_since_publish = res.residual_rms_m * res.residual_rms_m * static_cast<double>(obs.size());
}

template <int D>
void TwrEstimator::publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now) {
  if (t.last_publish_utime != 0 && now - t.last_publish_utime < s_to_utime(params_.publish_period_s))
    return;
  pose_t p;
  p.utime = now;
  p.source = source_;
  p.tag_id = tag_id;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  cov.topLeftCorner<D, D>() = f.P.template topLeftCorner<D, D>();
  for (int k = 0; k < 3; ++k) {
    p.position[k] = k < D ? f.x(k) : t.height_m;
    p.velocity[k] = k < D ? f.x(D + k) : 0.0;
    for (int j = 0; j < 3; ++j) p.position_cov[3 * k + j] = cov(k, j);
  }
  const double speed = std::hypot(f.x(D), f.x(D + 1));
  p.heading_rad = speed > 0.2 ? std::atan2(f.x(D + 1), f.x(D)) : kNaN;
  p.num_used = t.used_since_publish;
  p.residual_m = t.used_since_publish > 0
                     ? std::sqrt(t.sq_innov_since_publish / t.used_since_publish)
                     : kNaN;
  p.status = pose_t::STATUS_OK;
  if (D == 2) p.status |= pose_t::STATUS_2D;
  if (t.used_since_publish == 0) p.status |= pose_t::STATUS_COASTING;
  if (t.reinitialised) p.status |= pose_t::STATUS_REINITIALISED;
  t.reinitialised = false;
  t.used_since_publish = 0;
  t.sq_innov_since_publish = 0;
  t.last_publish_utime = now;
  ++stats_.poses_out;
  sink_(p);
}

}  // namespace ips::uwb_twr
