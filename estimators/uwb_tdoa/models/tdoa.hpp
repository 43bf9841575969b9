#pragma once
// TDoA measurement model: one blink received at anchor i and at the reference anchor gives the
// range difference z = c (t_i - t_ref) = |p - a_i| - |p - a_ref| (the hyperboloid
// R_ij = |x - x_i| - |x - x_j| of ../shared/reference/004_uwb_kf.md §2.1 and c t_ij = d_i - d_j
// of §2.2). In 2D the height is fixed at the tag's. Two ways to apply an epoch's differences:
// - tdoa_update: one scalar update per difference (Crazyflie's mm_tdoa), the noise of the shared
//   reference treated as independent each time;
// - tdoa_vector_update: all of them at once with their true covariance
//   R = diag(var_i) + var_ref 1 1' (every difference shares the reference reception's error).
#include <Eigen/Core>
#include <algorithm>

#include "core/cv_filter.hpp"
#include "core/ekf.hpp"

namespace ips::uwb_tdoa {

// Differences applied in one vector update at most: the 8 nearest anchors of an epoch, less the
// reference (more add little, and each size is a template instance).
inline constexpr int kMaxTdoaPerEpoch = 7;

template <int D>
struct TdoaRow {
  double predicted = 0;  // h(x), m
  Mat<1, 2 * D> H = Mat<1, 2 * D>::Zero();
};

// h(x) and its Jacobian: dh/dp = (p - a_i)/|p - a_i| - (p - a_ref)/|p - a_ref|.
template <int D>
TdoaRow<D> tdoa_row(const Vec<2 * D>& x, double height, const Eigen::Vector3d& anchor,
                    const Eigen::Vector3d& reference) {
  Eigen::Vector3d p;
  if constexpr (D == 2) {
    p << x(0), x(1), height;
  } else {
    p = x.template head<3>();
  }
  const Eigen::Vector3d di = p - anchor;
  const Eigen::Vector3d dr = p - reference;
  const double ni = std::max(di.norm(), 1e-6);
  const double nr = std::max(dr.norm(), 1e-6);
  TdoaRow<D> row;
  row.predicted = ni - nr;
  row.H.template head<D>() = (di.template head<D>() / ni - dr.template head<D>() / nr).transpose();
  return row;
}

// One scalar update; `innovation` receives z - h(x).
template <int D>
UpdateResult tdoa_update(CvFilter<D>& f, double height, const Eigen::Vector3d& anchor,
                         const Eigen::Vector3d& reference, double z_m, double r_var,
                         double gate_chi2, double* innovation) {
  const TdoaRow<D> row = tdoa_row<D>(f.x, height, anchor, reference);
  const double y = z_m - row.predicted;
  if (innovation) *innovation = y;
  return scalar_update<2 * D>(f.x, f.P, row.H, y, r_var, gate_chi2);
}

template <int D, int M>
UpdateResult tdoa_vector_update_fixed(CvFilter<D>& f, const TdoaRow<D>* rows, const double* y,
                                      const double* var, double var_ref) {
  Mat<M, 2 * D> H;
  Vec<M> yy;
  Mat<M> R = Mat<M>::Constant(var_ref);
  for (int k = 0; k < M; ++k) {
    H.row(k) = rows[k].H;
    yy(k) = y[k];
    R(k, k) += var[k];
  }
  return vector_update<2 * D, M>(f.x, f.P, H, yy, R);
}

// The m (1..kMaxTdoaPerEpoch) differences of one epoch, linearised at the same prior: rows from
// tdoa_row, innovations y, each difference's own variance var (anchor i's reception and clock)
// and the reference's var_ref. Not gated here: gate each difference before.
template <int D, int M = 1>
UpdateResult tdoa_vector_update(CvFilter<D>& f, const TdoaRow<D>* rows, const double* y,
                                const double* var, double var_ref, int m) {
  if constexpr (M > kMaxTdoaPerEpoch) {
    return {};
  } else if constexpr (M == 1) {
    // One difference: the scalar update is the same thing, without a 1 x 1 factorisation.
    if (m == 1) return scalar_update<2 * D>(f.x, f.P, rows[0].H, y[0], var[0] + var_ref);
    return tdoa_vector_update<D, 2>(f, rows, y, var, var_ref, m);
  } else {
    if (m == M) return tdoa_vector_update_fixed<D, M>(f, rows, y, var, var_ref);
    return tdoa_vector_update<D, M + 1>(f, rows, y, var, var_ref, m);
  }
}

}  // namespace ips::uwb_tdoa
