// ips-uwb-tdoa from pairwise TDoA alone (UWB_TDOA, as Loco-style systems deliver it), in-process:
// the simulator's uwb_tdoa_pairs model -> TdoaEstimator::on_pair -> evaluator. A Loco-style room
// (10 x 8 m, 8 anchors in the corners, alternately high and low), the tag at a known 1.2 m (2D),
// 100 differences a second (TDoA2: consecutive anchors), 0.05 m noise. Deterministic seeds.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <cstdio>
#include <ips/pose_t.hpp>
#include <ips/uwb_tdoa_t.hpp>
#include <string>

#include "drivers/sim/scenario.hpp"
#include "estimators/uwb_tdoa/models/tdoa_pair.hpp"
#include "estimators/uwb_tdoa/pair_tracker.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::uwb_tdoa {
namespace {

constexpr const char* kSite = R"(site:
  name: loco-room
  anchors:
    - {id: L0, kind: uwb_tdoa, position: [0.2, 0.2, 0.3]}
    - {id: L1, kind: uwb_tdoa, position: [0.2, 0.2, 2.7]}
    - {id: L2, kind: uwb_tdoa, position: [9.8, 0.2, 0.3]}
    - {id: L3, kind: uwb_tdoa, position: [9.8, 0.2, 2.7]}
    - {id: L4, kind: uwb_tdoa, position: [9.8, 7.8, 0.3]}
    - {id: L5, kind: uwb_tdoa, position: [9.8, 7.8, 2.7]}
    - {id: L6, kind: uwb_tdoa, position: [0.2, 7.8, 0.3]}
    - {id: L7, kind: uwb_tdoa, position: [0.2, 7.8, 2.7]}
  tags:
    - {id: T1, height_m: 1.2}
)";

// A scenario of `duration_s` with the tag on `trajectory` (YAML) and `pairs` (YAML map text) as
// the uwb_tdoa_pairs section.
sim::Scenario scenario(const std::string& trajectory, const std::string& pairs,
                       double duration_s, const char* site = kSite) {
  const std::string text = "name: loco-pairs\nduration_s: " + std::to_string(duration_s) + "\n" +
                           site + "trajectories:\n  - tag: T1\n    height_m: 1.2\n" + trajectory +
                           "sensors:\n  truth:\n    rate_hz: 50\n  uwb_tdoa_pairs: " + pairs + "\n";
  return sim::parse_scenario_text(text, "tdoa_pair_test");
}

std::string standing_at(double x, double y) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "    loop: false\n    waypoints: [[%g, %g], [%g, %g]]\n", x, y,
                x + 0.001, y);
  return buf;
}

const std::string kWalk =
    "    loop: true\n    speed_mps: 1.0\n"
    "    waypoints: [[1.5, 1.5], [8.5, 1.5], [8.5, 6.5], [4.0, 6.5], [4.0, 3.5], [1.5, 3.5]]\n";

struct Result {
  eval::ErrorRow row;
  PairStats stats;
  double final_error_m = NAN;  // of the last pose against the tag's last truth
  std::string consistency;
};

// Scores poses after `skip_s` (the first fix needs one window of pairs).
Result run(const sim::Scenario& sc, uint64_t seed, double skip_s = 1.0,
           const std::string& params = "") {
  Result r;
  eval::Evaluator ev;
  pose_t last_pose, last_truth;
  TdoaEstimator est(
      [&](const pose_t& p) {
        last_pose = p;
        if (p.utime - test::kSimStart >= s_to_utime(skip_s)) ev.add_estimate("POSE_TDOA", p);
      },
      [](const clock_t&) {});
  Site site = sc.site;
  if (!params.empty()) site.estimators = parse_yaml_text("uwb_tdoa: " + params, "params");
  est.set_site(site);
  test::run_simulated(sc, seed,
                      {.truth =
                           [&](const pose_t& m) {
                             last_truth = m;
                             ev.add_truth(m);
                           },
                       .uwb_tdoa = [&](const uwb_tdoa_t& m) { est.on_pair(m); }});
  const auto rows = ev.rows();
  EXPECT_EQ(rows.size(), 1u);
  if (!rows.empty()) r.row = rows[0];
  r.stats = est.pair_stats();
  r.final_error_m = std::hypot(last_pose.position[0] - last_truth.position[0],
                               last_pose.position[1] - last_truth.position[1]);
  r.consistency = est.consistency().summary();
  return r;
}

void print(const char* what, const Result& r) {
  std::printf(
      "%s: poses %zu rmse_h %.3f p95_h %.3f max_h %.3f; pairs in %lld used %lld gated %lld "
      "geometry %lld initialising %lld; fixes %lld lost %lld\n",
      what, r.row.count, r.row.rmse_h, r.row.p95_h, r.row.max_h,
      static_cast<long long>(r.stats.pairs_in), static_cast<long long>(r.stats.pairs_used),
      static_cast<long long>(r.stats.pairs_gated), static_cast<long long>(r.stats.pairs_geometry),
      static_cast<long long>(r.stats.pairs_initialising),
      static_cast<long long>(r.stats.initialisations), static_cast<long long>(r.stats.lost));
}

TEST(TdoaPairs, StaticTagFromPairsAlone) {
  const Result r = run(scenario(standing_at(7.0, 2.5), "{noise_sigma_m: 0.05}", 30), 1);
  print("static (7.0, 2.5) seed 1 30 s", r);
  EXPECT_GT(r.row.count, 280u);  // 10 poses a second after the first
  EXPECT_LE(r.row.rmse_h, 0.15);
  EXPECT_LE(r.row.max_h, 0.30);
  EXPECT_EQ(r.stats.initialisations, 1);
  EXPECT_EQ(r.stats.lost, 0);
  EXPECT_GT(r.stats.pairs_used, 2900);  // 100 a second, nearly all used
  EXPECT_LT(r.stats.pairs_gated, r.stats.pairs_in / 50);
}

TEST(TdoaPairs, WalkFromPairsAlone) {
  for (uint64_t seed : {1, 2, 3}) {
    const Result r = run(scenario(kWalk, "{noise_sigma_m: 0.05}", 60), seed);
    print(("walk seed " + std::to_string(seed) + " 60 s").c_str(), r);
    EXPECT_GT(r.row.count, 580u) << seed;
    EXPECT_LE(r.row.rmse_h, 0.15) << seed;
    EXPECT_EQ(r.stats.lost, 0) << seed;
  }
}

TEST(TdoaPairs, RandomPairsTdoa3) {
  const Result r = run(scenario(kWalk, "{noise_sigma_m: 0.05, pairing: random}", 60), 4);
  print("walk TDoA3 (random pairs) seed 4 60 s", r);
  EXPECT_LE(r.row.rmse_h, 0.15);
}

// One anchor's distance off by -1 m (an obstructed path): its pairs carry -1 m as anchor_b and
// +1 m as anchor_a, a quarter of all pairs. The gate refuses them; the estimate stays.
TEST(TdoaPairs, NlosAnchorIsGated) {
  for (const char* where : {"static", "walk"}) {
    const bool walk = std::string(where) == "walk";
    const Result r = run(scenario(walk ? kWalk : standing_at(3.0, 5.0),
                                  "{noise_sigma_m: 0.05, nlos_bias_m: {L3: -1.0}}", 60),
                         5);
    print((std::string("NLOS L3 -1 m, ") + where + " seed 5 60 s").c_str(), r);
    EXPECT_LE(r.row.rmse_h, 0.15) << where;
    EXPECT_LE(r.row.p95_h, 0.25) << where;
    // Pairs with L3 are 2 in 8 (L2>L3, L3>L4): most of them gated, the others used.
    EXPECT_GT(r.stats.pairs_gated, r.stats.pairs_in / 5) << where;
    EXPECT_LT(r.stats.pairs_gated, r.stats.pairs_in / 3) << where;
    EXPECT_EQ(r.stats.lost, 0) << where;
    // The consistency monitor counts the gated pairs per anchor pair.
    EXPECT_NE(r.consistency.find("TDOA_PAIR"), std::string::npos) << r.consistency;
  }
  // Without the gate (wide open), the same bias drags the estimate.
  const Result open = run(scenario(standing_at(3.0, 5.0),
                                   "{noise_sigma_m: 0.05, nlos_bias_m: {L3: -1.0}}", 30),
                          5, 1.0, "{pair_gate_sigma: 1e6}");
  print("NLOS L3 -1 m, static, gate open", open);
  EXPECT_GT(open.row.rmse_h, 0.15);
}

// Random NLOS on any difference (UTIL's -0.2 to -3.9 m), 10 % of them.
TEST(TdoaPairs, RandomNlosBiasesAreGated) {
  const Result r =
      run(scenario(kWalk, "{noise_sigma_m: 0.05, nlos_probability: 0.1}", 60), 6);
  print("walk, 10 % NLOS -3.9..-0.2 m, seed 6", r);
  EXPECT_LE(r.row.rmse_h, 0.15);
}

// A small Loco set-up: 4 anchors at one height, TDoA2 (4 distinct pairs, 3 independent): the
// start asks for what such a site can give.
TEST(TdoaPairs, FourAnchorSite) {
  static const char* kFour = R"(site:
  name: four
  anchors:
    - {id: D1, kind: uwb_tdoa, position: [0.3, 0.3, 2.6]}
    - {id: D2, kind: uwb_tdoa, position: [9.7, 0.3, 2.6]}
    - {id: D3, kind: uwb_tdoa, position: [9.7, 7.7, 2.6]}
    - {id: D4, kind: uwb_tdoa, position: [0.3, 7.7, 2.6]}
  tags:
    - {id: T1, height_m: 1.2}
)";
  const Result st = run(scenario(standing_at(6.5, 2.0), "{noise_sigma_m: 0.05}", 20, kFour), 8);
  print("4 anchors, static (6.5, 2.0) seed 8", st);
  EXPECT_EQ(st.stats.initialisations, 1);
  EXPECT_LE(st.row.rmse_h, 0.15);
  const Result w = run(scenario(kWalk, "{noise_sigma_m: 0.05}", 60, kFour), 8);
  print("4 anchors, walk seed 8", w);
  EXPECT_LE(w.row.rmse_h, 0.15);
}

// The first fix converges from anywhere inside the site: the tag standing at points over the
// room, corners included.
TEST(TdoaPairs, ConvergesFromAnywhereInsideTheSite) {
  for (double x : {0.6, 3.0, 5.0, 7.5, 9.4}) {
    for (double y : {0.6, 4.0, 7.4}) {
      const Result r = run(scenario(standing_at(x, y), "{noise_sigma_m: 0.05}", 3), 7, 0.5);
      EXPECT_EQ(r.stats.initialisations, 1) << x << "," << y;
      EXPECT_LE(r.final_error_m, 0.15) << x << "," << y;
      EXPECT_LE(r.row.max_h, 0.4) << x << "," << y;
    }
  }
}

// A track lost (the tag teleported, as after a relocation with the logger paused) restarts from a
// fix through the gate integrator.
TEST(TdoaPairs, LostTrackRestarts) {
  PairParams p;
  std::vector<pose_t> poses;
  PairTracker tr([&](const pose_t& m) { poses.push_back(m); }, "test");
  const Site site = sim::parse_scenario_text(std::string("name: s\n") + kSite +
                                                 "trajectories:\n  - tag: T1\n    waypoints: "
                                                 "[[1, 1], [2, 1]]\n",
                                             "t")
                        .site;
  tr.configure(site, p, nullptr);
  auto feed = [&](const Eigen::Vector3d& at, utime_t t0, int n) {
    std::vector<Eigen::Vector3d> a;
    std::vector<std::string> ids;
    for (const auto& an : site.anchors) {
      a.push_back(an.position);
      ids.push_back(an.id);
    }
    for (int k = 0; k < n; ++k) {
      const size_t i = static_cast<size_t>(k) % a.size(), j = (i + 1) % a.size();
      uwb_tdoa_t m;
      m.utime = t0 + k * 10000;
      m.source = "test";
      m.tag_id = "T1";
      m.anchor_a = ids[i];
      m.anchor_b = ids[j];
      m.diff_m = (at - a[j]).norm() - (at - a[i]).norm();
      m.sigma_m = NAN;
      m.quality = NAN;
      m.seq = k;
      tr.on_pair(m);
    }
  };
  feed({2, 2, 1.2}, test::kSimStart, 200);
  feed({8, 6, 1.2}, test::kSimStart + 2000000, 200);
  EXPECT_EQ(tr.stats().lost, 1);
  EXPECT_EQ(tr.stats().initialisations, 2);
  ASSERT_FALSE(poses.empty());
  EXPECT_NEAR(poses.back().position[0], 8.0, 0.05);
  EXPECT_NEAR(poses.back().position[1], 6.0, 0.05);
}

TEST(TdoaPairs, BadPairsAreCountedNotUsed) {
  std::vector<pose_t> poses;
  TdoaEstimator est([&](const pose_t& p) { poses.push_back(p); }, [](const clock_t&) {});
  uwb_tdoa_t m;
  m.utime = test::kSimStart;
  m.tag_id = "T1";
  m.anchor_a = "L0";
  m.anchor_b = "L2";
  m.diff_m = 1.0;
  m.sigma_m = NAN;
  m.quality = NAN;
  m.seq = -1;
  est.on_pair(m);  // no site yet
  EXPECT_EQ(est.pair_stats().pairs_no_site, 1);
  est.set_site(scenario(standing_at(1, 1), "{}", 1).site);
  uwb_tdoa_t bad = m;
  bad.diff_m = NAN;
  est.on_pair(bad);
  bad = m;
  bad.anchor_b = "L0";
  est.on_pair(bad);
  bad = m;
  bad.sigma_m = -1;
  est.on_pair(bad);
  bad = m;
  bad.utime = -5;
  est.on_pair(bad);
  EXPECT_EQ(est.pair_stats().pairs_invalid, 4);
  bad = m;
  bad.anchor_b = "X9";
  est.on_pair(bad);
  EXPECT_EQ(est.pair_stats().pairs_unknown_anchor, 1);
  bad = m;
  bad.diff_m = 30;  // L0-L2 are 9.6 m apart
  est.on_pair(bad);
  EXPECT_EQ(est.pair_stats().pairs_geometry, 1);
  EXPECT_TRUE(poses.empty());
  EXPECT_GE(est.drop_reasons().total(), 7);
}

// Pairs off the bus can be anything: random anchors (known and not), differences (NaN, inf, huge,
// plausible), sigmas and times (jumping back and forth). Only finite poses come out; every pair
// is counted once, as used, gated or dropped for a reason.
TEST(TdoaPairs, RandomPairsNeverPublishNonFinite) {
  const Site site = scenario(standing_at(1, 1), "{}", 1).site;
  std::mt19937_64 rng(11);
  int64_t poses = 0;
  TdoaEstimator est(
      [&](const pose_t& p) {
        ++poses;
        for (double v : p.position) ASSERT_TRUE(std::isfinite(v));
        for (double v : p.position_cov) ASSERT_TRUE(std::isfinite(v));
      },
      [](const clock_t&) {});
  est.set_site(site);
  const char* ids[] = {"L0", "L1", "L2", "L3", "L4", "L5", "L6", "L7", "X9", ""};
  const double odd[] = {NAN, INFINITY, -INFINITY, 1e300, -1e9, 0.0};
  utime_t t = test::kSimStart;
  for (int k = 0; k < 50000; ++k) {
    uwb_tdoa_t m;
    const int mode = static_cast<int>(rng() % 100);
    t += mode < 2 ? -static_cast<utime_t>(rng() % 10000000) : static_cast<utime_t>(rng() % 20000);
    m.utime = mode == 3 ? -1 : t;
    m.tag_id = mode < 90 ? "T1" : (mode < 95 ? "T" + std::to_string(rng() % 5000) : "");
    m.anchor_a = ids[rng() % 10];
    m.anchor_b = ids[rng() % 10];
    const Eigen::Vector3d p(static_cast<double>(rng() % 1000) / 100.0,
                            static_cast<double>(rng() % 800) / 100.0, 1.2);
    const Anchor* a = site.find_anchor(m.anchor_a);
    const Anchor* b = site.find_anchor(m.anchor_b);
    m.diff_m = mode < 80 && a && b ? (p - b->position).norm() - (p - a->position).norm()
                                   : (mode < 90 ? (static_cast<double>(rng() % 4000) - 2000) / 100
                                                : odd[rng() % 6]);
    m.sigma_m = mode % 7 == 0 ? static_cast<float>(odd[rng() % 6]) : NAN;
    m.quality = NAN;
    m.seq = static_cast<int32_t>(k);
    est.on_pair(m);
  }
  const PairStats& s = est.pair_stats();
  std::printf("random pairs: %lld in, %lld used, %lld gated, %lld invalid, %lld unknown anchor, "
              "%lld geometry, %lld late, %lld initialising, %lld fixes, %lld lost, %lld poses\n",
              static_cast<long long>(s.pairs_in), static_cast<long long>(s.pairs_used),
              static_cast<long long>(s.pairs_gated), static_cast<long long>(s.pairs_invalid),
              static_cast<long long>(s.pairs_unknown_anchor),
              static_cast<long long>(s.pairs_geometry), static_cast<long long>(s.pairs_late),
              static_cast<long long>(s.pairs_initialising),
              static_cast<long long>(s.initialisations), static_cast<long long>(s.lost),
              static_cast<long long>(poses));
  EXPECT_EQ(s.pairs_in, 50000);
  EXPECT_GT(s.pairs_invalid, 0);
  EXPECT_GT(s.pairs_unknown_anchor, 0);
  EXPECT_GT(s.pairs_geometry, 0);
  EXPECT_GT(poses, 0);
}

// The model: predicted d_b - d_a and H = unit(p - b) - unit(p - a), as Crazyflie's mm_tdoa.
TEST(TdoaPairs, ModelRowIsCrazyflieConvention) {
  Vec<4> x;
  x << 3, 4, 0, 0;
  const Eigen::Vector3d a(0, 0, 0), b(6, 0, 0);
  const TdoaRow<2> row = tdoa_pair_row<2>(x, 0.0, a, b);
  const Eigen::Vector3d p(3, 4, 0);
  EXPECT_NEAR(row.predicted, (p - b).norm() - (p - a).norm(), 1e-12);
  const Eigen::Vector3d h = (p - b).normalized() - (p - a).normalized();
  EXPECT_NEAR(row.H(0), h(0), 1e-12);
  EXPECT_NEAR(row.H(1), h(1), 1e-12);
  EXPECT_EQ(row.H(2), 0.0);
}

}  // namespace
}  // namespace ips::uwb_tdoa
