#pragma once
// What FuseEstimator's input files share (not for its users): the plausibility limits of the
// inputs, and track_for() (a template, so defined where it is used).
#include <cmath>
#include <optional>
#include <utility>

#include "fusion/fuse_estimator.hpp"

namespace ips::fusion {

constexpr double kMaxCoordinateM = 1e5;

inline bool finite_position(const pose_t& m) {
  for (double v : m.position)
    if (!std::isfinite(v) || std::abs(v) > kMaxCoordinateM) return false;
  return true;
}

// A pose's position covariance, or nullopt when it has none usable (NaN, not positive).
inline std::optional<Eigen::Matrix3d> pose_covariance(const pose_t& m, bool horizontal_only) {
  Eigen::Matrix3d c;
  for (int i = 0; i < 9; ++i) c(i / 3, i % 3) = m.position_cov[i];
  const int n = horizontal_only ? 2 : 3;
  if (!c.topLeftCorner(n, n).allFinite()) return std::nullopt;
  for (int i = 0; i < n; ++i)
    if (!(c(i, i) > 0)) return std::nullopt;
  return c;
}

template <class Again>
FuseEstimator::Track* FuseEstimator::track_for(const std::string& tag_id, utime_t t,
                                               Again&& again) {
  if (!site_) {
    ++stats_.messages_in;
    ++stats_.dropped_no_site;
    return nullptr;
  }
  if (tag_id.empty() || !plausible_utime(t)) {
    ++stats_.messages_in;
    ++stats_.dropped_invalid;
    return nullptr;
  }
  // A stamp far from the tag's timeline is held until confirmed (never the tag's newest); a
  // confirmed jump back in time starts the track afresh.
  if (!guard_.admit(tag_id, t, std::forward<Again>(again), [&] { restart_track(tag_id); }))
    return nullptr;
  return find_or_add_track(tag_id, t);
}

}  // namespace ips::fusion
