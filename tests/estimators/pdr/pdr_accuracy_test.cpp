// ips-pdr on the simulated walks of source 002 (walk-square: a phone in the hand round a 200 m
// square block, indoors with magnetic disturbances; walk-loop-840: the 841 m outdoor loop),
// in-process: simulator -> estimator -> evaluator. Steps are counted against the simulator's
// (distance walked / step length), distance against the path length, and the loop's closure
// (final position against the start) reported as the source reported its Table 7.1.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/step_t.hpp>

#include "drivers/sim/scenario.hpp"
#include "drivers/sim/simulator.hpp"
#include "estimators/pdr/pdr_estimator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::pdr {
namespace {

struct PdrRun {
  int steps = 0;
  double distance_m = 0;      // sum of step lengths
  double path_m = 0;          // the truth's path length
  double final_error_m = 0;   // last pose against the last truth position
  double closure_m = 0;       // last pose against the first truth position (start = end)
  eval::ErrorRow row;
  PdrStats stats;
};

PdrRun run(const std::string& scenario, uint64_t seed, const std::string& params = "") {
  sim::Scenario sc = sim::load_scenario(scenario);
  eval::Evaluator ev;
  PdrRun r;
  pose_t last_pose{};
  PdrEstimator est(
      [&](const step_t& s) {
        ++r.steps;
        r.distance_m += s.length_m;
      },
      [&](const pose_t& p) {
        ev.add_estimate("POSE_PDR", p);
        last_pose = p;
      });
  Site site = sc.site;
  if (!params.empty()) site.estimators = parse_yaml_text("pdr: " + params, "params");
  est.set_site(site);
  Eigen::Vector2d first(NAN, NAN), prev(NAN, NAN);
  test::run_simulated(sc, seed,
                      {.truth =
                           [&](const pose_t& m) {
                             ev.add_truth(m);
                             const Eigen::Vector2d p(m.position[0], m.position[1]);
                             if (!first.allFinite()) first = p;
                             if (prev.allFinite()) r.path_m += (p - prev).norm();
                             prev = p;
                           },
                       .imu = [&](const imu_t& m) { est.on_imu(m); }});
  const Eigen::Vector2d end(last_pose.position[0], last_pose.position[1]);
  r.final_error_m = (end - prev).norm();
  r.closure_m = (end - first).norm();
  const auto rows = ev.rows();
  if (!rows.empty()) r.row = rows[0];
  r.stats = est.stats();
  return r;
}

void print(const std::string& what, const PdrRun& r, double expected_steps) {
  std::printf("%s: steps %d (expected %.1f, %+.2f %%), distance %.2f m of %.2f m (%+.2f %%), "
              "final error %.2f m, closure %.2f m, rmse_h %.2f m; mag %lld used, %lld not static, "
              "%lld norm/dip\n",
              what.c_str(), r.steps, expected_steps, 100.0 * (r.steps - expected_steps) / expected_steps,
              r.distance_m, r.path_m, 100.0 * (r.distance_m - r.path_m) / r.path_m,
              r.final_error_m, r.closure_m, r.row.rmse_h,
              static_cast<long long>(r.stats.mag_updates - r.stats.mag_gated),
              static_cast<long long>(r.stats.mag_not_static),
              static_cast<long long>(r.stats.mag_rejected));
}

// The bounds: step count within 2 %, distance within 3 % (walk-square). First
// measurements (closing note of issue 8): steps -0.27 % (277 of 277.8), distance -0.35 %, on
// every seed; the closure (start-end gap after 200 m) 3.5 to 12.9 m over seeds 1-3 against the
// source's 2.7 m (CCW) and 12.7 m (CW) on its square block. The closure bound, 15 m (7.5 % of
// the distance), sits above the seeds measured; it is there to catch a heading gone wrong.
TEST(PdrAccuracy, WalkSquareStepsDistanceAndClosure) {
  for (uint64_t seed : {1, 2, 3}) {
    const PdrRun r = run("walk-square", seed);
    const double expected_steps = r.path_m / 0.72;
    print("walk-square seed " + std::to_string(seed), r, expected_steps);
    EXPECT_NEAR(r.steps, expected_steps, 0.02 * expected_steps);
    EXPECT_NEAR(r.distance_m, r.path_m, 0.03 * r.path_m);
    EXPECT_LT(r.closure_m, 15.0);
    EXPECT_EQ(r.stats.alignments, 1);
    EXPECT_EQ(r.stats.alignments_without_rest, 0);
    EXPECT_EQ(r.stats.no_start_pose, 0);
    // The building's field is refused where it varies along the walk (the lift shaft and the
    // steel door among it); what is used passed the quasi-static check.
    EXPECT_GT(r.stats.mag_not_static, 10 * (r.stats.mag_updates + r.stats.mag_rejected));
  }
}

// The 841 m outdoor loop (002: 32.5 m final error "around CTU"): seed 1, steps and distance
// within the same bounds, closure under 20 m (measured 15.7 m; seeds 2 and 3: 5.9 and 8.9 m).
TEST(PdrAccuracy, Loop840StepsDistanceAndClosure) {
  const PdrRun r = run("walk-loop-840", 1);
  const double expected_steps = r.path_m / 0.80;
  print("walk-loop-840 seed 1", r, expected_steps);
  EXPECT_NEAR(r.steps, expected_steps, 0.02 * expected_steps);
  EXPECT_NEAR(r.distance_m, r.path_m, 0.03 * r.path_m);
  EXPECT_LT(r.closure_m, 20.0);
}

// walk-square's POSE_PDR horizontal RMSE on seeds 1 to 5. Before issue 22 (magnetometer
// heading updates twice a second, also at rest; TRIAD start heading from the local field):
// 2.88 / 9.50 / 4.53 / 2.34 / 6.31 m. With the site's start heading and one heading update per
// 2 m walked: 2.40 / 5.82 / 3.02 / 1.69 / 3.39 m. With the magnetometer's heading noise learned
// from its innovations and gyro_noise_rad_s 0.003 (was 0.01, 60x the simulated gyro's):
// 2.45 / 2.92 / 3.04 / 1.52 / 2.62 m. With the quasi-static field check (a heading update only
// where the world-frame field kept its heading within 5 deg, its norm within 2 uT and its dip
// within 3 deg over the last 3 m) and the correlated updates' variance inflated:
// 0.43 / 0.58 / 0.52 / 0.71 / 1.60 m (magnetometer off: 0.43 / 0.43 / 0.41 / 0.48 / 0.36 m).
// Issue 22's bound, 2 m on every seed.
TEST(PdrAccuracy, WalkSquareRmse) {
  const double bound_m[] = {2.0, 2.0, 2.0, 2.0, 2.0};
  for (uint64_t seed : {1, 2, 3, 4, 5}) {
    const PdrRun r = run("walk-square", seed);
    print("walk-square seed " + std::to_string(seed), r, r.path_m / 0.72);
    EXPECT_LE(r.row.rmse_h, bound_m[seed - 1]) << "seed " << seed;
  }
}

// Consistency (issue 22): with mag_heading_sigma_deg 10x too small (1.15 deg for 11.5) the
// magnetometer's heading innovations are named in problems() within 10 s of walking; with the
// default, no problem is said.
TEST(PdrAccuracy, TooSmallMagSigmaIsSaidWithin10Seconds) {
  for (const bool wrong : {false, true}) {
    sim::Scenario sc = sim::load_scenario("walk-square");
    sc.duration_s = 10 + 1 + 10;  // 10 s at rest, then 10 s of walking (and the filter's 1 s)
    PdrEstimator est([](const step_t&) {}, [](const pose_t&) {});
    Site site = sc.site;
    if (wrong) site.estimators = parse_yaml_text("pdr: {mag_heading_sigma_deg: 1.15}", "params");
    est.set_site(site);
    test::run_simulated(sc, 1, {.imu = [&](const imu_t& m) { est.on_imu(m); }});
    const std::string problems = est.consistency().problems();
    std::printf("mag sigma %s: %s | %s\n", wrong ? "1.15 deg" : "default", problems.c_str(),
                est.consistency().summary().c_str());
    if (wrong) {
      EXPECT_NE(problems.find("MAG P1"), std::string::npos) << problems;
      EXPECT_NE(problems.find("mag_heading_sigma_deg"), std::string::npos) << problems;
    } else {
      EXPECT_EQ(problems, "");
    }
  }
}

// The zero-crossing detector and the norm signal count the same steps within 2 %.
TEST(PdrAccuracy, ZeroCrossingAndNormSignalAlsoCountTheSteps) {
  for (const char* params : {"{detector: zero_crossing}", "{signal: norm}"}) {
    const PdrRun r = run("walk-square", 1, params);
    const double expected_steps = r.path_m / 0.72;
    print(std::string("walk-square seed 1 ") + params, r, expected_steps);
    EXPECT_NEAR(r.steps, expected_steps, 0.02 * expected_steps) << params;
  }
}

// The quasi-static check refuses a disturbed field, not the magnetometer: in walk-square's
// building without its disturbances (no random field, no anomalies) nearly every heading update
// is used, and the track stays within 1.5 m (measured 0.48 to 1.38 m on seeds 1-5).
TEST(PdrAccuracy, CleanFieldPassesTheQuasiStaticCheck) {
  std::string text = sim::builtin_scenario_text("walk-square");
  const auto cut = text.find("    mag_anomalies:");
  ASSERT_NE(cut, std::string::npos);
  text.resize(cut);
  const auto dist = text.find("mag_disturbance_ut: 3");
  ASSERT_NE(dist, std::string::npos);
  text.replace(dist, 21, "mag_disturbance_ut: 0");
  const std::string path = ::testing::TempDir() + "walk-square-clean.yaml";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs(text.c_str(), f);
    std::fclose(f);
  }
  for (uint64_t seed : {1, 2}) {
    const PdrRun r = run(path, seed);
    print("walk-square (clean field) seed " + std::to_string(seed), r, r.path_m / 0.72);
    EXPECT_GT(r.stats.mag_updates, 80) << seed;
    EXPECT_LT(r.stats.mag_not_static, 5) << seed;
    EXPECT_LT(r.row.rmse_h, 1.5) << seed;
  }
}

}  // namespace
}  // namespace ips::pdr
