// Barometric heights (ALTITUDE, 003_baro.md): a gated update of the height (models/height.hpp);
// heights relative to a lone barometer's start are not of the site's z.
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "fusion/fuse_inputs.hpp"
#include "fusion/models/height.hpp"

namespace ips::fusion {

void FuseEstimator::on_altitude(const altitude_t& m) {
  Track* t = track_for(m.tag_id, m.utime, [this, m] { on_altitude(m); });
  if (!t) return;
  if (!std::isfinite(m.height_m) || std::abs(m.height_m) > kMaxCoordinateM ||
      !(m.height_std_m > 0) || !std::isfinite(m.height_std_m)) {
    ++stats_.dropped_invalid;
    return;
  }
  // A single barometer's heights are relative to its first readings (ips-altitude's relative
  // mode, altitude_t.relative), not the site's z: not fused as absolute heights.
  if (m.relative) {
    ++stats_.dropped_relative_height;
    return;
  }
  Measurement h;
  h.kind = Measurement::Kind::kHeight;
  h.t = m.utime;
  h.value = m.height_m;
  h.sigma = std::max(m.height_std_m, 0.01);
  h.source = kSrcAltitude;
  add(m.tag_id, *t, std::move(h));
}

void FuseEstimator::apply_height(Track& t, Snapshot& s, const Measurement& m, bool live) {
  FuseFilter& f = s.filter;
  if (f.planar) return;
  const UpdateResult u = update_height(f, m.value, m.sigma,
                                       params_.height_gate_sigma * params_.height_gate_sigma);
  if (u.accepted) s.last_absolute = m.t;
  if (live) {
    consistency_.add_nis("HEIGHT", "ALTITUDE", utime_to_s(m.t), u.mahalanobis_sq, 1, !u.accepted,
                         "ips-altitude's height sigma");
    (u.accepted ? stats_.heights_used : stats_.heights_rejected)++;
    if (u.accepted) t.sources |= kSrcAltitude;
  }
}

}  // namespace ips::fusion
