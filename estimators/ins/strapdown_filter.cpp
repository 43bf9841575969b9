#include "estimators/ins/strapdown_filter.hpp"

#include <cmath>

namespace ips::ins {

void StrapdownFilter::reset(const Eigen::Quaterniond& attitude, const Eigen::Vector3d& position,
                            const ErrorCov& covariance) {
  q_ = attitude.normalized();
  v_.setZero();
  p_ = position;
  P_ = covariance;
}

void StrapdownFilter::propagate(const Eigen::Vector3d& f_b, const Eigen::Vector3d& w_b, double dt,
                                double gravity_mps2, double accel_sigma_mps2,
                                double gyro_sigma_rps) {
  q_ = (q_ * rotation_quaternion(w_b * dt)).normalized();
  const Eigen::Vector3d f_n = q_ * f_b;
  const Eigen::Vector3d a = f_n - gravity_mps2 * Eigen::Vector3d::UnitZ();
  p_ += v_ * dt + 0.5 * dt * dt * a;
  v_ += a * dt;

  // P <- F P F' + Qd with F = I + Fc dt; Fc has two non-zero blocks: I (dp/dv) and -[f_n x]
  // (dv/phi). Written out by blocks: F P F' = P + dt (Fc P + P Fc') + dt^2 Fc P Fc'.
  ErrorCov FcP = ErrorCov::Zero();
  const Eigen::Matrix3d S = -skew(f_n);
  FcP.middleRows<3>(kPos) = P_.middleRows<3>(kVel);
  FcP.middleRows<3>(kVel) = S * P_.middleRows<3>(kAtt);
  ErrorCov FcPFct = ErrorCov::Zero();
  FcPFct.middleCols<3>(kPos) = FcP.middleCols<3>(kVel);
  FcPFct.middleCols<3>(kVel) = FcP.middleCols<3>(kAtt) * S.transpose();
  P_ += dt * (FcP + FcP.transpose()) + dt * dt * FcPFct;
  const double qa = accel_sigma_mps2 * accel_sigma_mps2 * dt * dt;
  const double qg = gyro_sigma_rps * gyro_sigma_rps * dt * dt;
  for (int i = 0; i < 3; ++i) {
    P_(kVel + i, kVel + i) += qa;
    P_(kAtt + i, kAtt + i) += qg;
  }
  symmetrize<kErrorStates>(P_);
}

void StrapdownFilter::apply_correction(const ErrorState& dx) {
  p_ += dx.segment<3>(kPos);
  v_ += dx.segment<3>(kVel);
  q_ = (rotation_quaternion(dx.segment<3>(kAtt)) * q_).normalized();
}

double StrapdownFilter::heading_rad() const {
  Eigen::Vector3d forward = q_ * Eigen::Vector3d::UnitY();
  // Device y vertical (strapped upright): its screen normal points the other way round.
  if (std::hypot(forward.x(), forward.y()) < 1e-3) forward = -(q_ * Eigen::Vector3d::UnitZ());
  return std::atan2(forward.y(), forward.x());
}

}  // namespace ips::ins
