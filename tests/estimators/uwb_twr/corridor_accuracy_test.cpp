// The TWR tracker, UWB only, on the corridor scenarios of ../shared/reference/001_hybrid_uwb_ins.md
// chapter 4: ranges N(d + 0.11, 0.45) every 0.5 s per anchor, anchors of Tab. 4.2 at 0.54 m, the
// tag on the foot at 0.1 m. Issue 6's bound: RMSE at least 30 % below the source simulation's Foy
// figures (Tab. 4.3: L 0.78 m with 4 anchors and 0.90 m with 3; 8: 0.73 m and 0.89 m). The same
// data also goes through Foy's per-epoch solver: our simulation's Foy error is below the source's
// (0.50 to 0.66 m; the source's anchor layout exists only in a figure, and its epoching is not
// described), so the tracker is also held to beating Foy on the very same ranges.
#include <gtest/gtest.h>

#include <cmath>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <vector>

#include "core/multilateration.hpp"
#include "drivers/sim/simulator.hpp"
#include "tests/estimators/simulated_inputs.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "loggers/eval/evaluation.hpp"

namespace ips::uwb_twr {
namespace {

struct CorridorRun {
  eval::ErrorRow twr;  // POSE_UWB
  eval::ErrorRow foy;  // Foy's method on each 0.5 s epoch's newest range per anchor
};

CorridorRun run(const std::string& scenario, uint64_t seed) {
  sim::Scenario sc = sim::load_scenario(scenario);
  eval::Evaluator ev;
  TwrEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_UWB", p); });
  est.set_site(sc.site);
  std::map<std::string, double> epoch;  // anchor -> newest range in the current 0.5 s epoch
  utime_t epoch_end = 0;
  auto solve_epoch = [&](utime_t t) {
    std::vector<RangeObservation> obs;
    for (const auto& [id, r] : epoch) obs.push_back({sc.site.find_anchor(id)->position, r});
    epoch.clear();
    MultilaterationOptions o;
    o.fixed_height = true;
    o.height_m = sc.site.tags[0].height_m;
    const MultilaterationResult res = multilaterate_foy(obs, o);
    if (!res.ok) return;
    pose_t p{};
    p.utime = t;
    p.tag_id = "T1";
    for (int k = 0; k < 3; ++k) p.position[k] = res.position(k);
    ev.add_estimate("FOY", p);
  };
  test::run_simulated(sc, seed,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_range = [&](const uwb_range_t& m) {
                         est.on_range(m);
                         if (m.utime >= epoch_end) {
                           if (epoch_end != 0) solve_epoch(epoch_end);
                           epoch_end = m.utime + 500'000;
                         }
                         epoch[m.anchor_id] = m.range_m;
                       }});
  CorridorRun out;
  for (const auto& row : ev.rows()) (row.channel == "FOY" ? out.foy : out.twr) = row;
  return out;
}

struct Case {
  const char* scenario;
  double source_foy_rmse_m;  // 001 Tab. 4.3
};

class TwrCorridorAccuracy : public ::testing::TestWithParam<Case> {};

TEST_P(TwrCorridorAccuracy, RmseAtLeastThirtyPercentBelowTheSourceFoyFigure) {
  const Case c = GetParam();
  const double bound = 0.7 * c.source_foy_rmse_m;
  double sum_sq = 0, foy_sum_sq = 0;
  const int seeds = 5;
  for (uint64_t seed = 1; seed <= seeds; ++seed) {
    const CorridorRun r = run(c.scenario, seed);
    std::printf("%s seed %d: POSE_UWB n %zu rmse_h %.3f p95_h %.3f | Foy per epoch n %zu rmse_h %.3f\n",
                c.scenario, static_cast<int>(seed), r.twr.count, r.twr.rmse_h, r.twr.p95_h,
                r.foy.count, r.foy.rmse_h);
    EXPECT_GT(r.twr.count, 50u) << "seed " << seed;
    EXPECT_LE(r.twr.rmse_h, bound) << c.scenario << " seed " << seed;
    sum_sq += r.twr.rmse_h * r.twr.rmse_h;
    foy_sum_sq += r.foy.rmse_h * r.foy.rmse_h;
  }
  const double rmse = std::sqrt(sum_sq / seeds), foy = std::sqrt(foy_sum_sq / seeds);
  std::printf("%s over %d seeds: POSE_UWB rmse_h %.3f (bound %.3f) | Foy %.3f (source %.2f)\n",
              c.scenario, seeds, rmse, bound, foy, c.source_foy_rmse_m);
  // Filtering over epochs must be worth clearly more than solving each epoch alone.
  EXPECT_LE(rmse, 0.85 * foy);
  EXPECT_LE(foy, c.source_foy_rmse_m);
}

INSTANTIATE_TEST_SUITE_P(Corridor, TwrCorridorAccuracy,
                         ::testing::Values(Case{"corridor-L", 0.78}, Case{"corridor-L-3", 0.90},
                                           Case{"corridor-8", 0.73}, Case{"corridor-8-3", 0.89}),
                         [](const auto& param_info) {
                           std::string n = param_info.param.scenario;
                           for (char& ch : n)
                             if (ch == '-') ch = '_';
                           return n;
                         });

}  // namespace
}  // namespace ips::uwb_twr
