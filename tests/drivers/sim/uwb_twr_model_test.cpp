// The two-way-ranging model's options beyond the lab's: NLOS episodes and per-anchor rates.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/uwb_range_t.hpp>
#include <map>

#include "drivers/sim/simulator.hpp"
#include "tests/drivers/sim/sim_test_support.hpp"

namespace ips::sim {
namespace {

std::string scenario(const std::string& twr) {
  return "site:\n  anchors:\n    - {id: A1, position: [0, 0, 2]}\n    - {id: A2, position: [5, 0, 2]}\n"
         "  tags:\n    - {id: T1, height_m: 1}\n"
         "trajectories:\n  - {tag: T1, loop: false, start_s: 1e6, waypoints: [[2, 2], [3, 2]]}\n"
         "duration_s: 2000\nsensors:\n  truth: {enabled: false}\n  uwb_twr: " + twr + "\n";
}

// Range errors of the static tag at (2, 2, 1) to A1, in order.
std::vector<double> errors_to_a1(const std::string& twr, uint64_t seed) {
  std::vector<double> e;
  const double d = std::sqrt(2.0 * 2.0 + 2.0 * 2.0 + 1.0);
  for (const auto& m : simulated_messages<uwb_range_t>(parse_scenario_text(scenario(twr), "t.yaml"),
                                                       seed, "UWB_RANGE"))
    if (m.anchor_id == "A1") e.push_back(m.range_m - d);
  return e;
}

TEST(UwbTwrModel, NlosEpisodesKeepTheShareAndLastAsConfigured) {
  // 10 Hz for 2000 s; 20 % NLOS in episodes of 2 s on average, +1 m each (min = max).
  auto e = errors_to_a1("{noise_sigma_m: 0.01, nlos_probability: 0.2, nlos_episode_s: 2, "
                        "nlos_bias_min_m: 1, nlos_bias_max_m: 1}",
                        1);
  ASSERT_EQ(e.size(), 20000u);
  int nlos = 0, episodes = 0;
  bool prev = false;
  for (double x : e) {
    const bool in = x > 0.5;
    nlos += in;
    episodes += in && !prev;
    prev = in;
  }
  const double share = nlos / 20000.0;
  const double mean_len_s = 0.1 * nlos / episodes;
  EXPECT_NEAR(share, 0.2, 0.04);      // ~200 episodes: the share's spread is ~0.015
  EXPECT_NEAR(mean_len_s, 2.0, 0.4);  // geometric lengths, ~200 of them: spread ~0.15 s
}

TEST(UwbTwrModel, IndependentOutliersWhenNoEpisodeLength) {
  auto e = errors_to_a1("{noise_sigma_m: 0.01, nlos_probability: 0.2, nlos_bias_min_m: 1, "
                        "nlos_bias_max_m: 1}",
                        1);
  int nlos = 0, runs = 0;
  bool prev = false;
  for (double x : e) {
    const bool in = x > 0.5;
    nlos += in;
    runs += in && !prev;
    prev = in;
  }
  EXPECT_NEAR(nlos / 20000.0, 0.2, 0.01);
  // Independent: a run continues with probability 0.2, so mean run length is 1.25 samples.
  EXPECT_NEAR(static_cast<double>(nlos) / runs, 1.25, 0.05);
}

TEST(UwbTwrModel, PerAnchorRates) {
  std::map<std::string, int> count;
  for (const auto& m : simulated_messages<uwb_range_t>(
           parse_scenario_text(scenario("{rate_hz: 10, anchor_rates_hz: {A2: 2}}"), "t.yaml"), 1,
           "UWB_RANGE"))
    count[m.anchor_id]++;
  EXPECT_NEAR(count["A1"], 20000, 1);
  EXPECT_NEAR(count["A2"], 4000, 1);
  try {
    parse_scenario_text(scenario("{anchor_rates_hz: {A9: 2}}"), "t.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "t.yaml:12: sensors.uwb_twr.anchor_rates_hz.A9: no uwb anchor 'A9' in the site");
  }
}

}  // namespace
}  // namespace ips::sim
