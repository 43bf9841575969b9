#pragma once
// Measurement model: another estimator's position with its covariance, loosely coupled
// (POSE_TDOA, POSE_AOA, ...): z = p (horizontal only when the pose is 2D or has no height
// covariance).
#include <Eigen/Core>

#include "fusion/fuse_filter.hpp"

namespace ips::fusion {

inline UpdateResult update_position(FuseFilter& f, const Eigen::Vector3d& position,
                                    const Eigen::Matrix3d& cov, bool horizontal_only,
                                    double gate_chi2) {
  if (horizontal_only || f.planar) {
    Mat<2, kStateSize> H = Mat<2, kStateSize>::Zero();
    H(0, 0) = H(1, 1) = 1.0;
    const Vec<2> y = position.head<2>() - f.x.head<2>();
    return vector_update<kStateSize, 2>(f.x, f.P, H, y, cov.topLeftCorner<2, 2>(), gate_chi2);
  }
  Mat<3, kStateSize> H = Mat<3, kStateSize>::Zero();
  H.block<3, 3>(0, 0).setIdentity();
  const Vec<3> y = position - f.x.head<3>();
  return vector_update<kStateSize, 3>(f.x, f.P, H, y, cov, gate_chi2);
}

}  // namespace ips::fusion
