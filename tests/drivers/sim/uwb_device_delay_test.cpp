// The two-way-ranging model's per-device antenna delays (sensors.uwb_twr.device_delay_min_m /
// max_m): every range, tag-anchor and anchor-anchor, reads long by the delays of both its ends
// (plus its pair offset when set), each device's delay from its own stream.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <set>

#include "drivers/sim/sensor_model.hpp"
#include "drivers/sim/simulator.hpp"
#include "tests/drivers/sim/sim_test_support.hpp"

namespace ips::sim {
namespace {

// Four anchors, a static tag at (2, 2, 1), noiseless ranges; anchors range in pairs at 1 Hz.
std::string delay_scenario(const std::string& extra) {
  return "site:\n  anchors:\n"
         "    - {id: A1, position: [0, 0, 2.4]}\n"
         "    - {id: A2, position: [10, 0, 2.0]}\n"
         "    - {id: A3, position: [10, 8, 3.0]}\n"
         "    - {id: A4, position: [0, 8, 1.5]}\n"
         "  tags:\n    - {id: T1, height_m: 1}\n"
         "trajectories:\n  - {tag: T1, loop: false, start_s: 1e6, waypoints: [[2, 2], [3, 2]]}\n"
         "duration_s: 20\nsensors:\n  truth: {enabled: false}\n"
         "  uwb_twr: {rate_hz: 2, noise_sigma_m: 0, anchor_pairs_rate_hz: 1" +
         extra + "}\n";
}

const std::map<std::string, Eigen::Vector3d> kPos = {{"T1", {2, 2, 1}},
                                                     {"A1", {0, 0, 2.4}},
                                                     {"A2", {10, 0, 2.0}},
                                                     {"A3", {10, 8, 3.0}},
                                                     {"A4", {0, 8, 1.5}}};

TEST(UwbDeviceDelay, EveryRangeReadsLongByBothEndsDelays) {
  constexpr uint64_t kSeed = 7;
  const auto msgs = simulated_messages<uwb_range_t>(
      parse_scenario_text(delay_scenario(", device_delay_min_m: 0.05, device_delay_max_m: 0.15"),
                          "t.yaml"),
      kSeed, "UWB_RANGE");
  std::map<std::string, double> delay;
  std::set<double> distinct;
  for (const auto& [id, p] : kPos) {
    delay[id] = uwb_device_delay_m(kSeed, id, 0.05, 0.15);
    EXPECT_GE(delay[id], 0.05) << id;
    EXPECT_LE(delay[id], 0.15) << id;
    distinct.insert(delay[id]);
  }
  EXPECT_EQ(distinct.size(), kPos.size()) << "each device its own delay";
  std::set<std::string> pairs;
  for (const auto& m : msgs) {
    const double excess = m.range_m - (kPos.at(m.tag_id) - kPos.at(m.anchor_id)).norm();
    EXPECT_NEAR(excess, delay[m.tag_id] + delay[m.anchor_id], 1e-9)
        << m.tag_id << "-" << m.anchor_id;
    pairs.insert(m.tag_id + "-" + m.anchor_id);
  }
  EXPECT_EQ(pairs.size(), 4u + 6u);  // the tag with each anchor, the six anchor pairs
}

TEST(UwbDeviceDelay, AddsToThePairOffsetAndIsOffByDefault) {
  constexpr uint64_t kSeed = 3;
  const auto both = simulated_messages<uwb_range_t>(
      parse_scenario_text(delay_scenario(", device_delay_min_m: 0.05, device_delay_max_m: 0.15, "
                                         "pair_offset_min_m: 0.1, pair_offset_max_m: 0.3"),
                          "t.yaml"),
      kSeed, "UWB_RANGE");
  for (const auto& m : both) {
    const double excess = m.range_m - (kPos.at(m.tag_id) - kPos.at(m.anchor_id)).norm();
    EXPECT_NEAR(excess,
                uwb_pair_offset_m(kSeed, m.tag_id, m.anchor_id, 0.1, 0.3) +
                    uwb_device_delay_m(kSeed, m.tag_id, 0.05, 0.15) +
                    uwb_device_delay_m(kSeed, m.anchor_id, 0.05, 0.15),
                1e-9);
  }
  for (const auto& m : simulated_messages<uwb_range_t>(
           parse_scenario_text(delay_scenario(""), "t.yaml"), kSeed, "UWB_RANGE"))
    EXPECT_NEAR(m.range_m, (kPos.at(m.tag_id) - kPos.at(m.anchor_id)).norm(), 1e-9);
  EXPECT_EQ(uwb_device_delay_m(kSeed, "A1", 0, 0), 0.0);
  EXPECT_THROW(parse_scenario_text(
                   delay_scenario(", device_delay_min_m: 0.2, device_delay_max_m: 0.1"), "t.yaml"),
               ConfigError);
}

}  // namespace
}  // namespace ips::sim
