#pragma once
// Per-epoch AoA position solvers (source 000 section 3): one position from the angles of one
// advertisement at several anchors.
//   - kBearingLines: linear least squares on the bearing lines (each anchor's line towards the
//     tag; 2D: the horizontal lines, sum of squared perpendicular distances; 3D with elevation:
//     the 3D lines). Closed form; a second pass weights each line by 1 / (sigma d)^2 with d the
//     distance from the first pass. No start needed: the iterative solvers start from it.
//   - kGaussNewton: the source's "Newton-Raphson", x += (J'J)^-1 J' rho (5.13).
//   - kSteepestDescent: x += a J' rho (5.15), a = steepest_step (the source's a = 1).
//   - kLevenbergMarquardt: x += (J'J + lambda diag(J'J))^-1 J' rho (5.18) with the source's
//     schedule (Algorithm 2): lambda0 = 1, lambda /= c after an improving step, a step that does
//     not lower the cost is undone and lambda *= c^2; c = 5, stop at lambda > 1e5.
// rho_i = wrapped (measured - predicted) angle; the residuals and Jacobian rows of the
// iterative solvers are divided by each angle's sigma (all equal in the source, where this is
// its unweighted cost g = 1/2 sum rho^2 up to a constant), except steepest descent, which
// keeps the source's unweighted step so that a = 1 means what it meant there.
// Termination (source): at most 100 iterations; converged when the step is below
// converged_step_m (source 0.03 m; our default 1 mm: 3 cm stops early, which with the source's
// warm start acts as smoothing); diverged when a step exceeds 100 m. A failed solve keeps the
// best point found, flagged.
// Next to an anchor its bearing is undefined and the weighted residual's Jacobian grows as 1/d:
// the cost has a false minimum there (every step shrinks with d, so "converged" triggers), and
// a warm start keeps the solver in it. So each angle's sigma is inflated by (1 + (near_anchor_m
// / d)^2) (d: the anchor to the point, horizontal for an azimuth; the near field of the array):
// far away it is the measured sigma, within near_anchor_m the angle fades out and its weighted
// Jacobian stays bounded (d / (sigma (d^2 + near_anchor_m^2))), the other anchors decide. The
// cost is the negative log-likelihood with that sigma (the log sigma term makes the anchor's
// own position expensive instead of free; it moves an exact solution by micrometres). And the iterative solvers start
// from several points (multi_start): the given start, the bearing lines' crossing and, when the
// best so far lies within near_anchor_m of an anchor or failed, the anchors' centroid; the
// lowest cost wins.
#include <Eigen/Core>
#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "estimators/aoa/models/aoa_bearing.hpp"

namespace ips::aoa {

enum class AoaSolver { kBearingLines, kGaussNewton, kSteepestDescent, kLevenbergMarquardt };

// "bearing_lines", "gauss_newton" (alias "newton_raphson"), "steepest_descent", "lm".
std::optional<AoaSolver> parse_aoa_solver(const std::string& name);
const char* aoa_solver_name(AoaSolver s);

struct BearingObservation {
  const AnchorFrame* frame = nullptr;
  double azimuth_rad = 0;       // anchor frame, corrected
  double elevation_rad = 0;     // anchor frame, corrected; used by 3D solves only
  double azimuth_sigma_rad = 0.0873;
  double elevation_sigma_rad = 0.0873;
};

struct AoaSolveOptions {
  AoaSolver solver = AoaSolver::kLevenbergMarquardt;
  bool three_d = false;      // 3D: x, y, z from azimuth and elevation; 2D: z = height_m
  double height_m = 0;
  std::optional<Eigen::Vector3d> initial;  // start of the iterative solvers; none: bearing lines
  int max_iterations = 100;
  double converged_step_m = 1e-3;
  double diverged_step_m = 100.0;
  double lm_lambda0 = 1.0;
  double lm_factor = 5.0;
  double lm_lambda_max = 1e5;
  double steepest_step = 1.0;  // m^2/rad (the source's a)
  double near_anchor_m = 0.5;  // sigma * (1 + (near_anchor_m / d)^2); 0: off (the source)
  bool multi_start = true;
};

struct AoaSolution {
  bool ok = false;          // a position (possibly not converged; see converged)
  bool converged = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (J' W J)^-1; z row/column 0 in 2D
  int iterations = 0;
  double rms_residual_rad = 0;  // unweighted, at the solution
  double rms_residual_m = 0;    // each angle residual times the anchor's distance
  double cost = 0;              // 1/2 sum (residual / effective sigma)^2 at the solution
  int starts = 0;               // starting points tried
  std::string failure;          // why not ok / not converged
};

// Needs at least two angles from two anchors whose lines are not parallel (2D) and, in 3D, the
// elevation too. Observations with a null frame are ignored.
AoaSolution solve_aoa(const std::vector<BearingObservation>& obs, const AoaSolveOptions& opts);

// The effective sigma of an angle whose anchor is d metres from the point (see above).
inline double near_anchor_sigma(double sigma, double d, double near_anchor_m) {
  if (!(near_anchor_m > 0)) return sigma;
  const double q = near_anchor_m / std::max(d, 1e-6);
  return sigma * (1.0 + q * q);
}

}  // namespace ips::aoa
