#pragma once
// The tag-anchor pairs' constant range offsets, learned online. Real DW1000 pairs read long by a
// constant of their own (antenna delays: +0.08 to +0.32 m per pair on public recordings, with
// a spread of only about 0.07 m around it). Left in, the offsets bias the fix and, being
// positive, look like NLOS to the asymmetric gate (models/uwb_range.hpp), which then drops or
// down-weights good ranges.
//
// Learned from per-epoch least-squares fixes (every anchor heard, the current offsets removed):
// an epoch's residuals r = M (b - b_used) + noise, with M = I - J (J'J)^-1 J' the fix's residual
// projector (J: the unit vectors to the anchors), hold only the part of the offsets b that the
// epoch's geometry can tell from a shift of the position. Stacking the epochs, b solves the
// joint least squares of all positions and offsets with the positions eliminated (Schur
// complement): (sum M + P) b = sum (r + M b_used) + P b0, P the prior's information (b0: the
// configured offsets or 0; P: a common part and a smaller part per pair). So a direction no
// epoch observes (three anchors in 2D, a corridor)
// keeps its prior, and the others converge as the tag moves. Not from the tracker's
// innovations: their prediction carries the track's own error, which the offsets would learn.
// Residuals are clipped at 2 sigma (an NLOS range moves the sums no more than a good one), and
// old epochs are forgotten over `window` epochs (the offsets drift with temperature over
// minutes). The offsets' variances are added to the ranges', so the filter does not trust a
// correction it has barely learned.
#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "core/multilateration.hpp"
#include "core/time.hpp"

namespace ips::uwb_twr {

class PairOffsets {
 public:
  // One entry per site anchor: the prior offset, its own sigma (0: known, never learned) and
  // whether it shares the common part: a radio's offsets are one common value (the tag's
  // antenna delay and the firmware's constant) plus a smaller one per pair (the anchors'
  // delays), so the prior is sigma_i^2 I + common_sigma^2 s s' (s_i 1 for the pairs that
  // share it): the well observed common part frees the weakly observed differences from having
  // to be learned from scratch.
  void reset(const std::vector<double>& prior_m, const std::vector<double>& prior_sigma_m,
             const std::vector<bool>& shares_common, double common_sigma_m) {
    const auto n = static_cast<Eigen::Index>(prior_m.size());
    b0_ = Eigen::VectorXd::Zero(n);
    learned_ = Eigen::VectorXd::Zero(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      b0_(k) = prior_m[static_cast<size_t>(k)];
      learned_(k) = prior_sigma_m[static_cast<size_t>(k)] > 0 ? 1.0 : 0.0;
    }
    // The prior's information over the learned offsets.
    free_.clear();
    for (Eigen::Index k = 0; k < n; ++k)
      if (learned_(k) > 0) free_.push_back(k);
    const auto f = static_cast<Eigen::Index>(free_.size());
    Eigen::MatrixXd cov0 = Eigen::MatrixXd::Zero(f, f);
    for (Eigen::Index i = 0; i < f; ++i) {
      const auto ki = static_cast<size_t>(free_[static_cast<size_t>(i)]);
      cov0(i, i) = prior_sigma_m[ki] * prior_sigma_m[ki];
      for (Eigen::Index j = 0; j < f; ++j) {
        const auto kj = static_cast<size_t>(free_[static_cast<size_t>(j)]);
        if (shares_common[ki] && shares_common[kj]) cov0(i, j) += common_sigma_m * common_sigma_m;
      }
    }
    info0_ = f > 0 ? Eigen::MatrixXd(cov0.ldlt().solve(Eigen::MatrixXd::Identity(f, f)))
                   : Eigen::MatrixXd();
    A_ = Eigen::MatrixXd::Zero(n, n);
    y_ = Eigen::VectorXd::Zero(n);
    epochs_ = 0;
    b_ = b0_;
    var_ = Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < f; ++i) var_(free_[static_cast<size_t>(i)]) = cov0(i, i);
  }
  size_t size() const { return static_cast<size_t>(b_.size()); }
  // Each pair's configured scale factor s (range = (1 + s) d + offset; range_scales, written by
  // ips-uwb-calibrate --scale), not learned: a range is divided by 1 + s before its offset is
  // taken off, so the offsets (configured and learned) are in the unscaled ranges' terms.
  void set_scales(std::vector<double> scales) { scales_ = std::move(scales); }
  double unscaled(size_t k, double range_m) const {
    return k < scales_.size() ? range_m / (1.0 + scales_[k]) : range_m;
  }
  double offset_m(size_t k) const { return b_(static_cast<Eigen::Index>(k)); }
  // The offset's variance once any epoch has been learned from; 0 before (where the geometry
  // never lets it be learned, e.g. four anchors in 3D, the prior's spread would inflate every
  // range's variance for good: an unknown constant is not white noise).
  double var_m2(size_t k) const { return epochs_ > 0 ? var_(static_cast<Eigen::Index>(k)) : 0.0; }

  // One epoch's fix: idx the site anchors of its ranges, J their unit vectors (rows; the fix's
  // free coordinates), r the ranges less the offsets used less the fix's predicted ranges,
  // r_var one range's variance; forget in (0, 1]: the weight left to the epochs before.
  // Returns false for an epoch not used (a degenerate fix). Not refused for a large residual:
  // while the offsets are unknown every residual is large.
  bool add_epoch(const std::vector<size_t>& idx, const Eigen::MatrixXd& J,
                 const Eigen::VectorXd& r, double r_var, double forget, double max_abs_m) {
    const auto m = static_cast<Eigen::Index>(idx.size());
    if (m <= J.cols() || !(r_var > 0)) return false;
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    Eigen::LDLT<Eigen::MatrixXd> ldlt(JtJ);
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-9)) return false;
    const Eigen::MatrixXd M =
        Eigen::MatrixXd::Identity(m, m) - J * ldlt.solve(J.transpose());
    const double clip = 2.0 * std::sqrt(r_var);
    Eigen::VectorXd used(m), rc(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      used(i) = b_(static_cast<Eigen::Index>(idx[static_cast<size_t>(i)]));
      rc(i) = std::clamp(r(i), -clip, clip);
    }
    // Clipped residuals are no longer residuals of a fix: projected back (M r), or the clipped
    // part would land where no epoch observes and only the prior holds (a static tag's offsets
    // ran off by 0.4 m after one NLOS range).
    const Eigen::VectorXd rhs = (M * rc + M * used) / r_var;
    A_ *= forget;
    y_ *= forget;
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto gi = static_cast<Eigen::Index>(idx[static_cast<size_t>(i)]);
      y_(gi) += rhs(i);
      for (Eigen::Index j = 0; j < m; ++j)
        A_(gi, static_cast<Eigen::Index>(idx[static_cast<size_t>(j)])) += M(i, j) / r_var;
    }
    ++epochs_;
    solve(max_abs_m);
    return true;
  }

 private:
  void solve(double max_abs_m) {
    // Only the learned offsets; a known one stays as configured (its column moves to the
    // right-hand side).
    const Eigen::Index n = b_.size();
    const auto f = static_cast<Eigen::Index>(free_.size());
    if (f == 0) return;
    Eigen::MatrixXd N = info0_;
    Eigen::VectorXd b0f(f);
    for (Eigen::Index i = 0; i < f; ++i) b0f(i) = b0_(free_[static_cast<size_t>(i)]);
    Eigen::VectorXd v = info0_ * b0f;
    for (Eigen::Index i = 0; i < f; ++i) {
      const Eigen::Index gi = free_[static_cast<size_t>(i)];
      v(i) += y_(gi);
      for (Eigen::Index j = 0; j < f; ++j) N(i, j) += A_(gi, free_[static_cast<size_t>(j)]);
      for (Eigen::Index k = 0; k < n; ++k)
        if (learned_(k) == 0) v(i) -= A_(gi, k) * b_(k);
    }
    Eigen::LDLT<Eigen::MatrixXd> ldlt(N);
    if (ldlt.info() != Eigen::Success) return;
    const Eigen::VectorXd b = ldlt.solve(v);
    const Eigen::MatrixXd cov = ldlt.solve(Eigen::MatrixXd::Identity(f, f));
    for (Eigen::Index i = 0; i < f; ++i) {
      const Eigen::Index gi = free_[static_cast<size_t>(i)];
      b_(gi) = std::clamp(b(i), -max_abs_m, max_abs_m);
      var_(gi) = std::max(0.0, cov(i, i));
    }
  }

  Eigen::VectorXd b0_, learned_, b_, var_, y_;
  std::vector<double> scales_;  // per site anchor; empty: none
  Eigen::MatrixXd A_, info0_;  // the sums of the epochs' M / r; the prior's information
  std::vector<Eigen::Index> free_;  // the learned offsets' indices
  int64_t epochs_ = 0;              // epochs learned from
};

// One epoch's lesson for `offsets`, shared by ips-uwb-twr and ips-fuse. latest: per site anchor
// (index into anchor_positions) the epoch's newest range (its time, the range less any
// configured per-range bias, not less the pair's offset); track, velocity, track_var: the
// track's position, velocity and position variance (trace) now; dims 2 (height fixed at
// track.z()) or 3. The ranges were taken one anchor after another: each is moved to `now`
// along the track's velocity (its radial part), or a moving tag's slot order would be learned
// as offsets. The fix starts at the track (the same minimum, not a mirror image); an epoch
// whose residuals are large (an NLOS range: above 3 range_sigma_m) or whose fix the track does
// not cover teaches nothing. Returns whether the epoch was used.
inline bool learn_offsets_from_epoch(PairOffsets& offsets,
                                     const std::map<size_t, std::pair<utime_t, double>>& latest,
                                     const std::vector<Eigen::Vector3d>& anchor_positions,
                                     utime_t now, const Eigen::Vector3d& track,
                                     const Eigen::Vector3d& velocity, double track_var, int dims,
                                     double range_sigma_m, double r_var, double forget,
                                     double max_abs_m, MultilaterationSolver solver) {
  const int m = static_cast<int>(latest.size());
  if (m < dims + 2) return false;  // a residual needs a range more than the fix does
  std::vector<RangeObservation> obs;
  std::vector<size_t> idx;
  for (const auto& [k, taken] : latest) {
    const Eigen::Vector3d d = track - anchor_positions[k];
    const double radial = d.norm() > 1e-6 ? d.dot(velocity) / d.norm() : 0.0;
    obs.push_back({anchor_positions[k],
                   taken.second + radial * utime_to_s(now - taken.first) - offsets.offset_m(k)});
    idx.push_back(k);
  }
  MultilaterationOptions o;
  o.fixed_height = dims == 2;
  o.height_m = track.z();
  const MultilaterationResult res = multilaterate(obs, o, solver, track);
  if (!res.ok || res.residual_rms_m > 3.0 * range_sigma_m) return false;
  Eigen::Vector3d p = res.position;
  if (dims == 2) p.z() = track.z();
  const double fix_var =
      res.covariance_unit.topLeftCorner(dims, dims).trace() * range_sigma_m * range_sigma_m;
  double miss2 = 0;
  for (int c = 0; c < dims; ++c) miss2 += (p(c) - track(c)) * (p(c) - track(c));
  if (miss2 > 9.0 * (track_var + fix_var)) return false;
  Eigen::MatrixXd J(m, dims);
  Eigen::VectorXd residual(m);
  for (int i = 0; i < m; ++i) {
    const Eigen::Vector3d d = p - obs[static_cast<size_t>(i)].anchor;
    const double predicted = std::max(d.norm(), 1e-6);
    for (int c = 0; c < dims; ++c) J(i, c) = d(c) / predicted;
    residual(i) = obs[static_cast<size_t>(i)].range_m - predicted;
  }
  return offsets.add_epoch(idx, J, residual, r_var, forget, max_abs_m);
}

}  // namespace ips::uwb_twr
