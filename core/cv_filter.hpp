#pragma once
// Constant-velocity Kalman filter in D dimensions (D = 2: height known from the site; D = 3),
// state [position; velocity], white-acceleration process noise. The motion model of the UWB
// trackers (ips-uwb-twr, ips-uwb-tdoa); their measurement models live beside them (models/).
#include <cmath>
#include <ips/pose_t.hpp>
#include <limits>

#include "core/ekf.hpp"

namespace ips {

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

// The filter's state into a pose: position (the third axis at height_m in 2D), velocity (0
// vertically in 2D), position covariance, and heading (NaN below 0.2 m/s, where it is noise).
template <int D>
void fill_pose_from_cv(const CvFilter<D>& f, double height_m, pose_t& p) {
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  cov.topLeftCorner<D, D>() = f.P.template topLeftCorner<D, D>();
  for (int k = 0; k < 3; ++k) {
    p.position[k] = k < D ? f.x(k) : height_m;
    p.velocity[k] = k < D ? f.x(D + k) : 0.0;
    for (int j = 0; j < 3; ++j) p.position_cov[3 * k + j] = cov(k, j);
  }
  const double speed = std::hypot(f.x(D), f.x(D + 1));
  p.heading_rad = speed > 0.2 ? std::atan2(f.x(D + 1), f.x(D))
                              : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace ips
