#pragma once
// Per-epoch position from ranges to known anchors: Levenberg-Marquardt on the range residuals
// (parameters from ../shared/reference/001_hybrid_uwb_ins.md: lambda 1, factor 5, at most 100
// iterations, convergence 0.03 m, divergence 100 m). 2D mode fixes the height.
#include <Eigen/Core>
#include <limits>
#include <span>
#include <string>

namespace ips {

struct RangeObservation {
  Eigen::Vector3d anchor;
  double range_m;
};

struct MultilaterationOptions {
  bool fixed_height = false;
  double height_m = std::numeric_limits<double>::quiet_NaN();  // used when fixed_height
  double lambda0 = 1.0;
  double lambda_factor = 5.0;
  int max_iterations = 100;
  double convergence_m = 0.03;  // step size that ends the iteration
  double divergence_m = 100.0;  // distance from the start that aborts it
};

struct MultilaterationResult {
  bool ok = false;
  Eigen::Vector3d position = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix3d covariance_unit = Eigen::Matrix3d::Zero();  // (J'J)^-1; scale by sigma^2
  double residual_rms_m = std::numeric_limits<double>::quiet_NaN();
  int iterations = 0;
  std::string failure;  // why !ok
};

// Solves from `initial` (the anchors' centroid when NaN). Needs at least 3 ranges in 2D and 4 in
// 3D.
MultilaterationResult multilaterate_lm(std::span<const RangeObservation> obs,
                                       const MultilaterationOptions& opts,
                                       Eigen::Vector3d initial = Eigen::Vector3d::Constant(
                                           std::numeric_limits<double>::quiet_NaN()));

}  // namespace ips
