// UWB TDoA, tightly coupled (models/tdoa.hpp, models/tdoa_pair.hpp): the blinks (UWB_RX) through
// ips-uwb-tdoa's clock synchronisation and grouping, and pairwise differences (UWB_TDOA).
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "core/device_text.hpp"
#include "fusion/fuse_inputs.hpp"
#include "fusion/models/tdoa.hpp"
#include "fusion/models/tdoa_pair.hpp"

namespace ips::fusion {

void FuseEstimator::on_rx(const uwb_rx_t& m) {
  if (have_site_for_raw()) tdoa_.on_rx(m);  // its blinks come back through on_tdoa_epoch
}

void FuseEstimator::on_pair(const uwb_tdoa_t& m) {
  if (!have_site_for_raw()) return;
  // Applied to the track first (as a blink goes before its hosted fix); the hosted pair tracker
  // then counts it (its drops are this process's) and, for a tag without a track, starts one.
  const Anchor* a = site_->find_anchor(m.anchor_a);
  const Anchor* b = site_->find_anchor(m.anchor_b);
  const bool usable = a && b && a != b && a->enabled && b->enabled && a->kind == "uwb_tdoa" &&
                      b->kind == "uwb_tdoa" && std::isfinite(m.diff_m) &&
                      std::abs(m.diff_m) <= (b->position - a->position).norm() + 1.0 &&
                      plausible_utime(m.utime) && valid_device_id(m.tag_id) &&
                      (std::isnan(m.sigma_m) || (m.sigma_m > 0 && m.sigma_m <= 100));
  if (usable) {
    Track* t = track_for_checked(m.tag_id, m.utime, tdoa_.time_stats().reanchors_back,
                                 tdoa_reanchors_back_);
    if (t && t->initialised) {
      const double sigma = std::isnan(m.sigma_m) ? tdoa_.params().pairs.pair_sigma_m
                                                 : static_cast<double>(m.sigma_m);
      Measurement meas;
      meas.kind = Measurement::Kind::kTdoa;
      meas.t = m.utime;
      meas.source = kSrcTdoa;
      meas.group = std::make_shared<const TdoaArrivals>(
          pair_arrivals(a->position, b->position, m.diff_m, sigma * sigma));
      t->tight_tdoa = true;
      add(m.tag_id, *t, std::move(meas));
    }
  }
  tdoa_.on_pair(m);
}

void FuseEstimator::on_tdoa_epoch(const uwb_tdoa::TdoaEpoch& e) {
  Track* t = track_for_checked(*e.tag_id, e.utime, tdoa_.time_stats().reanchors_back,
                               tdoa_reanchors_back_);
  // A blink says where the tag is only relative to the anchors' hyperboloids: the track starts
  // from something else (ranges, a start pose, POSE_TDOA, or the hosted tracker's fix from the
  // blinks: on_hosted_fix, right after this).
  if (!t || !t->initialised) return;
  // The nearest anchors to the estimate, nearest first (the most likely direct paths).
  std::array<int, uwb_tdoa::kMaxEpochArrivals> order;
  for (int k = 0; k < e.count; ++k) order[k] = k;
  const Eigen::Vector3d p = t->state.filter.x.head<3>();
  std::sort(order.begin(), order.begin() + e.count, [&](int a, int b) {
    return (e.anchor[a] - p).squaredNorm() < (e.anchor[b] - p).squaredNorm();
  });
  Measurement m;
  m.kind = Measurement::Kind::kTdoa;
  m.t = e.utime;
  m.source = kSrcTdoa;
  auto arrivals = std::make_shared<TdoaArrivals>();
  TdoaArrivals& a = *arrivals;
  a.count = std::min(e.count, kMaxTdoaArrivals);
  for (int k = 0; k < a.count; ++k) {
    a.anchor[k] = e.anchor[order[k]];
    a.range_m[k] = e.range_m[order[k]];
    a.var_m2[k] = e.var_m2[order[k]];
  }
  m.group = std::shared_ptr<const TdoaArrivals>(std::move(arrivals));
  t->tight_tdoa = true;
  add(*e.tag_id, *t, std::move(m));
}

void FuseEstimator::apply_tdoa(Track& t, Snapshot& s, const Measurement& m, bool live) {
  FuseFilter& f = s.filter;
  const TdoaUpdate u = update_tdoa(f, *std::get<std::shared_ptr<const TdoaArrivals>>(m.group),
                                   params_.tdoa_gate_sigma * params_.tdoa_gate_sigma);
  count_absolute(s, m.t, u.accepted, live);
  if (live) {
    (u.accepted ? stats_.tdoa_epochs_used : stats_.tdoa_epochs_rejected)++;
    if (u.accepted) {
      stats_.tdoa_differences_used += u.used;
      t.tally.add_many(u.used, u.innovation_sq);
      t.sources |= kSrcTdoa;
    }
  }
}

}  // namespace ips::fusion
