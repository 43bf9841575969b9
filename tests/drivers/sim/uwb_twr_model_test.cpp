// The two-way-ranging model's options beyond the lab's: NLOS episodes, per-anchor rates and
// anchor-to-anchor ranging.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <set>

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

// Anchors at different heights, one disabled and one of another kind (neither ranges), and a tag.
std::string pair_scenario(const std::string& twr) {
  return "site:\n  anchors:\n"
         "    - {id: A1, position: [0, 0, 2.4]}\n"
         "    - {id: A2, position: [10, 0, 2.0]}\n"
         "    - {id: X9, position: [5, 5, 2.0], enabled: false}\n"
         "    - {id: B1, kind: ble_aoa, position: [5, 0, 2.2]}\n"
         "    - {id: A3, position: [10, 8, 3.0]}\n"
         "    - {id: A4, position: [0, 8, 1.5]}\n"
         "  tags:\n    - {id: T1, height_m: 1}\n"
         "trajectories:\n  - {tag: T1, loop: false, start_s: 1e6, waypoints: [[2, 2], [3, 2]]}\n"
         "duration_s: 2000\nsensors:\n  truth: {enabled: false}\n  uwb_twr: " +
         twr + "\n";
}

bool is_anchor_pair(const uwb_range_t& m) { return m.tag_id != "T1"; }

TEST(UwbTwrModel, AnchorPairsRangeEveryEnabledPairAtTheirRateInSiteOrder) {
  std::map<std::pair<std::string, std::string>, std::vector<uwb_range_t>> pairs;
  int tag_ranges = 0;
  for (const auto& m : simulated_messages<uwb_range_t>(
           parse_scenario_text(pair_scenario("{rate_hz: 2, anchor_pairs_rate_hz: 0.5}"), "t.yaml"),
           1, "UWB_RANGE")) {
    if (is_anchor_pair(m))
      pairs[{m.tag_id, m.anchor_id}].push_back(m);
    else
      ++tag_ranges;
  }
  // 4 enabled uwb anchors: 6 unordered pairs, initiator = the one first in the site.
  const std::set<std::pair<std::string, std::string>> want = {
      {"A1", "A2"}, {"A1", "A3"}, {"A1", "A4"}, {"A2", "A3"}, {"A2", "A4"}, {"A3", "A4"}};
  std::set<std::pair<std::string, std::string>> got;
  for (const auto& [k, v] : pairs) got.insert(k);
  EXPECT_EQ(got, want);
  for (const auto& [k, v] : pairs) {
    EXPECT_NEAR(static_cast<double>(v.size()), 1000, 1)
        << k.first << "-" << k.second;  // 0.5 Hz, 2000 s
    EXPECT_EQ(v.front().seq, 0);
    EXPECT_EQ(v.back().seq, static_cast<int32_t>(v.size()) - 1);
    EXPECT_NEAR(utime_to_s(v[1].utime - v[0].utime), 2.0, 1e-6);
  }
  EXPECT_NEAR(tag_ranges, 4 * 2 * 2000, 4);  // the tag's ranges are as before
}

TEST(UwbTwrModel, AnchorPairErrorsFollowTheTagErrorModel) {
  // sigma 0.10 m, bias +0.05 m, 20 % NLOS of exactly +1 m, 10 % loss; 10 Hz for 2000 s per pair.
  const auto msgs = simulated_messages<uwb_range_t>(
      parse_scenario_text(
          pair_scenario("{noise_sigma_m: 0.10, bias_m: 0.05, nlos_probability: 0.2, "
                        "nlos_bias_min_m: 1, nlos_bias_max_m: 1, "
                        "loss_probability: 0.1, anchor_pairs_rate_hz: 10}"),
          "t.yaml"),
      2, "UWB_RANGE");
  const std::map<std::string, Eigen::Vector3d> pos = {
      {"A1", {0, 0, 2.4}}, {"A2", {10, 0, 2.0}}, {"A3", {10, 8, 3.0}}, {"A4", {0, 8, 1.5}}};
  std::map<std::string, std::vector<double>> err;  // per pair, in order
  for (const auto& m : msgs)
    if (is_anchor_pair(m))
      err[m.tag_id + "-" + m.anchor_id].push_back(m.range_m -
                                                  (pos.at(m.tag_id) - pos.at(m.anchor_id)).norm());
  ASSERT_EQ(err.size(), 6u);
  for (const auto& [pair, e] : err) {
    // 20000 attempts, 10 % lost: binomial spread ~42.
    EXPECT_NEAR(static_cast<double>(e.size()), 18000, 200) << pair;
    int nlos = 0;
    double sum = 0, sum_sq = 0;
    for (double x : e) {
      if (x > 0.55) {  // +1 m NLOS against 4.5 sigma of clean noise around +0.05
        ++nlos;
        continue;
      }
      sum += x;
      sum_sq += x * x;
    }
    const double n = static_cast<double>(e.size() - static_cast<size_t>(nlos));
    const double mean = sum / n, sigma = std::sqrt(sum_sq / n - mean * mean);
    std::printf("pair %s: %zu ranges, NLOS share %.3f, clean mean %+.4f m, sigma %.4f m\n",
                pair.c_str(), e.size(), nlos / static_cast<double>(e.size()), mean, sigma);
    EXPECT_NEAR(nlos / static_cast<double>(e.size()), 0.2, 0.015) << pair;
    EXPECT_NEAR(mean, 0.05, 0.005) << pair;  // sigma / sqrt(14400) ~ 0.001
    EXPECT_NEAR(sigma, 0.10, 0.005) << pair;
  }
  // Every pair has its own stream: the noise of two pairs is uncorrelated.
  const auto& a = err.at("A1-A2");
  const auto& b = err.at("A3-A4");
  const size_t n = std::min(a.size(), b.size());
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) ma += a[i], mb += b[i];
  ma /= static_cast<double>(n);
  mb /= static_cast<double>(n);
  double cab = 0, caa = 0, cbb = 0;
  for (size_t i = 0; i < n; ++i) {
    cab += (a[i] - ma) * (b[i] - mb);
    caa += (a[i] - ma) * (a[i] - ma);
    cbb += (b[i] - mb) * (b[i] - mb);
  }
  EXPECT_LT(std::abs(cab / std::sqrt(caa * cbb)), 0.05);
}

TEST(UwbTwrModel, AnchorPairsBeyondMaxRangeAreNotRanged) {
  // max 11 m: A1-A3 (12.8 m) and A2-A4 (12.9 m) are out of range; the others are not.
  std::set<std::string> got;
  for (const auto& m : simulated_messages<uwb_range_t>(
           parse_scenario_text(pair_scenario("{max_range_m: 11, anchor_pairs_rate_hz: 1}"),
                               "t.yaml"),
           1, "UWB_RANGE"))
    if (is_anchor_pair(m)) got.insert(m.tag_id + "-" + m.anchor_id);
  EXPECT_EQ(got, (std::set<std::string>{"A1-A2", "A1-A4", "A2-A3", "A3-A4"}));
}

TEST(UwbTwrModel, AnchorPairsOffByDefaultAndRateChecked) {
  for (const auto& m : simulated_messages<uwb_range_t>(
           parse_scenario_text(pair_scenario("{rate_hz: 1}"), "t.yaml"), 1, "UWB_RANGE"))
    ASSERT_FALSE(is_anchor_pair(m)) << m.tag_id;
  for (const char* bad : {"-1", "0.001", "2000"}) {
    try {
      parse_scenario_text(pair_scenario(std::string("{anchor_pairs_rate_hz: ") + bad + "}"),
                          "t.yaml");
      FAIL() << bad;
    } catch (const ConfigError& e) {
      EXPECT_STREQ(e.what(),
                   "t.yaml:16: sensors.uwb_twr.anchor_pairs_rate_hz: must be 0 (off) or in "
                   "[0.01, 1000]");
    }
  }
}

// Turning anchor ranging on adds the pair ranges and changes nothing else: every other event of
// the lab scenario (tag ranges, TRUTH, SITE, every other model) keeps its bytes, time and order.
TEST(UwbTwrModel, AnchorPairsLeaveEveryOtherStreamUnchanged) {
  std::string lab = builtin_scenario_text("lab");
  const std::string on = "anchor_pairs_rate_hz: 1";
  const size_t at = lab.find(on);
  ASSERT_NE(at, std::string::npos) << "lab.yaml ranges anchor pairs at 1 Hz";
  std::string off = lab;
  off.replace(at, on.size(), "anchor_pairs_rate_hz: 0");
  Simulator with(parse_scenario_text(lab, "lab.yaml"), 5, kTestStart);
  Simulator without(parse_scenario_text(off, "lab.yaml"), 5, kTestStart);
  SimEvent a, b;
  int pair_ranges = 0, others = 0;
  while (without.next(b)) {
    for (;;) {
      ASSERT_TRUE(with.next(a)) << "ends early";
      uwb_range_t m;
      if (a.kind == "UWB_RANGE") {
        ASSERT_EQ(m.decode(a.data.data(), 0, static_cast<int>(a.data.size())),
                  static_cast<int>(a.data.size()));
        if (m.tag_id.rfind("A", 0) == 0) {
          ++pair_ranges;
          continue;
        }
      }
      break;
    }
    ASSERT_EQ(a.kind, b.kind) << "event " << others;
    ASSERT_EQ(a.utime, b.utime) << "event " << others;
    ASSERT_EQ(a.data, b.data) << "event " << others;
    ++others;
  }
  while (with.next(a)) {  // pair ranges after the last other event
    ASSERT_EQ(a.kind, "UWB_RANGE");
    ++pair_ranges;
  }
  EXPECT_GT(others, 10000);
  EXPECT_NEAR(pair_ranges, 6 * 60, 6);  // 6 pairs at 1 Hz for 60 s
}

}  // namespace
}  // namespace ips::sim
