#pragma once
// Zero-velocity update (ZUPT, 001 section 2 "ZUPT update"): while the foot is in stance its
// velocity is zero. Measurement z = 0 of h(x) = v = v^ + dv: H = [0 I 0], innovation -v^ (001
// prints +v, a sign typo), R = sigma^2 I (001: R = 1e-4 I, sigma 0.01 m/s). The correction moves
// position and attitude too, through their correlation with the velocity error; covariance in
// Joseph form (core/ekf.hpp).
#include "estimators/ins/strapdown_filter.hpp"

namespace ips::ins {

struct ZeroVelocityResult {
  bool accepted = false;
  double position_correction_m = 0;  // |dp| applied
  double nis = 0;  // v' (H P H' + R)^-1 v before the update (chi-square, 3 dof when consistent)
};

inline ZeroVelocityResult zero_velocity_update(StrapdownFilter& f, double sigma_mps) {
  Mat<3, kErrorStates> H = Mat<3, kErrorStates>::Zero();
  H.middleCols<3>(kVel).setIdentity();
  const Vec<3> innovation = -f.velocity();
  const Mat<3> R = Mat<3>::Identity() * (sigma_mps * sigma_mps);
  const Mat<3> S = H * f.covariance() * H.transpose() + R;
  const double nis = innovation.dot(S.ldlt().solve(innovation));
  ErrorState dx = ErrorState::Zero();
  const UpdateResult u = vector_update<kErrorStates, 3>(dx, f.covariance(), H, innovation, R);
  ZeroVelocityResult r;
  r.nis = nis;
  if (!u.accepted) return r;
  f.apply_correction(dx);
  r.accepted = true;
  r.position_correction_m = dx.segment<3>(kPos).norm();
  return r;
}

}  // namespace ips::ins
