#include "estimators/aoa/aoa_solvers.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>  // inverse() and determinant() of fixed-size matrices
#include <cmath>
#include <limits>

namespace ips::aoa {

std::optional<AoaSolver> parse_aoa_solver(const std::string& name) {
  if (name == "bearing_lines") return AoaSolver::kBearingLines;
  if (name == "gauss_newton" || name == "newton_raphson") return AoaSolver::kGaussNewton;
  if (name == "steepest_descent") return AoaSolver::kSteepestDescent;
  if (name == "lm" || name == "levenberg_marquardt") return AoaSolver::kLevenbergMarquardt;
  return std::nullopt;
}

const char* aoa_solver_name(AoaSolver s) {
  switch (s) {
    case AoaSolver::kBearingLines: return "bearing_lines";
    case AoaSolver::kGaussNewton: return "gauss_newton";
    case AoaSolver::kSteepestDescent: return "steepest_descent";
    case AoaSolver::kLevenbergMarquardt: return "lm";
  }
  return "?";
}

namespace {

using MatX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic>;
using VecX = Eigen::Matrix<double, Eigen::Dynamic, 1>;

// The angles a solve uses: azimuths, plus elevations in 3D.
struct Rows {
  VecX residual;  // wrapped measured - predicted, rad
  MatX jacobian;  // d predicted / d position (D columns)
  VecX sigma;     // effective (faded near the anchor)
  VecX sigma0;    // as measured
  VecX distance;  // anchor to the point, m (residual_m)
  bool valid = true;
};

template <int D>
Rows rows_at(const std::vector<const BearingObservation*>& obs, const Vec<D>& x, double height,
             double near_anchor_m) {
  const int per = D == 3 ? 2 : 1;
  const int n = static_cast<int>(obs.size()) * per;
  Rows r;
  r.residual.resize(n);
  r.jacobian.resize(n, D);
  r.sigma.resize(n);
  r.sigma0.resize(n);
  r.distance.resize(n);
  const Eigen::Vector3d p = site_point<D>(x, height);
  int row = 0;
  for (const BearingObservation* o : obs) {
    for (int k = 0; k < per; ++k, ++row) {
      const AngleKind kind = k == 0 ? AngleKind::kAzimuth : AngleKind::kElevation;
      const AnglePrediction pr = predict_angle(*o->frame, p, kind);
      if (!pr.valid) r.valid = false;
      const double z = k == 0 ? o->azimuth_rad : o->elevation_rad;
      r.residual(row) = wrap_angle(z - pr.angle_rad);
      r.jacobian.row(row) = pr.jacobian.head<D>();
      const Eigen::Vector3d rel = p - o->frame->position;
      r.distance(row) = rel.norm();
      // An azimuth is singular on the anchor's vertical axis, an elevation at the anchor.
      const double d = k == 0 ? rel.head<2>().norm() : r.distance(row);
      r.sigma0(row) = k == 0 ? o->azimuth_sigma_rad : o->elevation_sigma_rad;
      r.sigma(row) = near_anchor_sigma(r.sigma0(row), d, near_anchor_m);
    }
  }
  return r;
}

// The anchor->tag line of an observation in the site frame: unit direction (horizontal in 2D,
// where the elevation is not used).
template <int D>
Eigen::Vector3d line_direction(const BearingObservation& o) {
  const double el = D == 3 ? o.elevation_rad : 0.0;
  const Eigen::Vector3d in_anchor(std::cos(el) * std::cos(o.azimuth_rad),
                                  -std::cos(el) * std::sin(o.azimuth_rad), std::sin(el));
  Eigen::Vector3d u = o.frame->site_from_anchor * in_anchor;
  if constexpr (D == 2) u.z() = 0;
  return u.normalized();
}

// Small symmetric matrices (D <= 3): invertible when the determinant is clear of zero relative
// to the matrix's scale (closed-form inverse, no pivoting decomposition).
template <int D>
bool invertible(const Mat<D>& A) {
  const double scale = A.norm();
  return std::isfinite(scale) && scale > 0 &&
         std::abs(A.determinant()) > 1e-9 * std::pow(scale, D);
}

// Least squares on the bearing lines: minimises sum w_i |(I - u_i u_i') (p - a_i)|^2.
template <int D>
bool bearing_lines(const std::vector<const BearingObservation*>& obs, const Vec<D>* weights_from,
                   double height, Vec<D>& out) {
  Mat<D> A = Mat<D>::Zero();
  Vec<D> b = Vec<D>::Zero();
  for (const BearingObservation* o : obs) {
    const Eigen::Vector3d u3 = line_direction<D>(*o);
    if (!u3.allFinite()) return false;
    const Vec<D> u = u3.head<D>();
    const Vec<D> a = o->frame->position.head<D>();
    double w = 1.0;
    if (weights_from) {
      const double d = std::max((site_point<D>(*weights_from, height) - o->frame->position).norm(),
                                0.1);
      w = 1.0 / (d * d * o->azimuth_sigma_rad * o->azimuth_sigma_rad);
    }
    const Mat<D> proj = Mat<D>::Identity() - u * u.transpose();
    A += w * proj;
    b += w * proj * a;
  }
  // Parallel lines leave A singular: no crossing point.
  if (!invertible<D>(A)) return false;
  out = A.inverse() * b;
  return out.allFinite();
}

// The negative log-likelihood up to a constant: 1/2 sum (residual / sigma)^2 plus sum log(sigma /
// sigma0) for the angles faded near their anchor (sigma0: the measured sigma). Without the log
// term fading would make an anchor's own position cheap (its angle no longer counts there): a
// false minimum again.
template <int D>
double half_cost(const Rows& r) {
  return 0.5 * (r.residual.array() / r.sigma.array()).square().sum() +
         (r.sigma.array() / r.sigma0.array()).log().sum();
}

template <int D>
AoaSolution solve(const std::vector<const BearingObservation*>& obs, const AoaSolveOptions& o) {
  AoaSolution s;
  const double h = o.height_m;
  Vec<D> x;
  {
    Vec<D> first;
    const bool have_lines = bearing_lines<D>(obs, nullptr, h, first);
    if (have_lines) {
      Vec<D> weighted;
      x = bearing_lines<D>(obs, &first, h, weighted) ? weighted : first;
    }
    if (o.solver == AoaSolver::kBearingLines) {
      if (!have_lines) {
        s.failure = "the bearing lines do not cross (parallel)";
        return s;
      }
    } else if (o.initial) {
      x = o.initial->head<D>();
    } else if (!have_lines) {
      s.failure = "no start: the bearing lines do not cross (parallel)";
      return s;
    }
  }
  const Vec<D> start = x;
  s.converged = o.solver == AoaSolver::kBearingLines;
  if (o.solver != AoaSolver::kBearingLines) {
    double lambda = o.lm_lambda0;
    Rows r = rows_at<D>(obs, x, h, o.near_anchor_m);
    double best_cost = half_cost<D>(r);
    Vec<D> best = x;
    for (s.iterations = 1; s.iterations <= o.max_iterations; ++s.iterations) {
      if (!r.valid) {
        s.failure = "a point on an anchor's axis";
        break;
      }
      const MatX Jw = r.jacobian.array().colwise() / r.sigma.array();
      const VecX rw = r.residual.array() / r.sigma.array();
      const Mat<D> JtJ = Jw.transpose() * Jw;
      const Vec<D> Jtr = Jw.transpose() * rw;
      Vec<D> step;
      if (o.solver == AoaSolver::kSteepestDescent) {
        step = o.steepest_step * (r.jacobian.transpose() * r.residual);
      } else {
        Mat<D> A = JtJ;
        if (o.solver == AoaSolver::kLevenbergMarquardt)
          A.diagonal() += lambda * JtJ.diagonal();
        Eigen::LDLT<Mat<D>> ldlt(A);
        if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
          s.failure = "singular geometry (the lines are parallel)";
          break;
        }
        step = ldlt.solve(Jtr);
      }
      if (!step.allFinite() || step.norm() > o.diverged_step_m ||
          (x + step - start).norm() > o.diverged_step_m) {
        s.failure = "diverged";
        break;
      }
      const Vec<D> candidate = x + step;
      Rows rc = rows_at<D>(obs, candidate, h, o.near_anchor_m);
      const double cost = half_cost<D>(rc);
      if (o.solver == AoaSolver::kLevenbergMarquardt && !(cost < best_cost)) {
        // Algorithm 2: undo the step, trust the linearisation less.
        lambda *= o.lm_factor * o.lm_factor;
        if (lambda > o.lm_lambda_max) {
          s.converged = true;  // no step lowers the cost: a minimum
          break;
        }
        continue;
      }
      x = candidate;
      r = std::move(rc);
      if (cost < best_cost) {
        best_cost = cost;
        best = x;
      }
      if (o.solver == AoaSolver::kLevenbergMarquardt) lambda /= o.lm_factor;
      if (step.norm() < o.converged_step_m) {
        s.converged = true;
        break;
      }
    }
    if (s.iterations > o.max_iterations) {
      s.iterations = o.max_iterations;
      s.failure = "no convergence in " + std::to_string(o.max_iterations) + " iterations";
    }
    x = best;
  }
  const Rows r = rows_at<D>(obs, x, h, o.near_anchor_m);
  const MatX Jw = r.jacobian.array().colwise() / r.sigma.array();
  const Mat<D> info = Jw.transpose() * Jw;
  if (!r.valid || !invertible<D>(info)) {
    if (s.failure.empty()) s.failure = "singular geometry at the solution";
    return s;
  }
  s.position = site_point<D>(x, h);
  s.covariance.setZero();
  s.covariance.topLeftCorner<D, D>() = info.inverse();
  s.cost = half_cost<D>(r);
  s.rms_residual_rad = std::sqrt(r.residual.squaredNorm() / static_cast<double>(r.residual.size()));
  s.rms_residual_m = std::sqrt((r.residual.array() * r.distance.array()).square().sum() /
                               static_cast<double>(r.residual.size()));
  s.ok = s.position.allFinite() && s.covariance.allFinite();
  if (!s.ok && s.failure.empty()) s.failure = "no finite solution";
  return s;
}

}  // namespace

AoaSolution solve_aoa(const std::vector<BearingObservation>& obs, const AoaSolveOptions& opts) {
  std::vector<const BearingObservation*> used;
  used.reserve(obs.size());
  for (const auto& o : obs)
    if (o.frame && std::isfinite(o.azimuth_rad) &&
        (!opts.three_d || std::isfinite(o.elevation_rad)))
      used.push_back(&o);
  if (used.size() < 2) {
    AoaSolution s;
    s.failure = "fewer than two anchors' angles";
    return s;
  }
  auto run = [&](const AoaSolveOptions& o) {
    return opts.three_d ? solve<3>(used, o) : solve<2>(used, o);
  };
  AoaSolution best = run(opts);
  best.starts = 1;
  if (!opts.multi_start || opts.solver == AoaSolver::kBearingLines) return best;
  int starts = 1;
  auto better = [](const AoaSolution& a, const AoaSolution& b) {  // a preferred to b
    if (a.ok != b.ok) return a.ok;
    return a.ok && a.cost < b.cost;
  };
  auto try_from = [&](const std::optional<Eigen::Vector3d>& start) {
    AoaSolveOptions o = opts;
    o.initial = start;
    AoaSolution s = run(o);
    ++starts;
    if (better(s, best)) best = std::move(s);
  };
  if (opts.initial) try_from(std::nullopt);  // the bearing lines' crossing
  auto near_an_anchor = [&](const Eigen::Vector3d& p) {
    for (const BearingObservation* o : used)
      if ((p - o->frame->position).head<2>().norm() < std::max(opts.near_anchor_m, 0.05))
        return true;
    return false;
  };
  if (!best.ok || near_an_anchor(best.position)) {
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const BearingObservation* o : used) centroid += o->frame->position;
    centroid /= static_cast<double>(used.size());
    if (!opts.three_d) centroid.z() = opts.height_m;
    try_from(centroid);
  }
  best.starts = starts;
  return best;
}

}  // namespace ips::aoa
