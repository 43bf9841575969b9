#include "core/multilateration.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace ips {

namespace {
// Sum of squared residuals and the Jacobian of the ranges w.r.t. the free coordinates.
double residuals(std::span<const RangeObservation> obs, const Eigen::Vector3d& p, int dims,
                 Eigen::MatrixXd* J, Eigen::VectorXd* r) {
  const auto n = static_cast<Eigen::Index>(obs.size());
  if (J) J->resize(n, dims);
  if (r) r->resize(n);
  double ss = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    Eigen::Vector3d d = p - obs[static_cast<size_t>(i)].anchor;
    double dist = std::max(d.norm(), 1e-9);
    double res = obs[static_cast<size_t>(i)].range_m - dist;
    ss += res * res;
    if (r) (*r)(i) = res;
    if (J)
      for (int k = 0; k < dims; ++k) (*J)(i, k) = d(k) / dist;
  }
  return ss;
}

// Checks the count and picks the start point; false (with out.failure) when too few ranges.
bool prepare(std::span<const RangeObservation> obs, const MultilaterationOptions& opts,
             Eigen::Vector3d& initial, MultilaterationResult& out) {
  const int dims = opts.fixed_height ? 2 : 3;
  if (static_cast<int>(obs.size()) < dims + 1) {
    out.failure = "need at least " + std::to_string(dims + 1) + " ranges, got " +
                  std::to_string(obs.size());
    return false;
  }
  if (!initial.allFinite()) {
    initial = Eigen::Vector3d::Zero();
    for (const auto& o : obs) initial += o.anchor;
    initial /= static_cast<double>(obs.size());
    // With anchors at one height, start below them: tags are carried below the anchors, and the
    // mirror solution above is a local minimum.
    initial.z() -= 1.0;
  }
  if (opts.fixed_height) initial.z() = opts.height_m;
  return true;
}

// The unit covariance (J'J)^-1 at the solution and the residual RMS.
MultilaterationResult finish(std::span<const RangeObservation> obs, const Eigen::Vector3d& p,
                             int dims, int iterations) {
  MultilaterationResult out;
  out.iterations = iterations;
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  const double cost = residuals(obs, p, dims, &J, &r);
  Eigen::MatrixXd A = J.transpose() * J;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!p.allFinite() || !lu.isInvertible()) {
    out.failure = "anchor geometry is degenerate";
    return out;
  }
  out.ok = true;
  out.position = p;
  out.covariance_unit.topLeftCorner(dims, dims) = lu.inverse();
  out.residual_rms_m = std::sqrt(cost / static_cast<double>(obs.size()));
  return out;
}

// The Gauss-Newton step (J'J)^-1 J'r; NaN when J'J is singular.
Eigen::VectorXd gauss_newton_step(const Eigen::MatrixXd& J, const Eigen::VectorXd& r) {
  Eigen::FullPivLU<Eigen::MatrixXd> lu(J.transpose() * J);
  if (!lu.isInvertible())
    return Eigen::VectorXd::Constant(J.cols(), std::numeric_limits<double>::quiet_NaN());
  return lu.solve(J.transpose() * r);
}

}  // namespace

std::optional<MultilaterationSolver> parse_multilateration_solver(const std::string& name) {
  if (name == "lm") return MultilaterationSolver::kLevenbergMarquardt;
  if (name == "gauss_newton") return MultilaterationSolver::kGaussNewton;
  if (name == "foy") return MultilaterationSolver::kFoy;
  return std::nullopt;
}

const char* multilateration_solver_name(MultilaterationSolver solver) {
  switch (solver) {
    case MultilaterationSolver::kLevenbergMarquardt: return "lm";
    case MultilaterationSolver::kGaussNewton: return "gauss_newton";
    case MultilaterationSolver::kFoy: return "foy";
  }
  return "?";
}

MultilaterationResult multilaterate(std::span<const RangeObservation> obs,
                                    const MultilaterationOptions& opts,
                                    MultilaterationSolver solver, Eigen::Vector3d initial) {
  switch (solver) {
    case MultilaterationSolver::kGaussNewton:
      return multilaterate_gauss_newton(obs, opts, initial);
    case MultilaterationSolver::kFoy:
      return multilaterate_foy(obs, opts);
    case MultilaterationSolver::kLevenbergMarquardt:
      break;
  }
  return multilaterate_lm(obs, opts, initial);
}

MultilaterationResult multilaterate_dropping_one(std::span<const RangeObservation> obs,
                                                 const MultilaterationOptions& opts,
                                                 MultilaterationSolver solver,
                                                 double max_residual_m) {
  const size_t needed = opts.fixed_height ? 3 : 4;
  // The residual per degree of freedom: with one range to spare, a 1.3 m NLOS range leaves an
  // RMS over all ranges of only about 0.3 m, but the whole of it in the one spare dimension.
  const auto consistent = [&](const MultilaterationResult& r, size_t n) {
    return r.ok && r.residual_rms_m * std::sqrt(static_cast<double>(n) /
                                                static_cast<double>(n - needed)) <=
                       max_residual_m;
  };
  MultilaterationResult res = multilaterate(obs, opts, solver);
  if (obs.size() <= needed || consistent(res, obs.size())) return res;
  // An NLOS range in the set: without each range in turn, the best fit of those that can still
  // be checked (a set with no range to spare fits any one NLOS range exactly).
  MultilaterationResult best;
  best.failure = "no consistent subset of the ranges";
  if (obs.size() >= needed + 2) {
    std::vector<RangeObservation> subset;
    for (size_t skip = 0; skip < obs.size(); ++skip) {
      subset.clear();
      for (size_t k = 0; k < obs.size(); ++k)
        if (k != skip) subset.push_back(obs[k]);
      MultilaterationResult r = multilaterate(subset, opts, solver);
      if (consistent(r, subset.size()) && (!best.ok || r.residual_rms_m < best.residual_rms_m))
        best = r;
    }
  }
  return best;
}

MultilaterationResult multilaterate_foy(std::span<const RangeObservation> obs,
                                        const MultilaterationOptions& opts) {
  MultilaterationResult out;
  Eigen::Vector3d p = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  if (!prepare(obs, opts, p, out)) return out;
  const Eigen::Vector3d start = p;
  const int dims = opts.fixed_height ? 2 : 3;
  Eigen::MatrixXd G;
  Eigen::VectorXd h;
  for (int it = 1; it <= opts.max_iterations; ++it) {
    residuals(obs, p, dims, &G, &h);
    const Eigen::VectorXd d = gauss_newton_step(G, h);
    if (!d.allFinite()) {
      out.failure = "anchor geometry is degenerate";
      return out;
    }
    p.head(dims) += d;
    if ((p - start).norm() > opts.divergence_m) {
      out.failure = "diverged beyond " + std::to_string(opts.divergence_m) + " m";
      return out;
    }
    if (d.norm() < opts.convergence_m) return finish(obs, p, dims, it);
  }
  out.failure = "did not converge in " + std::to_string(opts.max_iterations) + " iterations";
  return out;
}

MultilaterationResult multilaterate_gauss_newton(std::span<const RangeObservation> obs,
                                                 const MultilaterationOptions& opts,
                                                 Eigen::Vector3d initial) {
  MultilaterationResult out;
  if (!prepare(obs, opts, initial, out)) return out;
  const int dims = opts.fixed_height ? 2 : 3;
  Eigen::Vector3d p = initial;
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  double cost = residuals(obs, p, dims, &J, &r);
  for (int it = 1; it <= opts.max_iterations; ++it) {
    Eigen::VectorXd step = gauss_newton_step(J, r);
    if (!step.allFinite()) {
      out.failure = "anchor geometry is degenerate";
      return out;
    }
    // Step halving: the full step can overshoot far from the solution (poor geometry).
    Eigen::Vector3d candidate = p;
    double new_cost = cost;
    int halvings = 0;
    for (; halvings <= 10; ++halvings, step *= 0.5) {
      candidate = p;
      candidate.head(dims) += step;
      new_cost = residuals(obs, candidate, dims, nullptr, nullptr);
      if (new_cost <= cost) break;
    }
    if (halvings > 10) return finish(obs, p, dims, it);  // no step lowers the cost: at a minimum
    p = candidate;
    cost = residuals(obs, p, dims, &J, &r);
    if ((p - initial).norm() > opts.divergence_m) {
      out.failure = "diverged beyond " + std::to_string(opts.divergence_m) + " m";
      return out;
    }
    if (step.norm() < 1e-3 * opts.convergence_m) return finish(obs, p, dims, it);
  }
  out.failure = "did not converge in " + std::to_string(opts.max_iterations) + " iterations";
  return out;
}

MultilaterationResult multilaterate_lm(std::span<const RangeObservation> obs,
                                       const MultilaterationOptions& opts,
                                       Eigen::Vector3d initial) {
  MultilaterationResult out;
  if (!prepare(obs, opts, initial, out)) return out;
  const int dims = opts.fixed_height ? 2 : 3;

  Eigen::Vector3d p = initial;
  double lambda = opts.lambda0;
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  double cost = residuals(obs, p, dims, &J, &r);
  bool converged = false;
  int it = 1;
  for (; it <= opts.max_iterations; ++it) {
    Eigen::MatrixXd A = J.transpose() * J;
    Eigen::VectorXd g = J.transpose() * r;
    // Marquardt's scaling of the damping by the diagonal.
    Eigen::MatrixXd Ad = A;
    Ad.diagonal() += lambda * A.diagonal().cwiseMax(1e-9);
    Eigen::VectorXd step = Ad.ldlt().solve(g);
    Eigen::Vector3d candidate = p;
    candidate.head(dims) += step;
    double new_cost = residuals(obs, candidate, dims, nullptr, nullptr);
    if (new_cost < cost) {
      p = candidate;
      cost = residuals(obs, p, dims, &J, &r);
      lambda /= opts.lambda_factor;
      if (step.norm() < opts.convergence_m) {
        converged = true;
        break;
      }
    } else {
      lambda *= opts.lambda_factor;
      if (lambda > 1e12) {  // no descent direction left: at a minimum
        converged = true;
        break;
      }
    }
    if ((p - initial).norm() > opts.divergence_m) {
      out.failure = "diverged beyond " + std::to_string(opts.divergence_m) + " m";
      return out;
    }
  }
  if (!converged) {
    out.failure = "did not converge in " + std::to_string(opts.max_iterations) + " iterations";
    return out;
  }
  // A few undamped Gauss-Newton polish steps: LM stops at the 0.03 m step criterion.
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd step = gauss_newton_step(J, r);
    if (!step.allFinite()) break;
    Eigen::Vector3d candidate = p;
    candidate.head(dims) += step;
    double new_cost = residuals(obs, candidate, dims, nullptr, nullptr);
    if (!(new_cost < cost)) break;
    p = candidate;
    cost = residuals(obs, p, dims, &J, &r);
  }
  return finish(obs, p, dims, it);
}

}  // namespace ips
