#pragma once
// Measurement model: a height, z = p_z (ALTITUDE from ips-altitude, with its standard deviation;
// differential barometry, 003_baro.md).
#include "fusion/fuse_filter.hpp"

namespace ips::fusion {

inline UpdateResult update_height(FuseFilter& f, double height_m, double sigma_m,
                                  double gate_chi2) {
  Mat<1, kStateSize> H = Mat<1, kStateSize>::Zero();
  H(0, 2) = 1.0;
  return scalar_update<kStateSize>(f.x, f.P, H, height_m - f.x(2), sigma_m * sigma_m, gate_chi2);
}

}  // namespace ips::fusion
