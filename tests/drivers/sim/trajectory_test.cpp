// Walker trajectories: legs at their speeds, stops, height changes, delayed starts, distance.
#include "drivers/sim/trajectory.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

#include "drivers/sim/scenario.hpp"

namespace ips::sim {
namespace {

TEST(WaypointTrajectory, ClosedLoopWalksAtConstantSpeed) {
  WaypointTrajectory t({{0, 0}, {4, 0}, {4, 3}}, 1.0, 1.2, true);
  EXPECT_DOUBLE_EQ(t.length_m(), 12.0);
  auto s = t.at(2.0);
  EXPECT_NEAR(s.position.x(), 2.0, 1e-12);
  EXPECT_NEAR(s.velocity.x(), 1.0, 1e-12);
  s = t.at(5.5);  // 1.5 m up the second leg
  EXPECT_NEAR(s.position.y(), 1.5, 1e-12);
  s = t.at(12.0 + 2.0);  // second lap
  EXPECT_NEAR(s.position.x(), 2.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.position.z(), 1.2);
}

TEST(WaypointTrajectory, StopsSpeedsAndHeightChanges) {
  // 0 -> (4,0,1) at 1 m/s (4 s), stand 10 s, -> (4,0,2) at 0.5 m/s (2 s: stairs), once.
  WaypointTrajectory t({{Eigen::Vector3d(0, 0, 1)},
                        {Eigen::Vector3d(4, 0, 1), 10.0},
                        {Eigen::Vector3d(4, 0, 2), 0.0, 0.5}},
                       1.0, false);
  EXPECT_DOUBLE_EQ(t.lap_s(), 4 + 10 + 2);
  EXPECT_DOUBLE_EQ(t.length_m(), 5.0);
  auto s = t.at(2.0);
  EXPECT_NEAR(s.position.x(), 2.0, 1e-12);
  EXPECT_TRUE(s.moving);
  EXPECT_NEAR(s.distance_m, 2.0, 1e-12);
  s = t.at(9.0);  // standing
  EXPECT_FALSE(s.moving);
  EXPECT_EQ(s.velocity, Eigen::Vector3d::Zero());
  EXPECT_NEAR(s.distance_m, 4.0, 1e-12);
  EXPECT_NEAR(s.heading_rad, 0.0, 1e-12);
  s = t.at(15.0);  // half-way up
  EXPECT_NEAR(s.position.z(), 1.5, 1e-12);
  EXPECT_NEAR(s.velocity.z(), 0.5, 1e-12);
  EXPECT_NEAR(s.heading_rad, 0.0, 1e-12);  // a vertical leg keeps the last horizontal heading
  s = t.at(100.0);  // after the end: standing at the last point
  EXPECT_EQ(s.position, Eigen::Vector3d(4, 0, 2));
  EXPECT_FALSE(s.moving);
  EXPECT_NEAR(s.distance_m, 5.0, 1e-12);
}

TEST(WaypointTrajectory, DelayedStartAndLapsAccumulateDistance) {
  WaypointTrajectory t({{0, 0}, {4, 0}, {4, 3}}, 1.0, 1.2, true);  // 12 m loop
  WaypointTrajectory d = t.delayed(5.0);
  EXPECT_FALSE(d.at(3.0).moving);
  EXPECT_EQ(d.at(3.0).position, Eigen::Vector3d(0, 0, 1.2));
  EXPECT_NEAR(d.at(5.0 + 26.0).distance_m, 26.0, 1e-9);  // two laps and 2 m
  EXPECT_NEAR(d.at(5.0 + 26.0).position.x(), 2.0, 1e-9);
}

TEST(WaypointTrajectory, StaticWalkerStandsAtItsPoint) {
  WaypointTrajectory t({{Eigen::Vector3d(1, 2, 0.5)}, {Eigen::Vector3d(1, 2, 0.5)}}, 1.0, false);
  EXPECT_EQ(t.at(30.0).position, Eigen::Vector3d(1, 2, 0.5));
  EXPECT_FALSE(t.at(30.0).moving);
  EXPECT_THROW(WaypointTrajectory({{Eigen::Vector3d(1, 2, 0.5)}, {Eigen::Vector3d(1, 2, 0.5)}}, 1.0, true),
               std::invalid_argument);
}

TEST(ScenarioWaypoints, MapFormWithStopsSpeedsAndHeight) {
  const std::string text =
      "site:\n  anchors:\n    - {id: A1, position: [0, 0, 2]}\n  tags:\n    - {id: T1, height_m: 1.0}\n"
      "trajectories:\n  - tag: T1\n    loop: false\n    start_s: 2\n    waypoints:\n"
      "      - [0, 0]\n      - {at: [3, 4, 1.5], stop_s: 60, speed_mps: 0.5}\n";
  Scenario sc = parse_scenario_text(text, "my.yaml");
  const auto& path = sc.trajectories[0].path;
  EXPECT_DOUBLE_EQ(path.lap_s(), 5.0 / 0.5 * std::hypot(1.0, 0.1) + 60.0);
  EXPECT_EQ(path.at(0).position, Eigen::Vector3d(0, 0, 1.0));
  EXPECT_EQ(path.at(200).position, Eigen::Vector3d(3, 4, 1.5));
}

TEST(ScenarioWaypoints, BadWaypointNamesTheField) {
  const std::string text =
      "site:\n  anchors:\n    - {id: A1, position: [0, 0, 2]}\n  tags:\n    - {id: T1}\n"
      "trajectories:\n  - tag: T1\n    waypoints:\n      - [0, 0]\n      - {at: [1, 1], stop_s: -1}\n";
  try {
    parse_scenario_text(text, "my.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "my.yaml:10: trajectories[0].waypoints[1].stop_s: must be in [0, 1e7]");
  }
}

}  // namespace
}  // namespace ips::sim
