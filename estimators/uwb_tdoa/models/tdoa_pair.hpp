#pragma once
// Pairwise TDoA measurement model (uwb_tdoa_t on UWB_TDOA, as Loco-style systems deliver it):
// z = diff_m = |p - b| - |p - a| for anchors a and b, Crazyflie's convention. The update is
// Crazyflie's mm_tdoa.c scalar update: predicted d_b - d_a, H row = unit(p - b) - unit(p - a)
// (zero on the velocity states), one scalar Kalman update per pair. In 2D the height is fixed at
// the tag's. It is models/tdoa.hpp's row with b as "anchor i" and a as the reference.
#include <Eigen/Core>
#include <cmath>

#include "core/cv_filter.hpp"
#include "core/ekf.hpp"
#include "estimators/uwb_tdoa/models/tdoa.hpp"

namespace ips::uwb_tdoa {

// h(x) = |p - b| - |p - a| and its Jacobian row.
template <int D>
TdoaRow<D> tdoa_pair_row(const Vec<2 * D>& x, double height, const Eigen::Vector3d& a,
                         const Eigen::Vector3d& b) {
  return tdoa_row<D>(x, height, b, a);
}


template <int D>
struct PairPrediction {
  TdoaRow<D> row;
  double y = 0;    // z - h(x), m
  double hph = 0;  // H P H', m^2
};

template <int D>
PairPrediction<D> predict_pair(const CvFilter<D>& f, double height, const Eigen::Vector3d& a,
                               const Eigen::Vector3d& b, double z_m) {
  PairPrediction<D> p;
  p.row = tdoa_pair_row<D>(f.x, height, a, b);
  p.y = z_m - p.row.predicted;
  p.hph = (p.row.H * f.P * p.row.H.transpose())(0, 0);
  return p;
}

// Applies one pair (no gate here: the caller gated it on predict_pair's y and hph).
template <int D>
UpdateResult apply_pair(CvFilter<D>& f, const PairPrediction<D>& p, double r_var) {
  return scalar_update<2 * D>(f.x, f.P, p.row.H, p.y, r_var);
}

// The outlier gate of one tag's pair track. Two parts, because NLOS biases on TDoA (-0.2 to
// -3.9 m in the UTIL dataset) are many sigmas and persistent, per anchor:
//  - a chi-square gate on each pair's normalised innovation y^2 / (H P H' + R) <= gate^2: a
//    biased pair is far outside it once the track holds (1 m against 0.1 m), so one anchor in
//    NLOS loses its pairs and the others keep the track; while the track is young its P is
//    large and the gate is wide by itself (convergence needs no special case);
//  - an integrator on the gate's verdicts, Crazyflie's outlierFilterTdoa idea the other way
//    round: Crazyflie integrates the error and opens its gate after a run of large errors, since
//    then the estimate, not the measurements, is wrong. Here each gated pair adds 1 and each
//    accepted pair takes lost_share / (1 - lost_share) away (not below 0), so the level climbs
//    only while more than lost_share (0.4) of the pairs are refused: one NLOS anchor in n makes
//    about 2 in n refused (TDoA2's consecutive pairs), a lost track most of them (pairs of two
//    anchors above one another can still pass). At `lost_level` the track is declared lost and
//    restarted from a fresh least-squares fix over the recent pairs, which leaves out an NLOS
//    anchor or trims the worst pairs (the robust fallback: solve_pair_fix), instead of opening
//    the gate to everything, biased pairs included.
struct PairGate {
  double gate_sigma = 3.0;
  double lost_level = 20.0;
  double lost_share = 0.4;
  double level = 0.0;

  // True when the pair passes.
  bool admit(double y, double s) const { return y * y <= gate_sigma * gate_sigma * s; }
  // Records a verdict; true when the track is now considered lost.
  bool record(bool accepted) {
    level = accepted ? std::max(0.0, level - lost_share / (1.0 - lost_share)) : level + 1.0;
    return level >= lost_level;
  }
  void reset() { level = 0.0; }
};

}  // namespace ips::uwb_tdoa
