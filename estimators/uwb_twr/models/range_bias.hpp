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
// configured offsets or 0). So a direction no epoch observes (three anchors in 2D, a corridor)
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
#include <vector>

namespace ips::uwb_twr {

class PairOffsets {
 public:
  // One entry per site anchor: the prior offset and its sigma (0: known, never learned).
  void reset(const std::vector<double>& prior_m, const std::vector<double>& prior_sigma_m) {
    const auto n = static_cast<Eigen::Index>(prior_m.size());
    b0_ = Eigen::VectorXd::Zero(n);
    info0_ = Eigen::VectorXd::Zero(n);
    for (Eigen::Index k = 0; k < n; ++k) {
      b0_(k) = prior_m[static_cast<size_t>(k)];
      const double s = prior_sigma_m[static_cast<size_t>(k)];
      info0_(k) = s > 0 ? 1.0 / (s * s) : 0.0;
    }
    A_ = Eigen::MatrixXd::Zero(n, n);
    y_ = Eigen::VectorXd::Zero(n);
    b_ = b0_;
    var_ = Eigen::VectorXd::Zero(n);
    for (Eigen::Index k = 0; k < n; ++k) var_(k) = info0_(k) > 0 ? 1.0 / info0_(k) : 0.0;
  }
  size_t size() const { return static_cast<size_t>(b_.size()); }
  double offset_m(size_t k) const { return b_(static_cast<Eigen::Index>(k)); }
  double var_m2(size_t k) const { return var_(static_cast<Eigen::Index>(k)); }

  // One epoch's fix: idx the site anchors of its ranges, J their unit vectors (rows; the fix's
  // free coordinates), r the ranges less the offsets used less the fix's predicted ranges,
  // r_var one range's variance; forget in (0, 1]: the weight left to the epochs before.
  void add_epoch(const std::vector<size_t>& idx, const Eigen::MatrixXd& J,
                 const Eigen::VectorXd& r, double r_var, double forget, double max_abs_m) {
    const auto m = static_cast<Eigen::Index>(idx.size());
    if (m <= J.cols() || !(r_var > 0)) return;
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    Eigen::LDLT<Eigen::MatrixXd> ldlt(JtJ);
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-9)) return;
    const Eigen::MatrixXd M =
        Eigen::MatrixXd::Identity(m, m) - J * ldlt.solve(J.transpose());
    const double clip = 2.0 * std::sqrt(r_var);
    Eigen::VectorXd used(m), rc(m);
    for (Eigen::Index i = 0; i < m; ++i) {
      used(i) = b_(static_cast<Eigen::Index>(idx[static_cast<size_t>(i)]));
      rc(i) = std::clamp(r(i), -clip, clip);
    }
    const Eigen::VectorXd rhs = (rc + M * used) / r_var;
    A_ *= forget;
    y_ *= forget;
    for (Eigen::Index i = 0; i < m; ++i) {
      const auto gi = static_cast<Eigen::Index>(idx[static_cast<size_t>(i)]);
      y_(gi) += rhs(i);
      for (Eigen::Index j = 0; j < m; ++j)
        A_(gi, static_cast<Eigen::Index>(idx[static_cast<size_t>(j)])) += M(i, j) / r_var;
    }
    solve(max_abs_m);
  }

 private:
  void solve(double max_abs_m) {
    // Only the learned offsets (prior information > 0); a known one stays as configured.
    const Eigen::Index n = b_.size();
    std::vector<Eigen::Index> free;
    for (Eigen::Index k = 0; k < n; ++k)
      if (info0_(k) > 0) free.push_back(k);
    const auto f = static_cast<Eigen::Index>(free.size());
    if (f == 0) return;
    Eigen::MatrixXd N(f, f);
    Eigen::VectorXd v(f);
    for (Eigen::Index i = 0; i < f; ++i) {
      v(i) = y_(free[i]) + info0_(free[i]) * b0_(free[i]);
      for (Eigen::Index j = 0; j < f; ++j) N(i, j) = A_(free[i], free[j]);
      N(i, i) += info0_(free[i]);
      // A known offset's column: its value moves to the right-hand side.
      for (Eigen::Index k = 0; k < n; ++k)
        if (info0_(k) == 0) v(i) -= A_(free[i], k) * b_(k);
    }
    Eigen::LDLT<Eigen::MatrixXd> ldlt(N);
    if (ldlt.info() != Eigen::Success) return;
    const Eigen::VectorXd b = ldlt.solve(v);
    const Eigen::MatrixXd cov = ldlt.solve(Eigen::MatrixXd::Identity(f, f));
    for (Eigen::Index i = 0; i < f; ++i) {
      b_(free[i]) = std::clamp(b(i), -max_abs_m, max_abs_m);
      var_(free[i]) = std::max(0.0, cov(i, i));
    }
  }

  Eigen::VectorXd b0_, info0_, b_, var_, y_;
  Eigen::MatrixXd A_;
};

}  // namespace ips::uwb_twr
