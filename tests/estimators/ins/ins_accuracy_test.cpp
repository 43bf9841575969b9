// ips-ins on the simulated foot-mounted walks, in-process (simulator -> estimator -> evaluator):
// walk-square-foot (002's ~200 m square block, 174 s) and walk-8-foot (001's 36.3 m figure-8
// corridor loop), with the model's MEMS noise and per-device biases (docs/scenarios/
// walk-square.md). Issue goal (shared with PDR): distance walked within 3 %. 001 reports INS-only
// RMSEs of 1.01 to 1.05 m on its corridor loops (Tab. 6.4) and start-end gaps d_ss of 0.19 to
// 1.1 m after fusion; 002's PDR left 0.13 to 0.68 m on 40-50 m indoor loops and 2.7 to 12.7 m on
// its 200 m square (Table 7.1).
// TRUTH is the walker's body on the waypoint path; the foot lags it by up to a stride during
// stance and follows the 1 s smoothed path round corners, so the RMSE has a floor of a few
// decimetres that no foot INS can beat.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>

#include "core/geometry.hpp"
#include "drivers/sim/simulator.hpp"
#include "estimators/ins/ins_estimator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::ins {
namespace {

struct InsRun {
  eval::ErrorRow row;
  double truth_distance_m = 0;
  double ins_distance_m = 0;  // the estimator's stance-to-stance distance
  double distance_error = 0;  // relative
  double end_gap_m = 0;       // |final INS position - start|, horizontal (truth ends at start)
  double end_error_m = 0;     // |final INS position - final truth|, horizontal
  InsStats stats;
};

InsRun run(const std::string& scenario, uint64_t seed) {
  const sim::Scenario sc = sim::load_scenario(scenario);
  eval::Evaluator ev;
  pose_t last_truth, first_truth, last_pose;
  bool have_truth = false, have_pose = false;
  double truth_distance = 0;
  InsEstimator est([&](const pose_t& p) {
    ev.add_estimate("POSE_INS", p);
    last_pose = p;
    have_pose = true;
  });
  est.set_site(sc.site);
  sim::Simulator simulator(sc, seed, test::kSimStart);
  sim::SimEvent e;
  while (simulator.next(e)) {
    if (e.kind == "TRUTH") {
      pose_t m;
      m.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
      ev.add_truth(m);
      if (have_truth)
        truth_distance += std::hypot(m.position[0] - last_truth.position[0],
                                     m.position[1] - last_truth.position[1]);
      else
        first_truth = m;
      last_truth = m;
      have_truth = true;
    } else if (e.kind == "IMU") {
      imu_t m;
      m.decode(e.data.data(), 0, static_cast<int>(e.data.size()));
      est.on_imu(m);
    }
  }
  InsRun r;
  const auto rows = ev.rows();
  EXPECT_EQ(rows.size(), 1u);
  if (!rows.empty()) r.row = rows[0];
  r.stats = est.stats();
  EXPECT_TRUE(have_pose && have_truth);
  const std::string tag = sc.trajectories.front().tag_id;
  const auto t = est.track(tag);
  EXPECT_TRUE(t);
  if (!t) return r;
  r.truth_distance_m = truth_distance;
  r.ins_distance_m = t->distance_m;
  r.distance_error = (t->distance_m - truth_distance) / truth_distance;
  r.end_gap_m = std::hypot(t->position.x() - first_truth.position[0],
                           t->position.y() - first_truth.position[1]);
  r.end_error_m = std::hypot(t->position.x() - last_truth.position[0],
                             t->position.y() - last_truth.position[1]);
  return r;
}

void print(const std::string& what, const InsRun& r) {
  std::printf(
      "%s: n %zu rmse_h %.3f p95_h %.3f max_h %.3f rmse_v %.3f; distance %.2f / %.2f m "
      "(%+.2f %%); end gap %.3f m, end error %.3f m; zupts %lld stance samples %lld\n",
      what.c_str(), r.row.count, r.row.rmse_h, r.row.p95_h, r.row.max_h, r.row.rmse_v,
      r.ins_distance_m, r.truth_distance_m, 100 * r.distance_error, r.end_gap_m, r.end_error_m,
      static_cast<long long>(r.stats.zupts), static_cast<long long>(r.stats.stance_samples));
}

struct Case {
  const char* scenario;
  double max_distance_error;  // relative
  double max_end_gap_m;
  double max_rmse_m;
};

// Bounds from the first measurements (seeds 1 to 3, clang RelWithDebInfo):
//   walk-square-foot: distance -0.49/-0.30/-0.40 %, end gap 0.42/0.53/0.57 m, RMSE 0.57/0.61/0.58 m
//   walk-8-foot:      distance -1.37/-1.38/-1.40 %, end gap 0.11/0.10/0.07 m, RMSE 0.37/0.36/0.36 m
// (the figure-8's distance is short because the foot cuts its many corners on the smoothed path).
// Distance: the 3 %. Gaps and RMSEs: about 1.5 times the worst seed, all under 001's
// INS-only RMSE of ~1 m.
TEST(InsAccuracy, FootWalksKeepDistanceWithin3PercentAndCloseTheirLoops) {
  for (const Case c :
       {Case{"walk-square-foot", 0.03, 0.9, 0.9}, Case{"walk-8-foot", 0.03, 0.2, 0.55}}) {
    for (uint64_t seed : {1, 2, 3}) {
      const InsRun r = run(c.scenario, seed);
      const std::string what = std::string(c.scenario) + " seed " + std::to_string(seed);
      print(what, r);
      EXPECT_LE(std::abs(r.distance_error), c.max_distance_error) << what;
      EXPECT_LE(r.end_gap_m, c.max_end_gap_m) << what;
      EXPECT_LE(r.row.rmse_h, c.max_rmse_m) << what;
      EXPECT_EQ(r.stats.alignments, 1) << what;
      EXPECT_EQ(r.stats.dropped_invalid + r.stats.gaps + r.stats.dropped_out_of_order, 0) << what;
    }
  }
}

}  // namespace
}  // namespace ips::ins
