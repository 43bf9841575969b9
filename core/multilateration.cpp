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
}  // namespace

MultilaterationResult multilaterate_lm(std::span<const RangeObservation> obs,
                                       const MultilaterationOptions& opts,
                                       Eigen::Vector3d initial) {
  MultilaterationResult out;
  const int dims = opts.fixed_height ? 2 : 3;
  if (static_cast<int>(obs.size()) < dims + 1) {
    out.failure = "need at least " + std::to_string(dims + 1) + " ranges, got " +
                  std::to_string(obs.size());
    return out;
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

  Eigen::Vector3d p = initial;
  double lambda = opts.lambda0;
  Eigen::MatrixXd J;
  Eigen::VectorXd r;
  double cost = residuals(obs, p, dims, &J, &r);
  bool converged = false;
  for (out.iterations = 1; out.iterations <= opts.max_iterations; ++out.iterations) {
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
    Eigen::MatrixXd A = J.transpose() * J;
    Eigen::VectorXd step = A.ldlt().solve(J.transpose() * r);
    Eigen::Vector3d candidate = p;
    candidate.head(dims) += step;
    double new_cost = residuals(obs, candidate, dims, nullptr, nullptr);
    if (!(new_cost < cost)) break;
    p = candidate;
    cost = residuals(obs, p, dims, &J, &r);
  }
  Eigen::MatrixXd A = J.transpose() * J;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  if (!lu.isInvertible() || !p.allFinite()) {
    out.failure = "anchor geometry is degenerate";
    return out;
  }
  out.ok = true;
  out.position = p;
  out.covariance_unit.topLeftCorner(dims, dims) = lu.inverse();
  out.residual_rms_m = std::sqrt(cost / static_cast<double>(obs.size()));
  return out;
}

}  // namespace ips
