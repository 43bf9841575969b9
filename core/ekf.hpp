#pragma once
// A small extended-Kalman-filter toolkit on fixed-size Eigen matrices: scalar and vector
// measurement updates in Joseph form with Mahalanobis gating, and covariance symmetrisation.
// Measurement models compute a prediction and its Jacobian, then call one of these (the pattern
// of Crazyflie's kalman_core scalarUpdate).
#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <cmath>
#include <limits>

namespace ips {

template <int N>
using Vec = Eigen::Matrix<double, N, 1>;
template <int R, int C = R>
using Mat = Eigen::Matrix<double, R, C>;

struct UpdateResult {
  bool accepted = false;
  double mahalanobis_sq = 0.0;  // innovation' S^-1 innovation
};

inline constexpr double kNoGate = std::numeric_limits<double>::infinity();

template <int N>
void symmetrize(Mat<N>& P) {
  P = 0.5 * (P + P.transpose()).eval();
}

// Scalar update with measurement Jacobian row H, innovation (z - h(x)) and measurement variance
// r_var. Rejected without touching the state when innovation^2 / S exceeds the gate: gate_chi2,
// or gate_chi2_positive for a positive innovation when given (asymmetric gating, e.g. NLOS
// ranges that can only be too long).
template <int N>
UpdateResult scalar_update(Vec<N>& x, Mat<N>& P, const Mat<1, N>& H, double innovation,
                           double r_var, double gate_chi2 = kNoGate,
                           double gate_chi2_positive = std::numeric_limits<double>::quiet_NaN()) {
  const Vec<N> PHt = P * H.transpose();
  const double S = H.dot(PHt.transpose()) + r_var;
  UpdateResult res;
  if (!(S > 0.0) || !std::isfinite(innovation)) return res;
  res.mahalanobis_sq = innovation * innovation / S;
  const double gate =
      innovation > 0 && !std::isnan(gate_chi2_positive) ? gate_chi2_positive : gate_chi2;
  if (res.mahalanobis_sq > gate) return res;
  const Vec<N> K = PHt / S;
  x += K * innovation;
  // Joseph form: P = (I - K H) P (I - K H)' + K R K', stable for any gain.
  const Mat<N> IKH = Mat<N>::Identity() - K * H;
  P = IKH * P * IKH.transpose() + (r_var * K) * K.transpose();
  symmetrize<N>(P);
  res.accepted = true;
  return res;
}

// Vector update of M measurements with Jacobian H (M x N), innovation y and covariance R.
template <int N, int M>
UpdateResult vector_update(Vec<N>& x, Mat<N>& P, const Mat<M, N>& H, const Vec<M>& y,
                           const Mat<M>& R, double gate_chi2 = kNoGate) {
  const Mat<N, M> PHt = P * H.transpose();
  const Mat<M> S = H * PHt + R;
  Eigen::LDLT<Mat<M>> ldlt(S);
  UpdateResult res;
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || !y.allFinite()) return res;
  res.mahalanobis_sq = y.dot(ldlt.solve(y));
  if (!(res.mahalanobis_sq <= gate_chi2)) return res;
  const Mat<N, M> K = ldlt.solve(PHt.transpose()).transpose();
  x += K * y;
  const Mat<N> IKH = Mat<N>::Identity() - K * H;
  P = IKH * P * IKH.transpose() + K * R * K.transpose();
  symmetrize<N>(P);
  res.accepted = true;
  return res;
}

}  // namespace ips
