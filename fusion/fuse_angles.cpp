// BLE angles of arrival (BLE_AOA), tightly coupled: ips-aoa's calibration and epoch grouping,
// each azimuth (and elevation in 3D) one gated update (estimators/aoa/models/aoa_bearing.hpp).
#include "fusion/fuse_estimator.hpp"

#include <cmath>
#include <utility>

#include "estimators/aoa/models/aoa_bearing.hpp"
#include "fusion/fuse_inputs.hpp"

namespace ips::fusion {

void FuseEstimator::on_aoa(const ble_aoa_t& m) {
  if (have_site_for_raw()) aoa_.on_event(m);  // its epochs come back through on_aoa_epoch
}

void FuseEstimator::on_aoa_epoch(const aoa::AoaEpochAngles& e) {
  Track* t = track_for_checked(*e.tag_id, e.utime, aoa_.time_stats().reanchors_back,
                               aoa_reanchors_back_);
  // Angles start no track here: the hosted tracker's fix from them does (on_hosted_fix), as
  // POSE_AOA can.
  if (!t || !t->initialised || e.picked->empty()) return;
  Measurement m;
  m.kind = Measurement::Kind::kAngles;
  m.t = e.utime;
  m.source = kSrcAngles;
  auto angles = std::make_shared<Angles>();
  Angles& a = *angles;
  for (size_t i = 0; i < e.picked->size() && a.count < kMaxAngles; ++i) {
    a.anchor[a.count] = static_cast<int>((*e.picked)[i].anchor);
    a.angle[a.count] = (*e.angles)[i];
    a.angle[a.count].frame = nullptr;
    ++a.count;
  }
  m.group = std::shared_ptr<const Angles>(std::move(angles));
  t->tight_aoa = true;
  add(*e.tag_id, *t, std::move(m));
}

void FuseEstimator::apply_angles(Track& t, Snapshot& s, const Measurement& m, bool live) {
  FuseFilter& f = s.filter;
  const Angles& a = *std::get<std::shared_ptr<const Angles>>(m.group);
  bool any = false;
  for (int i = 0; i < a.count; ++i) {
    const aoa::AnchorFrame& frame = frames_[static_cast<size_t>(a.anchor[i])];
    const aoa::BearingObservation& o = a.angle[i];
    const double distance = (f.x.head<3>() - frame.position).norm();
    for (int k = 0; k < (f.planar ? 1 : 2); ++k) {
      const aoa::AngleKind kind = k == 0 ? aoa::AngleKind::kAzimuth : aoa::AngleKind::kElevation;
      const double z = k == 0 ? o.azimuth_rad : o.elevation_rad;
      const double sigma = k == 0 ? o.azimuth_sigma_rad : o.elevation_sigma_rad;
      if (!std::isfinite(z)) continue;
      const aoa::AngleUpdate u =
          f.planar ? aoa::angle_update<2, kStateSize>(f.x, f.P, frame, f.x(2), kind, z, sigma,
                                                       params_.angle_gate_sigma)
                   : aoa::angle_update<3, kStateSize>(f.x, f.P, frame, 0.0, kind, z, sigma,
                                                       params_.angle_gate_sigma);
      if (!u.valid) continue;
      any = any || u.accepted;
      if (live) {
        consistency_.add_nis("ANGLE", site_->anchors[static_cast<size_t>(a.anchor[i])].id,
                             utime_to_s(m.t), u.normalised * u.normalised, 1, !u.accepted,
                             "the anchor's angle sigma");
        (u.accepted ? stats_.angles_used : stats_.angles_rejected)++;
        if (u.accepted) {
          t.tally.add(u.innovation_rad * distance);
          t.sources |= kSrcAngles;
        }
      }
    }
  }
  // Angles are weak next to ranges: they do not count as gated ranges do (a tag the ranges
  // have lost is not found again by its bearings).
  if (any) {
    s.last_absolute = s.last_horizontal = m.t;
    ++s.accepted_in_row;
  }
}

}  // namespace ips::fusion
