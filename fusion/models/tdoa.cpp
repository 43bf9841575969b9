// The tightly coupled TDoA update (models/tdoa.hpp).
#include "fusion/models/tdoa.hpp"

#include <algorithm>
#include <cmath>

namespace ips::fusion {

namespace detail {

template <int M>
UpdateResult tdoa_vector_update(FuseFilter& f, const Mat<1, kStateSize>* rows, const double* y,
                                const double* var, double var_ref, int m) {
  if constexpr (M > kMaxTdoaArrivals - 1) {
    return {};
  } else if constexpr (M == 1) {
    // One difference: the scalar update is the same thing, without a 1 x 1 factorisation.
    if (m == 1) return scalar_update<kStateSize>(f.x, f.P, rows[0], y[0], var[0] + var_ref);
    return tdoa_vector_update<2>(f, rows, y, var, var_ref, m);
  } else {
    if (m != M) return tdoa_vector_update<M + 1>(f, rows, y, var, var_ref, m);
    Mat<M, kStateSize> H;
    Vec<M> yy;
    Mat<M> R = Mat<M>::Constant(var_ref);
    for (int k = 0; k < M; ++k) {
      H.row(k) = rows[k];
      yy(k) = y[k];
      R(k, k) += var[k];
    }
    return vector_update<kStateSize, M>(f.x, f.P, H, yy, R);
  }
}

}  // namespace detail

TdoaUpdate update_tdoa(FuseFilter& f, const TdoaArrivals& a, double gate_chi2) {
  struct Gated {
    std::array<Mat<1, kStateSize>, kMaxTdoaArrivals - 1> rows;
    std::array<double, kMaxTdoaArrivals - 1> y{}, var{};
    int accepted = 0, gated = 0;
  };
  const int dims = f.planar ? 2 : 3;
  const Eigen::Vector3d p = f.x.head<3>();
  auto gate_with = [&](int r, Gated& g) {
    const Eigen::Vector3d dr = p - a.anchor[r];
    const double nr = std::max(dr.norm(), 1e-6);
    for (int k = 0; k < a.count; ++k) {
      if (k == r) continue;
      const double z = a.range_m[k] - a.range_m[r];
      const double noise = std::sqrt(a.var_m2[k] + a.var_m2[r]);
      // |d_k - d_r| <= |a_k - a_r| (triangle inequality), up to the noise.
      if (std::abs(z) > (a.anchor[k] - a.anchor[r]).norm() + 5.0 * noise + 0.5) {
        ++g.gated;
        continue;
      }
      const Eigen::Vector3d dk = p - a.anchor[k];
      const double nk = std::max(dk.norm(), 1e-6);
      Mat<1, kStateSize> H = Mat<1, kStateSize>::Zero();
      for (int i = 0; i < dims; ++i) H(0, i) = dk(i) / nk - dr(i) / nr;
      const double y = z - (nk - nr);
      const double S = (H * f.P * H.transpose())(0, 0) + a.var_m2[k] + a.var_m2[r];
      if (!(y * y <= gate_chi2 * S)) {
        ++g.gated;
        continue;
      }
      g.rows[g.accepted] = H;
      g.y[g.accepted] = y;
      g.var[g.accepted] = a.var_m2[k];
      ++g.accepted;
    }
  };
  TdoaUpdate out;
  if (a.count < 2) return out;
  Gated g;
  int ref = 0;
  gate_with(0, g);
  if (g.accepted < g.gated && a.count >= 3) {
    Gated g2;
    gate_with(1, g2);
    if (g2.accepted > g.accepted) {
      g = g2;
      ref = 1;
    }
  }
  out.gated = g.gated;
  // Differences that mostly disagree with the track say more that the track is wrong than that
  // they are: the few that pass are not applied either.
  if (g.accepted == 0 || g.accepted < g.gated) return out;
  const UpdateResult u = detail::tdoa_vector_update<1>(f, g.rows.data(), g.y.data(),
                                                       g.var.data(), a.var_m2[ref], g.accepted);
  if (!u.accepted) {
    out.gated += g.accepted;
    return out;
  }
  out.accepted = true;
  out.used = g.accepted;
  for (int i = 0; i < g.accepted; ++i) out.innovation_sq += g.y[i] * g.y[i];
  return out;
}

}  // namespace ips::fusion
