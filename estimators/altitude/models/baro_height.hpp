#pragma once
// Measurement model: a tag barometer's pressure, given the tag's height h (state element
// `height_index`) and a reference station's pressure p_ref at its known height h_ref
// (../shared/reference/003_baro.md (4.31), (4.32)):
//   p_hat = p_ref exp(-k (h - h_ref)),   dp_hat/dh = -k p_hat,   k = g / (R_d T_v)
// i.e. about -11.8 Pa/m indoors. One scalar update with gating (core/ekf.hpp).
#include "core/barometric.hpp"
#include "core/ekf.hpp"

namespace ips::altitude {

struct BaroReference {
  double pressure_pa = 0;           // the reference's (offset-corrected) pressure at the tag's time
  double height_m = 0;              // the reference's known height
  double inverse_scale_height = 0;  // k = g / (R_d T_v), 1/m
};

struct BaroPrediction {
  double pressure_pa;
  double dpressure_dheight;  // Pa/m
};

inline BaroPrediction predict_baro(double height_m, const BaroReference& ref) {
  const double p = barometric::pressure_above_pa(ref.pressure_pa, height_m - ref.height_m,
                                                 ref.inverse_scale_height);
  return {p, -ref.inverse_scale_height * p};
}

template <int N>
UpdateResult update_baro_height(Vec<N>& x, Mat<N>& P, int height_index, double pressure_pa,
                                const BaroReference& ref, double pressure_var_pa2,
                                double gate_chi2) {
  const BaroPrediction pred = predict_baro(x(height_index), ref);
  Mat<1, N> H = Mat<1, N>::Zero();
  H(0, height_index) = pred.dpressure_dheight;
  return scalar_update<N>(x, P, H, pressure_pa - pred.pressure_pa, pressure_var_pa2, gate_chi2);
}

}  // namespace ips::altitude
