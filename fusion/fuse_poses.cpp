// Other estimators' poses (POSE_TDOA, POSE_AOA), loosely coupled (models/position.hpp), their
// covariance scaled for their correlated errors; superseded once a tag's blinks or angles are
// fused.
#include "fusion/fuse_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "fusion/fuse_inputs.hpp"
#include "fusion/models/position.hpp"

namespace ips::fusion {

void FuseEstimator::on_pose(const pose_t& m, const std::string& kind) {
  Track* t = track_for(m.tag_id, m.utime, [this, m, kind] { on_pose(m, kind); });
  if (!t) return;
  const bool horizontal_only = (m.status & pose_t::STATUS_2D) != 0;
  const auto cov = pose_covariance(m, horizontal_only);
  if (!finite_position(m) || !cov) {
    ++stats_.dropped_invalid;
    return;
  }
  if ((kind == "tdoa" && t->tight_tdoa) || (kind == "aoa" && t->tight_aoa)) {
    ++stats_.poses_superseded;
    return;
  }
  Measurement p;
  p.kind = Measurement::Kind::kPosition;
  p.t = m.utime;
  p.vec = Eigen::Vector3d(m.position[0], m.position[1], m.position[2]);
  p.cov = params_.pose_cov_scale * *cov;
  p.horizontal_only = horizontal_only;
  p.source = kSrcPose;
  p.pose_kind = kind;
  if (!t->initialised) {
    start(m.tag_id, *t, m.utime, p.vec, std::sqrt(std::max(cov->trace() / 3.0, 1e-6)));
    return;
  }
  add(m.tag_id, *t, std::move(p));
}

void FuseEstimator::apply_position(Track& t, Snapshot& s, const Measurement& m, bool live) {
  FuseFilter& f = s.filter;
  const UpdateResult u = update_position(f, m.vec, m.cov, m.horizontal_only,
                                         params_.pose_gate_sigma * params_.pose_gate_sigma);
  if (u.accepted) s.last_absolute = s.last_horizontal = m.t;
  if (live) {
    consistency_.add_nis("POSE", m.pose_kind, utime_to_s(m.t), u.mahalanobis_sq,
                         m.horizontal_only || f.planar ? 2 : 3, !u.accepted,
                         setting_text("pose_cov_scale", params_.pose_cov_scale));
    (u.accepted ? stats_.poses_used : stats_.poses_rejected)++;
    if (u.accepted) {
      t.sources |= kSrcPose;
      if (std::find(t.pose_kinds.begin(), t.pose_kinds.end(), m.pose_kind) ==
          t.pose_kinds.end())
        t.pose_kinds.push_back(m.pose_kind);
    }
  }
}

}  // namespace ips::fusion
