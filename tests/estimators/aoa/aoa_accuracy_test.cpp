// ips-aoa on the simulated hall of source 000 (aoa-hall, aoa-hall-static-1 at T1,
// aoa-hall-static-2 at T5), in-process (simulator -> estimator -> evaluator), with the source's
// error model: 5 deg noise, per-anchor biases of a few degrees, multipath duplicates, losses and
// 25 ms epoch skew (docs/scenarios/aoa-hall.md). The source measured 0.54 to 0.93 m RMSE_xy at
// its static points (Table 7.3, lab T2 with people walking to lab T1 NR; the hall's Table 7.5
// runs from 0.60 to 2.9 m); both our per-epoch Levenberg-Marquardt and our EKF must do at least
// as well, and the EKF better than per-epoch LM on the same events.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ips/ble_aoa_t.hpp>
#include <ips/pose_t.hpp>

#include "drivers/sim/simulator.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/aoa/calibration_fit.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::aoa {
namespace {

struct AoaRun {
  eval::ErrorRow row;
  AoaStats stats;
};

// `params`: YAML map text for the site's estimators.aoa. Static scenarios are scored like the
// source scored them: every estimate against the known point (RMSE_xy).
AoaRun run(const std::string& scenario, uint64_t seed, const std::string& params,
        bool static_point) {
  const sim::Scenario sc = sim::load_scenario(scenario);
  eval::Evaluator ev;
  if (static_point) {
    const Eigen::Vector3d w = sc.trajectories.front().path.at(sc.duration_s).position;
    ev.set_static_point(w, false);
  }
  AoaEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_AOA", p); });
  Site site = sc.site;
  if (!params.empty()) site.estimators = parse_yaml_text("aoa: " + params, "params");
  est.set_site(site);
  test::run_simulated(sc, seed,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .ble_aoa = [&](const ble_aoa_t& m) { est.on_event(m); }});
  est.finish();
  AoaRun r;
  const auto rows = ev.rows();
  EXPECT_EQ(rows.size(), 1u);
  if (!rows.empty()) r.row = rows[0];
  r.stats = est.stats();
  return r;
}

void print(const std::string& what, const AoaRun& r) {
  std::printf("%s: n %zu rmse_h %.3f p95_h %.3f max_h %.3f; used %lld gated %lld dup %lld "
              "inits %lld fail %lld\n",
              what.c_str(), r.row.count, r.row.rmse_h, r.row.p95_h, r.row.max_h,
              static_cast<long long>(r.stats.angles_used),
              static_cast<long long>(r.stats.rejected_gate),
              static_cast<long long>(r.stats.duplicates),
              static_cast<long long>(r.stats.initialisations),
              static_cast<long long>(r.stats.solve_failures));
}

// Bounds chosen from the first measurements (seeds 1 to 5; closing note of issue 7): per-epoch
// LM scored 0.51 to 0.62 m, the EKF 0.22 to 0.44 m, and the EKF was at most 0.72 times LM on
// the same events. The bounds leave a margin for other seeds and compilers, and all lie under
// the source's best measured static figure (0.54 m) for the EKF and its worst (0.93 m) for LM.
constexpr double kLmBoundM = 0.70;
constexpr double kEkfBoundM = 0.50;
constexpr double kEkfOverLmMax = 0.80;

struct Case {
  const char* scenario;
  bool static_point;
};

TEST(AoaAccuracy, EkfBeatsPerEpochLmAndBothBeatTheSourceOnTheHall) {
  for (const Case c : {Case{"aoa-hall-static-1", true}, Case{"aoa-hall-static-2", true},
                       Case{"aoa-hall", false}}) {
    double sum_sq_lm = 0, sum_sq_ekf = 0;
    const std::vector<uint64_t> seeds{1, 2, 3, 4, 5};
    for (uint64_t seed : seeds) {
      const AoaRun lm = run(c.scenario, seed, "{method: per_epoch, solver: lm}", c.static_point);
      const AoaRun ekf = run(c.scenario, seed, "", c.static_point);
      const std::string what = std::string(c.scenario) + " seed " + std::to_string(seed);
      print(what + " per-epoch LM", lm);
      print(what + " EKF", ekf);
      // 10 advertisements a second; a few LM epochs lack two usable anchors.
      const double expected = 10.0 * sim::load_scenario(c.scenario).duration_s;
      EXPECT_GT(static_cast<double>(lm.row.count), 0.98 * expected) << what;
      EXPECT_GT(static_cast<double>(ekf.row.count), 0.99 * expected) << what;
      EXPECT_LE(lm.row.rmse_h, kLmBoundM) << what;
      EXPECT_LE(ekf.row.rmse_h, kEkfBoundM) << what;
      EXPECT_LE(ekf.row.rmse_h, kEkfOverLmMax * lm.row.rmse_h) << what;
      EXPECT_EQ(ekf.stats.initialisations, 1) << what;  // never lost
      EXPECT_GT(ekf.stats.duplicates, 0) << what;       // multipath copies were there
      sum_sq_lm += lm.row.rmse_h * lm.row.rmse_h;
      sum_sq_ekf += ekf.row.rmse_h * ekf.row.rmse_h;
    }
    const double n = static_cast<double>(seeds.size());
    std::printf("%s: RMS over seeds 1-5: per-epoch LM %.3f m, EKF %.3f m\n", c.scenario,
                std::sqrt(sum_sq_lm / n), std::sqrt(sum_sq_ekf / n));
  }
}

TEST(AoaAccuracy, TheSourceRandomWalkEkfAndOtherSolversAlsoBeatTheSource) {
  // The source's own filter (random walk, Q = 1.2^2 m^2/s) and the other per-epoch solvers, on
  // the walk, seed 1: all within the source's measured range.
  for (const char* params :
       {"{motion: random_walk}", "{method: per_epoch, solver: gauss_newton}",
        "{method: per_epoch, solver: bearing_lines}", "{method: per_epoch, solver: steepest_descent}",
        "{duplicate: nearest}", "{duplicate: first}"}) {
    const AoaRun r = run("aoa-hall", 1, params, false);
    print(std::string("aoa-hall seed 1 ") + params, r);
    EXPECT_LE(r.row.rmse_h, kLmBoundM) << params;
    EXPECT_GT(r.row.count, 590u) << params;
  }
}

// The estimators.aoa.calibration block (YAML flow map) that ips-aoa-calibrate's fit gives for
// a static capture of aoa-hall-calibration (tags T1..T5 at the thesis's five points) with `seed`,
// which draws the same anchor biases as aoa-hall with that seed.
std::string calibration_from_static_capture(uint64_t seed, int degree) {
  const sim::Scenario sc = sim::load_scenario("aoa-hall-calibration");
  std::vector<ReferencePoint> points;
  for (const auto& w : sc.trajectories) {
    ReferencePoint p;
    p.tag_id = w.tag_id;
    p.position = w.path.at(sc.duration_s).position;
    points.push_back(p);
  }
  CalibrationFitOptions opts;
  opts.degree = degree;
  CalibrationCollector collector(points, false, opts);
  collector.set_site(sc.site);
  test::run_simulated(sc, seed, {.ble_aoa = [&](const ble_aoa_t& m) {
                                   collector.add(m, utime_to_s(m.utime - test::kSimStart));
                                 }});
  std::string block = "{";
  for (const AnchorFit& a : collector.fit().anchors) {
    EXPECT_TRUE(a.azimuth.fitted) << a.anchor_id << ": " << a.azimuth.failure;
    if (!a.azimuth.fitted) continue;
    block += (block.size() > 1 ? ", " : "") + a.anchor_id +
             ": {azimuth: " + format_angle_correction(a.azimuth.correction) + "}";
  }
  return block + "}";
}

// The workflow docs/programs.md describes: calibrate on a static capture at known points, then
// position with the calibrated site. The mounting biases (3 deg sigma) are what limits the
// uncalibrated estimates; removing them must lower the walk's RMSE for both methods.
TEST(AoaAccuracy, CalibrationFromAStaticCaptureImprovesTheWalk) {
  double sum_sq[2][2] = {{0, 0}, {0, 0}};  // [method][calibrated]
  for (uint64_t seed : {1, 2, 3}) {
    const std::string cal = calibration_from_static_capture(seed, 1);
    for (int m = 0; m < 2; ++m) {
      const std::string method = m == 0 ? "method: per_epoch, solver: lm" : "method: ekf";
      const AoaRun raw = run("aoa-hall", seed, "{" + method + "}", false);
      const AoaRun calibrated =
          run("aoa-hall", seed, "{" + method + ", calibration: " + cal + "}", false);
      const std::string what = "aoa-hall seed " + std::to_string(seed) + " " + method;
      print(what + " uncalibrated", raw);
      print(what + " calibrated", calibrated);
      EXPECT_LT(calibrated.row.rmse_h, raw.row.rmse_h) << what;
      EXPECT_GT(calibrated.row.count, 590u) << what;
      sum_sq[m][0] += raw.row.rmse_h * raw.row.rmse_h;
      sum_sq[m][1] += calibrated.row.rmse_h * calibrated.row.rmse_h;
    }
  }
  for (int m = 0; m < 2; ++m)
    std::printf("aoa-hall seeds 1-3, %s: RMS of RMSE %.3f m uncalibrated, %.3f m calibrated\n",
                m == 0 ? "per-epoch LM" : "EKF", std::sqrt(sum_sq[m][0] / 3),
                std::sqrt(sum_sq[m][1] / 3));
}

}  // namespace
}  // namespace ips::aoa
