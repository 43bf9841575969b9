#pragma once
// Measurement model: one pairwise TDoA (uwb_tdoa_t on UWB_TDOA, as Loco-style systems deliver it:
// clocks synchronised upstream), z = diff_m = |p - b| - |p - a|. It is the two-arrival case of
// models/tdoa.hpp with anchor a as the reference: arrivals a at 0 and b at diff_m, the pair's
// variance split between them (update_tdoa adds the two back), so the update is Crazyflie's
// mm_tdoa.c scalar update: predicted d_b - d_a, H row unit(p - b) - unit(p - a) on the position
// states, gated on its own innovation (tdoa_gate_sigma).
#include <Eigen/Core>

#include "fusion/models/tdoa.hpp"

namespace ips::fusion {

inline TdoaArrivals pair_arrivals(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  double diff_m, double var_m2) {
  TdoaArrivals out;
  out.count = 2;
  out.anchor[0] = a;
  out.anchor[1] = b;
  out.range_m[0] = 0.0;
  out.range_m[1] = diff_m;
  out.var_m2[0] = out.var_m2[1] = 0.5 * var_m2;
  return out;
}

}  // namespace ips::fusion
