#include "estimators/uwb_tdoa/pair_tracker.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "core/track_limit.hpp"

namespace ips::uwb_tdoa {

namespace {

// One Levenberg-Marquardt run from `start` over `pairs`; the cost (sum of squared residuals) and
// the solution in `x` (dims 2 or 3). Returns +inf when it diverged.
double lm_run(const std::vector<PairObservation>& pairs, int dims, double height_m,
              Eigen::Vector3d& x, const Eigen::Vector3d& centroid) {
  auto residuals = [&](const Eigen::Vector3d& p, Eigen::VectorXd& r, Eigen::MatrixXd* J) {
    r.resize(static_cast<Eigen::Index>(pairs.size()));
    if (J) J->resize(static_cast<Eigen::Index>(pairs.size()), dims);
    for (size_t k = 0; k < pairs.size(); ++k) {
      const Eigen::Vector3d da = p - pairs[k].a, db = p - pairs[k].b;
      const double na = std::max(da.norm(), 1e-6), nb = std::max(db.norm(), 1e-6);
      r(static_cast<Eigen::Index>(k)) = nb - na - pairs[k].diff_m;
      if (J) {
        const Eigen::Vector3d g = db / nb - da / na;
        for (int d = 0; d < dims; ++d) (*J)(static_cast<Eigen::Index>(k), d) = g(d);
      }
    }
  };
  if (dims == 2) x(2) = height_m;
  Eigen::VectorXd r;
  Eigen::MatrixXd J;
  residuals(x, r, &J);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  for (int it = 0; it < 60; ++it) {
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    Eigen::MatrixXd Ad = A;
    Ad.diagonal().array() += lambda * (A.diagonal().array() + 1e-9);
    const Eigen::VectorXd step = Ad.ldlt().solve(-g);
    if (!step.allFinite()) return std::numeric_limits<double>::infinity();
    Eigen::Vector3d xn = x;
    for (int d = 0; d < dims; ++d) xn(d) += step(d);
    Eigen::VectorXd rn;
    residuals(xn, rn, nullptr);
    const double cn = rn.squaredNorm();
    if (cn < cost) {
      x = xn;
      cost = cn;
      lambda = std::max(lambda * 0.3, 1e-9);
      residuals(x, r, &J);
      if (step.norm() < 1e-5) break;
    } else {
      lambda *= 10;
      if (lambda > 1e8) break;
    }
    if ((x - centroid).norm() > 500.0) return std::numeric_limits<double>::infinity();
  }
  return cost;
}

}  // namespace

namespace {

// The fix of all `pairs`, the worst pair trimmed while the RMS residual exceeds max_residual_m.
PairFix trimmed_fix(std::vector<PairObservation> pairs, bool fixed_height, double height_m,
                    double max_residual_m, int min_pairs) {
  PairFix fix;
  const int dims = fixed_height ? 2 : 3;
  // Two pairs more than unknowns, always: with one redundant pair a wrong set can still fit
  // (two pairs of anchors above one another say little in plan), with none any set fits.
  while (static_cast<int>(pairs.size()) >= min_pairs) {
    // Starts: the centroid of the anchors named, then 1 m from each toward the centroid.
    std::vector<Eigen::Vector3d> anchors;
    for (const auto& o : pairs) {
      for (const Eigen::Vector3d* q : {&o.a, &o.b})
        if (std::none_of(anchors.begin(), anchors.end(),
                         [&](const Eigen::Vector3d& v) { return (v - *q).norm() < 1e-9; }))
          anchors.push_back(*q);
    }
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& a : anchors) centroid += a;
    centroid /= static_cast<double>(anchors.size());
    std::vector<Eigen::Vector3d> starts = {centroid};
    if (!fixed_height) starts.front()(2) -= 1.5;  // tags below ceiling anchors
    for (const auto& a : anchors) {
      Eigen::Vector3d s = a + (centroid - a).normalized() * std::min(1.0, (centroid - a).norm());
      if (!fixed_height) s(2) = centroid(2) - 1.5;
      starts.push_back(s);
    }
    double best = std::numeric_limits<double>::infinity();
    Eigen::Vector3d best_x = centroid;
    for (const auto& s : starts) {
      Eigen::Vector3d x = s;
      const double c = lm_run(pairs, dims, height_m, x, centroid);
      if (c < best) {
        best = c;
        best_x = x;
      }
    }
    if (!std::isfinite(best)) return fix;
    const double rms = std::sqrt(best / static_cast<double>(pairs.size()));
    if (rms <= max_residual_m || static_cast<int>(pairs.size()) <= min_pairs) {
      if (rms > max_residual_m) return fix;
      Eigen::MatrixXd J(static_cast<Eigen::Index>(pairs.size()), dims);
      for (size_t k = 0; k < pairs.size(); ++k) {
        const Eigen::Vector3d da = best_x - pairs[k].a, db = best_x - pairs[k].b;
        const Eigen::Vector3d g = db / std::max(db.norm(), 1e-6) - da / std::max(da.norm(), 1e-6);
        for (int d = 0; d < dims; ++d) J(static_cast<Eigen::Index>(k), d) = g(d);
      }
      const Eigen::MatrixXd JtJ = J.transpose() * J;
      Eigen::FullPivLU<Eigen::MatrixXd> lu(JtJ);
      if (!lu.isInvertible()) return fix;
      fix.covariance_unit.topLeftCorner(dims, dims) = lu.inverse();
      if (fixed_height) best_x(2) = height_m;
      fix.ok = best_x.allFinite();
      fix.position = best_x;
      fix.residual_rms_m = rms;
      fix.used = static_cast<int>(pairs.size());
      return fix;
    }
    // Trim the worst pair and try again.
    size_t worst = 0;
    double worst_r = -1;
    for (size_t k = 0; k < pairs.size(); ++k) {
      const double r = std::abs((best_x - pairs[k].b).norm() - (best_x - pairs[k].a).norm() -
                                pairs[k].diff_m);
      if (r > worst_r) {
        worst_r = r;
        worst = k;
      }
    }
    pairs.erase(pairs.begin() + static_cast<std::ptrdiff_t>(worst));
  }
  return fix;
}

bool same(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm() < 1e-9; }

}  // namespace

PairFix solve_pair_fix(std::vector<PairObservation> pairs, bool fixed_height, double height_m,
                       double max_residual_m, double noise_sigma_m, int min_pairs) {
  const int dims = fixed_height ? 2 : 3;
  min_pairs = std::max(min_pairs, dims + 2);
  if (static_cast<int>(pairs.size()) < min_pairs) return {};
  // 1. All pairs, untrimmed: good when nothing is biased.
  const double clean = std::min(max_residual_m, 2.0 * noise_sigma_m);
  PairFix all = trimmed_fix(pairs, fixed_height, height_m, 1e9, min_pairs);
  if (all.ok && all.residual_rms_m <= clean) return all;
  // 2. NLOS is per anchor (an obstructed path biases every pair it is in): leave each anchor's
  //    pairs out in turn and keep the cleanest fix that still has a redundant pair.
  std::vector<Eigen::Vector3d> anchors;
  for (const auto& o : pairs)
    for (const Eigen::Vector3d* q : {&o.a, &o.b})
      if (std::none_of(anchors.begin(), anchors.end(),
                       [&](const Eigen::Vector3d& v) { return same(v, *q); }))
        anchors.push_back(*q);
  PairFix best;
  if (anchors.size() >= static_cast<size_t>(dims + 2)) {
    for (const auto& left_out : anchors) {
      std::vector<PairObservation> rest;
      for (const auto& o : pairs)
        if (!same(o.a, left_out) && !same(o.b, left_out)) rest.push_back(o);
      if (static_cast<int>(rest.size()) < min_pairs) continue;
      const PairFix f = trimmed_fix(std::move(rest), fixed_height, height_m, 1e9, min_pairs);
      if (f.ok && (!best.ok || f.residual_rms_m < best.residual_rms_m)) best = f;
    }
  }
  if (best.ok && best.residual_rms_m <= clean) return best;
  // 3. Else trim the worst pairs one by one down to the residual allowed.
  return trimmed_fix(std::move(pairs), fixed_height, height_m, max_residual_m, min_pairs);
}

PairTracker::PairTracker(PoseSink sink, std::string source_name)
    : sink_(std::move(sink)), source_(std::move(source_name)) {}

void PairTracker::configure(const Site& site, const PairParams& params,
                            ConsistencyMonitor* consistency) {
  p_ = params;
  consistency_ = consistency;
  if (consistency_) consistency_->monitor_only("TDOA_PAIR");
  setting_ = setting_text("pair_sigma_m", p_.pair_sigma_m);
  anchor_ids_.clear();
  anchor_pos_.clear();
  for (const auto& a : site.anchors) {
    if (!a.enabled || a.kind != "uwb_tdoa") continue;
    anchor_ids_.push_back(a.id);
    anchor_pos_.push_back(a.position);
  }
  tag_height_.clear();
  for (const auto& t : site.tags)
    tag_height_[t.id] = {!p_.force_3d && std::isfinite(t.height_m), t.height_m};
  tracks_.clear();
  configured_ = true;
}

int PairTracker::anchor_index(const std::string& id) const {
  for (size_t i = 0; i < anchor_ids_.size(); ++i)
    if (anchor_ids_[i] == id) return static_cast<int>(i);
  return -1;
}

void PairTracker::on_pair(const uwb_tdoa_t& m) {
  ++stats_.pairs_in;
  if (!configured_) {
    ++stats_.pairs_no_site;
    return;
  }
  if (!plausible_utime(m.utime) || !valid_device_id(m.tag_id) || !valid_device_id(m.anchor_a) ||
      !valid_device_id(m.anchor_b) || m.anchor_a == m.anchor_b || !std::isfinite(m.diff_m) ||
      !(std::isnan(m.sigma_m) || (m.sigma_m > 0 && m.sigma_m <= 100))) {
    ++stats_.pairs_invalid;
    return;
  }
  const int a = anchor_index(m.anchor_a), b = anchor_index(m.anchor_b);
  if (a < 0 || b < 0) {
    ++stats_.pairs_unknown_anchor;
    return;
  }
  const double sigma = std::isnan(m.sigma_m) ? p_.pair_sigma_m : static_cast<double>(m.sigma_m);
  // |d_b - d_a| <= |b - a| (triangle inequality), up to the noise.
  if (std::abs(m.diff_m) > (anchor_pos_[b] - anchor_pos_[a]).norm() + 5 * sigma + 0.5) {
    ++stats_.pairs_geometry;
    return;
  }
  auto it = tracks_.find(m.tag_id);
  if (it == tracks_.end()) {
    // A track silent for 10 coast periods makes room (core/track_limit.hpp).
    if (!room_for_track(tracks_, m.utime, p_.max_tags, 10 * s_to_utime(p_.max_coast_s))) {
      ++stats_.pairs_too_many_tags;
      return;
    }
    it = tracks_.try_emplace(m.tag_id).first;
    const auto h = tag_height_.find(m.tag_id);
    it->second.planar = h != tag_height_.end() && h->second.first;
    it->second.height_m = it->second.planar ? h->second.second : 0.0;
  }
  const std::string& tag_id = it->first;
  Track& t = it->second;
  if (t.newest_utime != 0) {
    const utime_t behind = t.newest_utime - m.utime;
    if (behind > s_to_utime(p_.max_coast_s)) {
      // Time went back further than any reordering explains: start afresh.
      Track fresh;
      fresh.planar = t.planar;
      fresh.height_m = t.height_m;
      t = std::move(fresh);
    } else if (behind > s_to_utime(p_.reorder_tolerance_s)) {
      ++stats_.pairs_late;
      return;
    }
  }
  t.newest_utime = std::max(t.newest_utime, m.utime);
  // The window a fix is made of: kept whether or not the track runs, so a restart has it.
  t.window.push_back({m.utime, a, b, m.diff_m});
  while (!t.window.empty() && m.utime - t.window.front().utime > s_to_utime(p_.pair_window_s))
    t.window.pop_front();
  while (t.window.size() > 256) t.window.pop_front();

  if (t.initialised && m.utime - t.last_accept_utime > s_to_utime(p_.max_coast_s))
    t.initialised = false;
  if (!t.initialised) {
    try_initialise(tag_id, t, m.utime);
    return;
  }
  if (t.planar)
    update<2>(tag_id, t, t.f2, a, b, m.diff_m, sigma * sigma, m.utime);
  else
    update<3>(tag_id, t, t.f3, a, b, m.diff_m, sigma * sigma, m.utime);
}

void PairTracker::try_initialise(const std::string& tag_id, Track& t, utime_t now) {
  // The newest difference of each anchor pair in the window (either order).
  std::map<std::pair<int, int>, const Track::Held*> newest;
  for (const auto& h : t.window) newest[{std::min(h.a, h.b), std::max(h.a, h.b)}] = &h;
  const int dims = t.planar ? 2 : 3;
  std::vector<int> anchors;
  std::vector<PairObservation> obs;
  for (const auto& [key, h] : newest) {
    obs.push_back({anchor_pos_[static_cast<size_t>(h->a)], anchor_pos_[static_cast<size_t>(h->b)],
                   h->diff_m});
    for (int k : {h->a, h->b})
      if (std::find(anchors.begin(), anchors.end(), k) == anchors.end()) anchors.push_back(k);
  }
  // The window gets half its length to fill first (a TDoA2 cycle through 8 anchors at 100 Hz is
  // 80 ms): a fix of the first few pairs cannot yet leave an NLOS anchor out.
  if (t.window.empty() || now - t.window.front().utime < s_to_utime(p_.pair_window_s / 2)) {
    ++stats_.pairs_initialising;
    return;
  }
  // Three differences more than unknowns (an NLOS anchor's two pairs can be left out and the
  // residual still mean something), from enough anchors; a small site (4 anchors in 2D: TDoA2
  // gives 4 pairs) asks for what it can give, and cannot leave an anchor out.
  const int n_site = static_cast<int>(anchor_ids_.size());
  if (static_cast<int>(obs.size()) < std::min(dims + 4, n_site) ||
      static_cast<int>(anchors.size()) < std::min(dims + 3, n_site)) {
    ++stats_.pairs_initialising;
    return;
  }
  const PairFix fix = solve_pair_fix(std::move(obs), t.planar, t.height_m, p_.init_max_residual_m,
                                     p_.pair_sigma_m, std::min(dims + 3, n_site));
  // A fix far outside the anchors' box (2 m margin) is a wrong solution of a bad set: wait.
  bool inside = fix.ok;
  for (int k = 0; k < dims && inside; ++k) {
    double lo = 1e300, hi = -1e300;
    for (int i : anchors) {
      lo = std::min(lo, anchor_pos_[static_cast<size_t>(i)](k));
      hi = std::max(hi, anchor_pos_[static_cast<size_t>(i)](k));
    }
    inside = fix.position(k) >= lo - 2.0 && fix.position(k) <= hi + 2.0;
  }
  if (!inside) {
    ++stats_.pairs_initialising;
    return;
  }
  const double var = std::max(p_.pair_sigma_m * p_.pair_sigma_m,
                              fix.residual_rms_m * fix.residual_rms_m);
  const double v_var = p_.init_velocity_sigma_mps * p_.init_velocity_sigma_mps;
  auto init = [&](auto& f, int d) {
    f.x.setZero();
    f.P.setZero();
    for (int k = 0; k < d; ++k) f.x(k) = fix.position(k);
    f.P.topLeftCorner(d, d) =
        fix.covariance_unit.topLeftCorner(d, d) * var + Eigen::MatrixXd::Identity(d, d) * 0.01;
    f.P.bottomRightCorner(d, d) = Eigen::MatrixXd::Identity(d, d) * v_var;
  };
  if (t.planar)
    init(t.f2, 2);
  else
    init(t.f3, 3);
  t.initialised = true;
  t.gate.gate_sigma = p_.pair_gate_sigma;
  t.gate.lost_level = p_.pair_lost_level;
  t.gate.lost_share = p_.pair_lost_share;
  t.gate.reset();
  t.filter_utime = now;
  t.last_accept_utime = now;
  ++stats_.initialisations;
  stats_.pairs_used += fix.used;
  t.tally.restart(fix.used, fix.residual_rms_m);
  if (t.planar)
    publish<2>(t, t.f2, tag_id, now);
  else
    publish<3>(t, t.f3, tag_id, now);
}

template <int D>
void PairTracker::update(const std::string& tag_id, Track& t, CvFilter<D>& f, int a, int b,
                         double z, double r_var, utime_t now) {
  if (now > t.filter_utime) {
    f.predict(utime_to_s(now - t.filter_utime), p_.accel_psd);
    t.filter_utime = now;
  }
  const PairPrediction<D> pr = predict_pair<D>(f, t.height_m, anchor_pos_[static_cast<size_t>(a)],
                                               anchor_pos_[static_cast<size_t>(b)], z);
  const bool pass = t.gate.admit(pr.y, pr.hph + r_var);
  if (consistency_) {
    const std::string key = anchor_ids_[static_cast<size_t>(a)] + ">" +
                            anchor_ids_[static_cast<size_t>(b)];
    consistency_->add_scalar("TDOA_PAIR", key, utime_to_s(now), pr.y, pr.hph, r_var, !pass,
                             setting_);
  }
  bool used = false;
  if (pass) used = apply_pair<D>(f, pr, r_var).accepted;
  if (used) {
    ++stats_.pairs_used;
    t.last_accept_utime = now;
    t.tally.add(pr.y);
  } else {
    ++stats_.pairs_gated;
  }
  if (t.gate.record(used)) {
    // Most pairs refused for a while: the track, not the pairs, is wrong. Restart from a fix.
    ++stats_.lost;
    t.initialised = false;
    try_initialise(tag_id, t, now);
    return;
  }
  publish<D>(t, f, tag_id, now);
}

template <int D>
void PairTracker::publish(Track& t, const CvFilter<D>& f, const std::string& tag_id, utime_t now) {
  if (!t.tally.due(now, p_.publish_period_s)) return;
  pose_t p;
  p.utime = now;
  p.source = source_;
  p.tag_id = tag_id;
  fill_pose_from_cv<D>(f, t.height_m, p);
  t.tally.finish(p, D == 2, now);
  ++stats_.poses_out;
  sink_(p);
}

}  // namespace ips::uwb_tdoa
