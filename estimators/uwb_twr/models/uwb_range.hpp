#pragma once
// Measurement model: a two-way range to an anchor, h(x) = |p - a| (2D: the tag's height fixed).
//
// NLOS handling. A blocked direct path makes a range too long, never too short, so positive
// innovations are treated apart from negative ones:
// - gated tighter (gate_chi2_positive against gate_chi2);
// - down-weighted before the gate: a positive innovation of nu > downweight_sigma standard
//   deviations gets its measurement variance multiplied by nu / downweight_sigma (Huber's
//   weight k / |nu| as a variance), so a moderately long range pulls the estimate as much as
//   one at the threshold and no more.
#include <cmath>

#include "core/ekf.hpp"
#include "core/cv_filter.hpp"

namespace ips::uwb_twr {

struct RangeNoise {
  double r_var = 0.01;                   // m^2
  double gate_chi2 = kNoGate;            // for innovations <= 0 (range shorter than predicted)
  double gate_chi2_positive = kNoGate;   // for innovations > 0 (longer: NLOS)
  double downweight_sigma = kNoGate;     // Huber threshold for positive innovations; inf: off
};

// The receiver's own NLOS indicator: the total received power minus the first path's power
// (DW1000: RX_POWER and FP_POWER, dBm; FP_POWER is the first-path amplitude, FP_AMPL1..3 summed
// in power and normalised by the preamble count, so a weak first path against the multipath
// energy shows here). Decawave APS006 Part 2 ("NLOS operation and mitigation"): a difference
// below about 6 dB means the channel is likely LOS, above about 10 dB likely NLOS. In between the
// likelihood rises linearly from 0 to 1 (the note gives no finer curve), so a range is trusted
// less the weaker its first path, without a cliff at one threshold. Only when both powers are
// finite and the indicator is on (nlos_db > 0): a range without powers is never flagged.
struct NlosPower {
  double los_db = 6.0;    // at or under: LOS, likelihood 0
  double nlos_db = 10.0;  // at or over: NLOS, likelihood 1; 0 turns the indicator off
  double var_scale = 10.0;  // the variance multiplier at likelihood 1

  double likelihood(double rx_power_dbm, double fp_power_dbm) const {
    if (!(nlos_db > 0) || !std::isfinite(rx_power_dbm) || !std::isfinite(fp_power_dbm)) return 0;
    const double d = rx_power_dbm - fp_power_dbm;
    if (d >= nlos_db) return 1;
    if (d <= los_db) return 0;
    return (d - los_db) / (nlos_db - los_db);
  }
  // The range's variance multiplier: 1 at likelihood 0, var_scale at 1, linear in between.
  double variance_scale(double likelihood) const { return 1 + likelihood * (var_scale - 1); }
};

// A range corrected for a known bias: range - (bias_m + bias_per_m * range). Both 0 by default
// (the bias is the device's and its antenna delay's, see docs/real-data.md).
inline double corrected_range(double range_m, double bias_m, double bias_per_m) {
  return range_m - (bias_m + bias_per_m * range_m);
}

struct RangeUpdate {
  bool accepted = false;
  bool downweighted = false;
  double innovation_m = 0;  // z - h(x) before the update
  double normalised = 0;    // innovation / sqrt(H P H' + r_var)
  double hph = 0;           // the prediction's variance H P H' (m^2)
};

// On any state whose first D elements are the position (D = 2: the height fixed at `height`):
// the tracker's constant-velocity filter, and ips-fuse's filter.
template <int D, int N>
RangeUpdate range_update_state(Vec<N>& x, Mat<N>& P, const Eigen::Vector3d& anchor,
                               double height, double range_m, const RangeNoise& noise) {
  Eigen::Vector3d p;
  if constexpr (D == 2) {
    p << x(0), x(1), height;
  } else {
    p = x.template head<3>();
  }
  const Eigen::Vector3d d = p - anchor;
  const double predicted = std::max(d.norm(), 1e-6);
  Mat<1, N> H = Mat<1, N>::Zero();
  H.template head<D>() = (d.template head<D>() / predicted).transpose();
  RangeUpdate out;
  out.innovation_m = range_m - predicted;
  // Only the position block of H is non-zero.
  const double hph = H.template head<D>() * P.template topLeftCorner<D, D>() *
                     H.template head<D>().transpose();
  out.hph = hph;
  const double S = hph + noise.r_var;
  if (!(S > 0) || !std::isfinite(out.innovation_m)) return out;
  out.normalised = out.innovation_m / std::sqrt(S);
  const double gate = out.innovation_m > 0 ? noise.gate_chi2_positive : noise.gate_chi2;
  if (out.normalised * out.normalised > gate) return out;
  double r_var = noise.r_var;
  if (out.normalised > noise.downweight_sigma) {
    r_var *= out.normalised / noise.downweight_sigma;
    out.downweighted = true;
  }
  out.accepted = scalar_update<N>(x, P, H, out.innovation_m, r_var).accepted;
  return out;
}

template <int D>
RangeUpdate range_update(CvFilter<D>& f, const Eigen::Vector3d& anchor, double height,
                         double range_m, const RangeNoise& noise) {
  return range_update_state<D, 2 * D>(f.x, f.P, anchor, height, range_m, noise);
}

}  // namespace ips::uwb_twr
