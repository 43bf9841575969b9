#pragma once
// A walker's path: waypoints walked at a constant speed, as a closed loop or once (then
// standing at the last point).
#include <Eigen/Core>
#include <vector>

namespace ips::sim {

struct TrajectoryState {
  Eigen::Vector3d position;
  Eigen::Vector3d velocity;
  double heading_rad;  // direction of travel from +x
};

class WaypointTrajectory {
 public:
  // Throws std::invalid_argument when fewer than 2 waypoints or a non-positive speed.
  WaypointTrajectory(std::vector<Eigen::Vector2d> waypoints, double speed_mps, double height_m,
                     bool loop);
  TrajectoryState at(double t_s) const;
  double length_m() const { return cumulative_.back(); }

 private:
  std::vector<Eigen::Vector2d> points_;  // closed loops repeat the first point at the end
  std::vector<double> cumulative_;       // arc length at each point
  double speed_;
  double height_;
  bool loop_;
};

}  // namespace ips::sim
