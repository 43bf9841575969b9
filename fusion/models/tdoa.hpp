#pragma once
// Measurement model: one UWB TDoA blink, tightly coupled. Anchor k received it c*t_k metres of
// light after the earliest arrival (master time, from ips-uwb-tdoa's clock synchronisation), so
// against a reference anchor r: z_k = c (t_k - t_r) = |p - a_k| - |p - a_r| (the hyperboloid of
// ../shared/reference/004_uwb_kf.md §2.1, as estimators/uwb_tdoa/models/tdoa.hpp). All the
// differences of a blink go in one update with their true covariance
// R = diag(var_k) + var_r 1 1' (they share the reference's reception error); each is gated on
// its own innovation first, and when most are gated the next-nearest anchor is tried as the
// reference (the first may be the outlier).
#include <Eigen/Core>
#include <array>

#include "fusion/fuse_filter.hpp"

namespace ips::fusion {

inline constexpr int kMaxTdoaArrivals = 8;  // the reference and the 7 nearest others

struct TdoaArrivals {
  int count = 0;
  std::array<Eigen::Vector3d, kMaxTdoaArrivals> anchor;
  std::array<double, kMaxTdoaArrivals> range_m{};  // relative to any common origin
  std::array<double, kMaxTdoaArrivals> var_m2{};
};

struct TdoaUpdate {
  bool accepted = false;
  int used = 0;
  int gated = 0;  // differences rejected by the gate or by geometry
  double innovation_sq = 0;  // sum over the used differences, m^2
};

// `a` sorted nearest-first to the estimate (the nearest anchor has the most likely direct path).
// Defined in tdoa.cpp: its fixed-size updates (1 to 7 differences) cost every includer ~15 s of
// compile time when they were inline here.
TdoaUpdate update_tdoa(FuseFilter& f, const TdoaArrivals& a, double gate_chi2);

}  // namespace ips::fusion
