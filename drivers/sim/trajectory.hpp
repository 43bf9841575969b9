#pragma once
// A walker's path: legs between waypoints walked at a constant speed each, stops at waypoints,
// a delay before the start, and either a closed loop or one pass (then standing at the end).
#include <Eigen/Core>
#include <limits>
#include <vector>

namespace ips::sim {

struct TrajectoryState {
  Eigen::Vector3d position;
  Eigen::Vector3d velocity;
  double heading_rad;  // direction of the current (or last) leg from +x, counter-clockwise
  double distance_m;   // path length walked since the start (all laps)
  bool moving;
};

struct Waypoint {
  Eigen::Vector3d at;
  double stop_s = 0;  // stand here this long after arriving
  double speed_mps = std::numeric_limits<double>::quiet_NaN();  // of the leg arriving here
};

class WaypointTrajectory {
 public:
  // Throws std::invalid_argument: fewer than 2 waypoints, a non-positive speed or stop, or a
  // closed loop of zero length.
  WaypointTrajectory(std::vector<Waypoint> waypoints, double speed_mps, bool loop,
                     double start_s = 0);
  // Planar waypoints at one height.
  WaypointTrajectory(const std::vector<Eigen::Vector2d>& waypoints, double speed_mps,
                     double height_m, bool loop);

  TrajectoryState at(double t_s) const;
  double length_m() const { return length_; }  // of one pass or lap
  double lap_s() const { return lap_s_; }      // duration of one pass or lap, stops included
  double start_s() const { return start_s_; }
  bool loop() const { return loop_; }
  // The same path started `delay_s` later (for replicated walkers).
  WaypointTrajectory delayed(double delay_s) const;

 private:
  struct Phase {
    double t0, t1;                 // within a lap
    Eigen::Vector3d from, to;
    double s0;                     // distance walked at t0 within the lap
    double heading;
    bool moving;
  };
  std::vector<Waypoint> waypoints_;
  double speed_;
  bool loop_;
  double start_s_;
  std::vector<Phase> phases_;
  double length_ = 0;
  double lap_s_ = 0;
};

}  // namespace ips::sim
