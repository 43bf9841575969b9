#pragma once
// Per-epoch TDoA position fix for (re-)initialising the tracker: Levenberg-Marquardt on the range
// differences r_k = (|p - a_k| - |p - a_0|) - z_k to a reference anchor a_0 (004 §2.2 leaves the
// solver open; its §2.1 minimises the ToA analogue with Levenberg-Marquardt). The hyperbolae
// can intersect more than once, so it starts from the anchors' centroid and then from near each
// anchor, and keeps the lowest cost. 2D fixes the height; 3D starts 1.5 m below the anchors'
// mean height (tags are below ceiling-mounted anchors; coplanar anchors cannot tell above from
// below).
#include <Eigen/Core>
#include <limits>
#include <span>

namespace ips::uwb_tdoa {

struct TdoaFixOptions {
  bool fixed_height = true;
  double height_m = 0;
  int max_iterations = 50;
  double convergence_m = 1e-4;  // step size that ends the iteration
  double divergence_m = 200.0;  // distance from the anchors' centroid that abandons a start
};

struct TdoaFix {
  bool ok = false;
  Eigen::Vector3d position = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix3d covariance_unit = Eigen::Matrix3d::Zero();  // (J'J)^-1; scale by sigma^2
  double residual_rms_m = std::numeric_limits<double>::quiet_NaN();
};

// anchors[0] is the reference; range_diff_m[k] = |p - anchors[k + 1]| - |p - anchors[0]|.
// Needs more differences than unknowns (one redundant, so that the residual means something):
// at least 3 in 2D, 4 in 3D, and at most 15.
TdoaFix solve_tdoa_fix(std::span<const Eigen::Vector3d> anchors,
                       std::span<const double> range_diff_m, const TdoaFixOptions& opts);

}  // namespace ips::uwb_tdoa
