#pragma once
// Strapdown mechanisation with a 9-state error-state Kalman filter: the ZUPT INS of 001 section 2
// "INS (3.2.2)" (OpenShoe), in the site frame (x East, y North, z up) instead of its NED.
//
// Nominal state: attitude q (body -> site, Hamilton), velocity v, position p. Per sample, with
// bias-corrected specific force f and angular rate w (body frame) over dt:
//   q <- q (x) exp(w dt / 2)            exact rotation for a constant rate (001's q_n formula)
//   a  = q f q* - [0, 0, g]             with the updated q, as OpenShoe does
//   p <- p + v dt + a dt^2 / 2,  v <- v + a dt      (001's A, B)
// Error state dx = [dp, dv, phi] (001's order: position, velocity, attitude), the truth being
// p = p^ + dp, v = v^ + dv, C = (I + [phi x]) C^. Then
//   d(dp)/dt = dv,  d(dv)/dt = -[a_n x] phi + C^ n_a,  d(phi)/dt = -C^ n_g
// (a_n = C^ f), discretised as F = I + Fc dt, Qd = G Q G' with G = Gc dt and per-sample sigmas
// of accelerometer and gyro (OpenShoe's settings, not densities): Qd = diag(0, sa^2 dt^2 I,
// sg^2 dt^2 I) since C^ C^' = I.
// Measurement models live in models/ (models/zero_velocity.hpp) and call apply_correction().
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/ekf.hpp"

namespace ips::ins {

inline constexpr int kErrorStates = 9;
using ErrorState = Vec<kErrorStates>;
using ErrorCov = Mat<kErrorStates>;

// Indices of the error-state blocks.
inline constexpr int kPos = 0, kVel = 3, kAtt = 6;

class StrapdownFilter {
 public:
  void reset(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& position,
             const ErrorCov& covariance);

  // One IMU sample; dt > 0.
  void propagate(const Eigen::Vector3d& specific_force_b, const Eigen::Vector3d& rate_b, double dt,
                 double gravity_mps2, double accel_sigma_mps2, double gyro_sigma_rps);

  // Adds an estimated error state to the nominal state (the error state is then zero again).
  void apply_correction(const ErrorState& dx);

  const Eigen::Quaterniond& attitude() const { return q_; }
  const Eigen::Vector3d& velocity() const { return v_; }
  const Eigen::Vector3d& position() const { return p_; }
  ErrorCov& covariance() { return P_; }
  const ErrorCov& covariance() const { return P_; }
  void set_velocity(const Eigen::Vector3d& v) { v_ = v; }
  void set_attitude(const Eigen::Quaterniond& q) { q_ = q.normalized(); }

  // Heading of the body's y axis (Android: the top of the device, the toes on a foot) in the
  // horizontal plane, counter-clockwise from +x.
  double heading_rad() const;

 private:
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_ = Eigen::Vector3d::Zero();
  ErrorCov P_ = ErrorCov::Identity();
};

// The skew-symmetric matrix [v x].
inline Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// The rotation by the rotation vector phi (exact exponential).
inline Eigen::Quaterniond rotation_quaternion(const Eigen::Vector3d& phi) {
  const double angle = phi.norm();
  if (angle < 1e-12)
    return Eigen::Quaterniond(1, 0.5 * phi.x(), 0.5 * phi.y(), 0.5 * phi.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, phi / angle));
}

}  // namespace ips::ins
