// UWB two-way ranges (UWB_RANGE), tightly coupled: ips-uwb-twr's range model
// (estimators/uwb_twr/models/uwb_range.hpp) with its NLOS gating, down-weighting and per-pair
// range offsets.
#include "fusion/fuse_estimator.hpp"

#include <cmath>
#include <map>
#include <utility>
#include <vector>

#include "core/multilateration.hpp"
#include "estimators/uwb_twr/models/uwb_range.hpp"
#include "fusion/fuse_inputs.hpp"

namespace ips::fusion {

namespace {
constexpr double kMaxRangeM = 1000.0;
}  // namespace

void FuseEstimator::on_range(const uwb_range_t& m) {
  // Anchor-to-anchor ranging (ips-uwb-survey's input): neither end is a tag, and no track is
  // made for the anchor (one ranged by three others would have started and been published).
  if (site_ && site_->find_anchor(m.tag_id)) {
    ++stats_.messages_in;
    ++stats_.anchor_pair_ranges;
    return;
  }
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_range(m); });
  if (!t) return;
  if (!std::isfinite(m.range_m) || m.range_m < 0 || m.range_m > kMaxRangeM) {
    ++stats_.dropped_invalid;
    return;
  }
  const Anchor* a = site_->find_anchor(m.anchor_id);
  if (!a || !a->enabled) {
    ++stats_.dropped_unknown_anchor;
    return;
  }
  Measurement r;
  r.kind = Measurement::Kind::kRange;
  r.t = m.utime;
  r.anchor = static_cast<int>(a - site_->anchors.data());
  // A copy of a range already taken (a LAN's repeated datagram) would be fused twice.
  if (t->range_repeats.repeated(repeat_key(m.utime, m.seq, r.anchor, m.range_m))) {
    ++stats_.dropped_range_repeated;
    return;
  }
  if (!t->offsets_set) {  // the prior and the configured scales: as ips-uwb-twr's
    t->offsets = uwb_twr::initial_offsets(radio_, m.tag_id, site_->anchors);
    t->offsets_set = true;
  }
  r.value = t->offsets.unscaled(
      static_cast<size_t>(r.anchor),
      uwb_twr::corrected_range(m.range_m, params_.range_bias_m, params_.range_bias_per_m));
  r.nlos_p = params_.nlos_power().likelihood(m.rx_power_dbm, m.fp_power_dbm);
  r.source = kSrcRange;
  learn_offsets(*t, r);
  // The pair's offset off before use: the gate judges what is left (an antenna delay is not NLOS).
  r.value -= t->offsets.offset_m(static_cast<size_t>(r.anchor));
  t->recent_ranges.push_back(r);
  if (t->recent_ranges.size() > 64) t->recent_ranges.pop_front();
  if (!t->initialised) {
    try_start_from_ranges(m.tag_id, *t);
    if (!t->initialised) ++stats_.waiting_start;
    return;
  }
  add(m.tag_id, *t, std::move(r));
  if (t->initialised) check_against_ranges(m.tag_id, *t);
}

void FuseEstimator::learn_offsets(Track& t, const Measurement& r) {
  if (!radio_.learn_bias) return;
  t.epoch_ranges.push_back({r.t, r.anchor, r.value});
  const utime_t window = s_to_utime(params_.epoch_window_s);
  while (t.epoch_ranges.size() > 64 ||
         (t.epoch_ranges.size() > 1 && r.t - t.epoch_ranges.front().t > window))
    t.epoch_ranges.pop_front();
  // One epoch per ips-uwb-twr epoch window, on a running track.
  if (!t.initialised ||
      (t.last_offsets_t != 0 && r.t - t.last_offsets_t < s_to_utime(radio_.epoch_window_s)))
    return;
  std::map<size_t, std::pair<utime_t, double>> latest;
  for (const auto& e : t.epoch_ranges) latest[static_cast<size_t>(e.anchor)] = {e.t, e.value};
  const FuseFilter& f = t.state.filter;
  const int dims = f.planar ? 2 : 3;
  std::vector<Eigen::Vector3d> positions;
  double r_var = 0;
  for (const auto& a : site_->anchors) {
    positions.push_back(a.position);
    r_var = std::max(r_var, consistency_.variance(
                                "RANGE", a.id, params_.range_sigma_m * params_.range_sigma_m,
                                noise_link(t, static_cast<size_t>(&a - site_->anchors.data()))));
  }
  const Eigen::Vector3d track = f.x.head<3>();
  Eigen::Vector3d v = f.x.segment<3>(kVel);
  if (f.planar) v.z() = 0;
  t.last_offsets_t = r.t;
  uwb_twr::learn_offsets_from_epoch(
      t.offsets, latest, positions, r.t, track, v, f.P.topLeftCorner(dims, dims).trace(), dims,
      params_.range_sigma_m, r_var, 1.0 - 1.0 / radio_.bias_window, radio_.bias_max_m,
      MultilaterationSolver::kLevenbergMarquardt);
}

ConsistencyMonitor::LinkId FuseEstimator::noise_link(Track& t, size_t anchor_index) {
  return consistency_.cached_link(t.noise_links, anchor_index, site_->anchors.size(), "RANGE",
                                  site_->anchors[anchor_index].id, t.tag_id);
}

void FuseEstimator::apply_range(Track& t, Snapshot& s, const Measurement& m, bool live) {
  FuseFilter& f = s.filter;
  uwb_twr::RangeNoise noise;
  const double r_cfg = params_.range_sigma_m * params_.range_sigma_m;
  const std::string& anchor_id = site_->anchors[static_cast<size_t>(m.anchor)].id;
  const ConsistencyMonitor::LinkId link = noise_link(t, static_cast<size_t>(m.anchor));
  noise.r_var = consistency_.variance("RANGE", anchor_id, r_cfg, link);  // the link's
  noise.gate_chi2 = params_.gate_sigma * params_.gate_sigma;
  noise.gate_chi2_positive = params_.nlos_gate_sigma * params_.nlos_gate_sigma;
  noise.downweight_sigma = params_.nlos_downweight_sigma;
  noise.r_var *= params_.nlos_power().variance_scale(m.nlos_p);  // rx - fp: likely NLOS
  // The offset taken off (learned: uncertain, uwb_twr/models/range_bias.hpp).
  if (t.offsets_set) noise.r_var += t.offsets.var_m2(static_cast<size_t>(m.anchor));
  const Eigen::Vector3d& anchor = site_->anchors[static_cast<size_t>(m.anchor)].position;
  const uwb_twr::RangeUpdate u =
      f.planar ? uwb_twr::range_update_state<2, kStateSize>(f.x, f.P, anchor, f.x(2),
                                                            m.value, noise)
               : uwb_twr::range_update_state<3, kStateSize>(f.x, f.P, anchor, 0.0, m.value,
                                                            noise);
  // Where the ranges checked fixes of late, the track is judged by check_against_ranges rather
  // than widened.
  constexpr utime_t kCheckedRecently = 2'000'000;
  count_absolute(s, m.t, u.accepted, live,
                 t.last_checked_fix == 0 || m.t - t.last_checked_fix > kCheckedRecently);
  if (live) {
    consistency_.add_scalar("RANGE", anchor_id, utime_to_s(m.t), u.innovation_m, u.hph, r_cfg,
                            !u.accepted, range_setting_, link);
    (u.accepted ? stats_.ranges_used : stats_.ranges_rejected)++;
    if (!u.accepted) ++t.gated_since_check;
    if (u.accepted && m.nlos_p > 0.5) ++stats_.ranges_nlos_power;
    if (u.accepted) {
      t.tally.add(u.innovation_m);
      t.sources |= kSrcRange;
    }
  }
}

}  // namespace ips::fusion
