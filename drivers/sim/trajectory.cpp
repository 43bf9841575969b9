#include "drivers/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ips::sim {

WaypointTrajectory::WaypointTrajectory(std::vector<Waypoint> waypoints, double speed_mps,
                                       bool loop, double start_s)
    : waypoints_(std::move(waypoints)), speed_(speed_mps), loop_(loop), start_s_(start_s) {
  if (waypoints_.size() < 2) throw std::invalid_argument("a trajectory needs at least 2 waypoints");
  if (!(speed_ > 0)) throw std::invalid_argument("speed_mps must be positive");
  if (!(start_s_ >= 0)) throw std::invalid_argument("start_s must not be negative");
  double t = 0, s = 0;
  double heading = 0;
  bool heading_set = false;
  const size_t n = waypoints_.size();
  const size_t legs = loop_ ? n : n - 1;
  std::vector<Phase> legs_phases;
  for (size_t i = 0; i < legs; ++i) {
    const Waypoint& a = waypoints_[i];
    const Waypoint& b = waypoints_[(i + 1) % n];
    const double v = std::isnan(b.speed_mps) ? speed_ : b.speed_mps;
    if (!(v > 0)) throw std::invalid_argument("speed_mps must be positive");
    if (!(b.stop_s >= 0)) throw std::invalid_argument("stop_s must not be negative");
    const double len = (b.at - a.at).norm();
    const Eigen::Vector3d d = b.at - a.at;
    if (std::hypot(d.x(), d.y()) > 1e-9) {
      heading = std::atan2(d.y(), d.x());
      if (!heading_set) {
        // Phases before the first horizontal leg face along it.
        for (auto& p : phases_) p.heading = heading;
        heading_set = true;
      }
    }
    if (len > 0) {
      phases_.push_back({t, t + len / v, a.at, b.at, s, heading, true});
      t += len / v;
      s += len;
    }
    if (b.stop_s > 0) {
      phases_.push_back({t, t + b.stop_s, b.at, b.at, s, heading, false});
      t += b.stop_s;
    }
  }
  length_ = s;
  lap_s_ = t;
  if (loop_ && !(length_ > 0)) throw std::invalid_argument("a closed loop must have a length");
  if (phases_.empty()) {
    // A walker that never moves: stand at the first waypoint.
    phases_.push_back({0, 0, waypoints_[0].at, waypoints_[0].at, 0, 0, false});
  }
}

WaypointTrajectory::WaypointTrajectory(const std::vector<Eigen::Vector2d>& waypoints,
                                       double speed_mps, double height_m, bool loop)
    : WaypointTrajectory(
          [&] {
            std::vector<Waypoint> w;
            for (const auto& p : waypoints) w.push_back({Eigen::Vector3d(p.x(), p.y(), height_m)});
            return w;
          }(),
          speed_mps, loop) {}

WaypointTrajectory WaypointTrajectory::delayed(double delay_s) const {
  return WaypointTrajectory(waypoints_, speed_, loop_, start_s_ + delay_s);
}

TrajectoryState WaypointTrajectory::at(double t_s) const {
  TrajectoryState st;
  double t = t_s - start_s_;
  double laps_distance = 0;
  if (t < 0) t = 0;
  if (loop_ && lap_s_ > 0) {
    const double k = std::floor(t / lap_s_);
    t -= k * lap_s_;
    laps_distance = k * length_;
  }
  // The phase containing t (the last one after the end of a single pass).
  auto it = std::upper_bound(phases_.begin(), phases_.end(), t,
                             [](double v, const Phase& p) { return v < p.t1; });
  const bool after_end = it == phases_.end();
  const Phase& p = after_end ? phases_.back() : *it;
  const double span = p.t1 - p.t0;
  const double f = after_end ? 1.0 : (span > 0 ? std::clamp((t - p.t0) / span, 0.0, 1.0) : 0.0);
  st.position = p.from + f * (p.to - p.from);
  st.heading_rad = p.heading;
  st.moving = p.moving && !after_end && t_s >= start_s_;
  st.velocity = st.moving ? Eigen::Vector3d((p.to - p.from) / span) : Eigen::Vector3d::Zero();
  st.distance_m = laps_distance + p.s0 + (p.moving ? f * (p.to - p.from).norm() : 0.0);
  return st;
}

}  // namespace ips::sim
