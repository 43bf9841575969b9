#pragma once
// Per-epoch position from ranges to known anchors, three solvers of the range residuals:
// - Levenberg-Marquardt (parameters from ../shared/reference/001_hybrid_uwb_ins.md: lambda 1,
//   factor 5, at most 100 iterations, convergence 0.03 m, divergence 100 m);
// - Gauss-Newton with step halving (a step that raises the cost is halved up to 10 times);
// - Foy's Taylor-series least squares as the source prints it (001 §3.3.2): start at the
//   anchors' centroid, undamped steps d = (G'G)^-1 G'h until |d| < convergence_m.
// 2D mode fixes the height; the ranges are then 3D distances to a point at that height, which is
// the same as Foy's "remove the height trigonometrically" (r_h = sqrt(r^2 - dh^2)) without the
// square root's failure for r < dh.
#include <Eigen/Core>
#include <limits>
#include <optional>
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

enum class MultilaterationSolver { kLevenbergMarquardt, kGaussNewton, kFoy };

// "lm", "gauss_newton", "foy"; nullopt for anything else.
std::optional<MultilaterationSolver> parse_multilateration_solver(const std::string& name);
const char* multilateration_solver_name(MultilaterationSolver solver);

// Each solves from `initial` (the anchors' centroid when NaN; Foy always starts there). Each needs
// at least 3 ranges in 2D and 4 in 3D.
MultilaterationResult multilaterate(std::span<const RangeObservation> obs,
                                    const MultilaterationOptions& opts,
                                    MultilaterationSolver solver,
                                    Eigen::Vector3d initial = Eigen::Vector3d::Constant(
                                        std::numeric_limits<double>::quiet_NaN()));
// A start fix that one NLOS range cannot spoil: the fix of all ranges when its residual RMS per
// degree of freedom is within max_residual_m; else, where two ranges can be spared, the best
// such fix leaving one range out; else !ok (the caller waits for a consistent epoch). A set with
// no range to spare (3 in 2D, 4 in 3D) is returned as solved: nothing can check it, and the
// caller must not trust it much. ips-uwb-twr's and ips-fuse's start.
MultilaterationResult multilaterate_dropping_one(std::span<const RangeObservation> obs,
                                                 const MultilaterationOptions& opts,
                                                 MultilaterationSolver solver,
                                                 double max_residual_m);
MultilaterationResult multilaterate_gauss_newton(std::span<const RangeObservation> obs,
                                                 const MultilaterationOptions& opts,
                                                 Eigen::Vector3d initial = Eigen::Vector3d::Constant(
                                                     std::numeric_limits<double>::quiet_NaN()));
MultilaterationResult multilaterate_foy(std::span<const RangeObservation> obs,
                                        const MultilaterationOptions& opts);
MultilaterationResult multilaterate_lm(std::span<const RangeObservation> obs,
                                       const MultilaterationOptions& opts,
                                       Eigen::Vector3d initial = Eigen::Vector3d::Constant(
                                           std::numeric_limits<double>::quiet_NaN()));

}  // namespace ips
