#include "estimators/uwb_tdoa/tdoa_least_squares.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>

namespace ips::uwb_tdoa {

namespace {

constexpr int kMaxRows = 15;

template <int D>
using Jac = Eigen::Matrix<double, Eigen::Dynamic, D, Eigen::ColMajor, kMaxRows, D>;
template <int D>
using Res = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxRows, 1>;

template <int D>
Eigen::Vector3d point(const Eigen::Matrix<double, D, 1>& u, const TdoaFixOptions& o) {
  if constexpr (D == 2) {
    return {u(0), u(1), o.height_m};
  } else {
    return u;
  }
}

template <int D>
double residuals(const Eigen::Matrix<double, D, 1>& u, std::span<const Eigen::Vector3d> a,
                 std::span<const double> z, const TdoaFixOptions& o, Res<D>& r, Jac<D>* J) {
  const Eigen::Vector3d p = point<D>(u, o);
  const Eigen::Vector3d d0 = p - a[0];
  const double n0 = std::max(d0.norm(), 1e-9);
  const int m = static_cast<int>(z.size());
  r.resize(m);
  if (J) J->resize(m, D);
  for (int k = 0; k < m; ++k) {
    const Eigen::Vector3d dk = p - a[k + 1];
    const double nk = std::max(dk.norm(), 1e-9);
    r(k) = (nk - n0) - z[k];
    if (J) J->row(k) = (dk.template head<D>() / nk - d0.template head<D>() / n0).transpose();
  }
  return r.squaredNorm();
}

// Levenberg-Marquardt with Marquardt's diagonal scaling from one start.
template <int D>
TdoaFix solve_from(Eigen::Matrix<double, D, 1> u, std::span<const Eigen::Vector3d> a,
                   std::span<const double> z, const TdoaFixOptions& o,
                   const Eigen::Vector3d& centroid) {
  using V = Eigen::Matrix<double, D, 1>;
  using M = Eigen::Matrix<double, D, D>;
  Res<D> r;
  Jac<D> J;
  double cost = residuals<D>(u, a, z, o, r, &J);
  double lambda = 1e-3;
  TdoaFix fix;
  for (int it = 0; it < o.max_iterations; ++it) {
    const M A = J.transpose() * J;
    const V g = J.transpose() * r;
    M Ad = A;
    Ad.diagonal() += lambda * (A.diagonal().array() + 1e-9).matrix();
    const V step = Ad.ldlt().solve(-g);
    if (!step.allFinite()) return fix;
    const V trial = u + step;
    Res<D> rt;
    Jac<D> Jt;
    const double trial_cost = residuals<D>(trial, a, z, o, rt, &Jt);
    if (trial_cost < cost) {
      u = trial;
      cost = trial_cost;
      r = rt;
      J = Jt;
      lambda = std::max(lambda / 5.0, 1e-9);
      if ((point<D>(u, o) - centroid).norm() > o.divergence_m) return fix;
      if (step.norm() < o.convergence_m) break;
    } else {
      lambda *= 5.0;
      if (lambda > 1e9) break;  // no step lowers the cost: at a minimum
    }
  }
  const M A = J.transpose() * J;
  Eigen::LDLT<M> ldlt(A);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || A.determinant() <= 1e-12) return fix;
  fix.ok = true;
  fix.position = point<D>(u, o);
  fix.covariance_unit.setZero();
  fix.covariance_unit.template topLeftCorner<D, D>() = ldlt.solve(M::Identity());
  fix.residual_rms_m = std::sqrt(cost / static_cast<double>(z.size()));
  return fix;
}

template <int D>
TdoaFix solve(std::span<const Eigen::Vector3d> a, std::span<const double> z,
              const TdoaFixOptions& o) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : a) centroid += p;
  centroid /= static_cast<double>(a.size());
  auto start_at = [&](const Eigen::Vector3d& p) {
    Eigen::Matrix<double, D, 1> u;
    if constexpr (D == 2) {
      u << p.x(), p.y();
    } else {
      u << p.x(), p.y(), p.z() - 1.5;
    }
    return u;
  };
  TdoaFix best = solve_from<D>(start_at(centroid), a, z, o, centroid);
  // Then from near each anchor (a fifth of the way to the centroid), from where a tag close to
  // one anchor of a wide installation is reached; the lowest cost wins.
  for (const auto& p : a) {
    TdoaFix f = solve_from<D>(start_at(p + 0.2 * (centroid - p)), a, z, o, centroid);
    if (f.ok && (!best.ok || f.residual_rms_m < best.residual_rms_m)) best = f;
  }
  return best;
}

}  // namespace

TdoaFix solve_tdoa_fix(std::span<const Eigen::Vector3d> anchors,
                       std::span<const double> range_diff_m, const TdoaFixOptions& opts) {
  const int dims = opts.fixed_height ? 2 : 3;
  if (anchors.size() != range_diff_m.size() + 1 ||
      static_cast<int>(range_diff_m.size()) < dims + 1 ||
      static_cast<int>(range_diff_m.size()) > kMaxRows)
    return {};
  return opts.fixed_height ? solve<2>(anchors, range_diff_m, opts)
                           : solve<3>(anchors, range_diff_m, opts);
}

}  // namespace ips::uwb_tdoa
