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
#include <Eigen/Core>
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
};

struct AoaSolution {
  bool ok = false;          // a position (possibly not converged; see converged)
  bool converged = false;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (J' W J)^-1; z row/column 0 in 2D
  int iterations = 0;
  double rms_residual_rad = 0;  // unweighted, at the solution
  double rms_residual_m = 0;    // each angle residual times the anchor's distance
  std::string failure;          // why not ok / not converged
};

// Needs at least two angles from two anchors whose lines are not parallel (2D) and, in 3D, the
// elevation too. Observations with a null frame are ignored.
AoaSolution solve_aoa(const std::vector<BearingObservation>& obs, const AoaSolveOptions& opts);

}  // namespace ips::aoa
