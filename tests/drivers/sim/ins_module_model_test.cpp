// The foot-INS module model (INS_MODULE): the thesis's step generator (001_hybrid_uwb_ins.md
// eq. 4.1) checked on a straight walk where the rotated, stretched path has a closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/pose_t.hpp>
#include <vector>

#include "drivers/sim/simulator.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;

std::string straight_walk(const std::string& ins_params) {
  return "site:\n  anchors:\n    - {id: A1, position: [0, 0, 2]}\n  tags:\n    - {id: T1, height_m: 0.1}\n"
         "trajectories:\n  - {tag: T1, loop: false, speed_mps: 1.0, waypoints: [[0, 0], [20, 0]]}\n"
         "duration_s: 25\nsensors:\n  ins_module: " + ins_params + "\n";
}

std::vector<pose_t> run(const std::string& text, uint64_t seed) {
  Simulator sim(parse_scenario_text(text, "t.yaml"), seed, kStart);
  std::vector<pose_t> out;
  SimEvent e;
  while (sim.next(e))
    if (e.kind == "INS_MODULE") {
      pose_t p;
      p.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
      out.push_back(p);
    }
  return out;
}

TEST(InsModuleModel, InitialHeadingErrorRotatesThePathAboutTheStart) {
  auto out = run(straight_walk("{initial_heading_error_rad: 0.1, heading_drift_rad_per_step: 0, "
                               "heading_sigma_rad_per_step: 0, length_sigma_m_per_step: 0}"),
                 1);
  ASSERT_EQ(out.size(), 51u);  // 2 Hz for 25 s, both ends included
  const pose_t& end = out.back();
  EXPECT_NEAR(end.position[0], 20 * std::cos(0.1), 1e-6);
  EXPECT_NEAR(end.position[1], 20 * std::sin(0.1), 1e-6);
  EXPECT_EQ(end.tag_id, "T1");
  EXPECT_EQ(end.num_used, 28);  // steps of 0.7 m in 20 m
}

TEST(InsModuleModel, HeadingDriftAccumulatesPerStep) {
  // gamma 0.01 rad per 1 m step over 20 steps: the last step's direction is 0.2 rad off.
  auto out = run(straight_walk("{initial_heading_error_rad: 0, heading_drift_rad_per_step: 0.01, "
                               "heading_sigma_rad_per_step: 0, length_sigma_m_per_step: 0, "
                               "step_length_m: 1.0}"),
                 1);
  // Direction of travel between the last two samples while walking (t = 19 .. 19.5 s).
  const pose_t& a = out[38];
  const pose_t& b = out[39];
  const double dir = std::atan2(b.position[1] - a.position[1], b.position[0] - a.position[0]);
  EXPECT_NEAR(dir, 0.19, 0.006);  // 19 steps done at 19 s
  // Closed form of the end point: sum over 1 m steps of (cos, sin)(0.01 k), k = 0..19.
  double x = 0, y = 0;
  for (int k = 0; k < 20; ++k) {
    x += std::cos(0.01 * k);
    y += std::sin(0.01 * k);
  }
  EXPECT_NEAR(out.back().position[0], x, 0.02);
  EXPECT_NEAR(out.back().position[1], y, 0.02);
}

TEST(InsModuleModel, HeadingRandomWalkHasTheConfiguredSpread) {
  // Final heading error over many seeds: mean n*gamma, sigma sqrt(n)*sigma_step (n = 20 steps).
  const std::string text = straight_walk(
      "{initial_heading_error_rad: 0, heading_drift_rad_per_step: 0.007, "
      "heading_sigma_rad_per_step: 0.003, length_sigma_m_per_step: 0, step_length_m: 1.0}");
  std::vector<double> dirs;
  for (uint64_t seed = 1; seed <= 200; ++seed) {
    auto out = run(text, seed);
    dirs.push_back(std::atan2(out[39].position[1] - out[38].position[1],
                              out[39].position[0] - out[38].position[0]));
  }
  double mean = 0, var = 0;
  const double n = static_cast<double>(dirs.size());
  for (double d : dirs) mean += d / n;
  for (double d : dirs) var += (d - mean) * (d - mean) / (n - 1);
  EXPECT_NEAR(mean, 19 * 0.007, 0.002);                 // 19 steps before t = 19 s
  EXPECT_NEAR(std::sqrt(var), std::sqrt(19.0) * 0.003, 0.003);
}

TEST(InsModuleModel, DeterministicAndBadParametersNamed) {
  const std::string text = straight_walk("{}");
  auto a = run(text, 5), b = run(text, 5);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_EQ(a[i].position[1], b[i].position[1]);
  try {
    parse_scenario_text(straight_walk("{step_length_m: 0}"), "t.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "t.yaml:10: sensors.ins_module.step_length_m: must be in [0.1, 3]");
  }
}

TEST(InsModuleModel, CorridorScenariosLoadWithTheirAnchorCounts) {
  for (const auto& [name, enabled] : std::vector<std::pair<std::string, int>>{
           {"corridor-L", 4}, {"corridor-L-3", 3}, {"corridor-8-2", 2}, {"corridor-8-1", 1}}) {
    Scenario sc = load_scenario(name);
    int n = 0;
    for (const auto& a : sc.site.anchors) n += a.enabled;
    EXPECT_EQ(n, enabled) << name;
    EXPECT_NE(sc.sensor("ins_module"), nullptr) << name;
  }
}

}  // namespace
}  // namespace ips::sim
