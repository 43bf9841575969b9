#pragma once
// Constant-velocity Kalman filter in D dimensions (D = 2: height known from the site; D = 3),
// state [position; velocity], white-acceleration process noise.
#include <cmath>

#include "core/ekf.hpp"

namespace ips::uwb_twr {

template <int D>
struct CvFilter {
  static constexpr int N = 2 * D;
  Vec<N> x = Vec<N>::Zero();
  Mat<N> P = Mat<N>::Identity();

  // Discrete white-noise-acceleration model over dt seconds with acceleration PSD q
  // ((m/s^2)^2 / Hz): Q = q [dt^3/3 I, dt^2/2 I; dt^2/2 I, dt I].
  void predict(double dt, double q) {
    if (dt <= 0) return;
    x.template head<D>() += dt * x.template tail<D>();
    // P = F P F' written out block-wise (F = [I dt I; 0 I]).
    Mat<D> Ppp = P.template topLeftCorner<D, D>();
    Mat<D> Ppv = P.template topRightCorner<D, D>();
    Mat<D> Pvv = P.template bottomRightCorner<D, D>();
    const double dt2 = dt * dt;
    Mat<D> nPpp = Ppp + dt * (Ppv + Ppv.transpose()) + dt2 * Pvv;
    Mat<D> nPpv = Ppv + dt * Pvv;
    const double qpp = q * dt2 * dt / 3.0, qpv = q * dt2 / 2.0, qvv = q * dt;
    nPpp.diagonal().array() += qpp;
    nPpv.diagonal().array() += qpv;
    Pvv.diagonal().array() += qvv;
    P.template topLeftCorner<D, D>() = nPpp;
    P.template topRightCorner<D, D>() = nPpv;
    P.template bottomLeftCorner<D, D>() = nPpv.transpose();
    P.template bottomRightCorner<D, D>() = Pvv;
  }
};

// Two-way range to an anchor: h(x) = |p - a| (2D: height fixed at `height`).
// Gated asymmetrically (NLOS ranges are too long). `innovation` receives z - h(x).
template <int D>
UpdateResult range_update(CvFilter<D>& f, const Eigen::Vector3d& anchor, double height,
                          double range_m, double r_var, double gate_chi2,
                          double gate_chi2_positive, double* innovation) {
  Eigen::Vector3d p;
  if constexpr (D == 2) {
    p << f.x(0), f.x(1), height;
  } else {
    p = f.x.template head<3>();
  }
  const Eigen::Vector3d d = p - anchor;
  const double predicted = std::max(d.norm(), 1e-6);
  Mat<1, 2 * D> H = Mat<1, 2 * D>::Zero();
  H.template head<D>() = (d.template head<D>() / predicted).transpose();
  const double y = range_m - predicted;
  if (innovation) *innovation = y;
  return scalar_update<2 * D>(f.x, f.P, H, y, r_var, gate_chi2, gate_chi2_positive);
}

}  // namespace ips::uwb_twr
