#include "drivers/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::sim {

WaypointTrajectory::WaypointTrajectory(std::vector<Eigen::Vector2d> waypoints, double speed_mps,
                                       double height_m, bool loop)
    : points_(std::move(waypoints)), speed_(speed_mps), height_(height_m), loop_(loop) {
  if (points_.size() < 2) throw std::invalid_argument("a trajectory needs at least 2 waypoints");
  if (!(speed_ > 0)) throw std::invalid_argument("speed_mps must be positive");
  if (loop_) points_.push_back(points_.front());
  cumulative_.push_back(0.0);
  for (size_t i = 1; i < points_.size(); ++i)
    cumulative_.push_back(cumulative_.back() + (points_[i] - points_[i - 1]).norm());
  if (!(cumulative_.back() > 0)) throw std::invalid_argument("waypoints are all the same point");
}

TrajectoryState WaypointTrajectory::at(double t_s) const {
  const double total = cumulative_.back();
  double s = std::max(0.0, t_s) * speed_;
  bool moving = true;
  if (loop_) {
    s = std::fmod(s, total);
  } else if (s >= total) {
    s = total;
    moving = false;
  }
  auto it = std::upper_bound(cumulative_.begin(), cumulative_.end(), s);
  size_t i = static_cast<size_t>(std::clamp<std::ptrdiff_t>(it - cumulative_.begin(), 1,
                                                            static_cast<std::ptrdiff_t>(points_.size()) - 1));
  // Skip zero-length segments.
  while (i + 1 < points_.size() && cumulative_[i] - cumulative_[i - 1] <= 0) ++i;
  const Eigen::Vector2d a = points_[i - 1], b = points_[i];
  const double seg = cumulative_[i] - cumulative_[i - 1];
  const double f = seg > 0 ? std::clamp((s - cumulative_[i - 1]) / seg, 0.0, 1.0) : 0.0;
  const Eigen::Vector2d dir = seg > 0 ? Eigen::Vector2d((b - a) / seg) : Eigen::Vector2d::UnitX();
  TrajectoryState st;
  st.position = Eigen::Vector3d(a.x() + f * (b.x() - a.x()), a.y() + f * (b.y() - a.y()), height_);
  const double v = moving ? speed_ : 0.0;
  st.velocity = Eigen::Vector3d(dir.x() * v, dir.y() * v, 0.0);
  st.heading_rad = std::atan2(dir.y(), dir.x());
  return st;
}

}  // namespace ips::sim
