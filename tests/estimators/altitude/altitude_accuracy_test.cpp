// ips-altitude on the simulated height-step experiment of ../shared/reference/003_baro.md
// (baro-steps: a tag lowered 1.82 -> 0.82 m in 25 cm steps, 3 min per step, a reference
// barometer at 2.4 m; BMP280 noise, a 25 Pa offset on the tag's sensor, a weather walk), after
// the co-located calibration capture of 003 section 2.4 (baro-calibration: 12 min beside the
// reference, a warm-up transient, the first 3 min discarded). Issue 9's goal: height error sigma
// <= 0.10 m and a mean error free of the sensors' offset; 003 reached 0.59 m mean and 0.19 m
// sigma with barometry alone (Table 5.1), using a 150-sample moving average (section 2.5).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <numeric>
#include <vector>

#include "core/barometric.hpp"
#include "drivers/sim/scenario.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/altitude/offset_calibration.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::altitude {
namespace {

struct Errors {
  int n = 0;
  double mean_m = 0;
  double sigma_m = 0;
  double max_abs_m = 0;
};

Errors errors_of(const std::vector<double>& e) {
  Errors r;
  r.n = static_cast<int>(e.size());
  if (e.empty()) return r;
  r.mean_m = std::accumulate(e.begin(), e.end(), 0.0) / r.n;
  double sq = 0;
  for (double x : e) {
    sq += (x - r.mean_m) * (x - r.mean_m);
    r.max_abs_m = std::max(r.max_abs_m, std::abs(x));
  }
  r.sigma_m = std::sqrt(sq / r.n);
  return r;
}

// TRUTH heights of one tag, interpolated.
class TruthHeights {
 public:
  void add(const pose_t& p) { samples_.emplace_back(p.utime, p.position[2]); }
  double at(utime_t t) const {
    auto it = std::lower_bound(samples_.begin(), samples_.end(), std::make_pair(t, -1e300));
    if (it == samples_.begin()) return it->second;
    if (it == samples_.end()) return samples_.back().second;
    const auto& [t1, z1] = *it;
    const auto& [t0, z0] = *(it - 1);
    return z0 + (z1 - z0) * static_cast<double>(t - t0) / static_cast<double>(t1 - t0);
  }
  // Whether the tag moved within `margin` of t (a step in progress).
  bool moving_near(utime_t t, utime_t margin) const {
    return std::abs(at(t - margin) - at(t + margin)) > 1e-4;
  }

 private:
  std::vector<std::pair<utime_t, double>> samples_;
};

std::vector<SensorOffset> calibrate(uint64_t seed, double settle_s) {
  const sim::Scenario sc = sim::load_scenario("baro-calibration");
  OffsetCalibrationOptions o;
  o.settle_s = settle_s;
  OffsetCalibration cal(o);
  cal.set_site(sc.site);
  test::run_simulated(sc, seed, {.baro = [&](const baro_t& m) { cal.on_baro(m); }});
  return cal.finish();
}

struct StepsRun {
  Errors all;     // every published height
  Errors still;   // away from the steps (1 s margin)
  Errors moving_average;  // 003's pipeline: 150-sample moving averages, then (2.2)
  double step_end_error_m = 0;  // mean error over the second after a step ends, worst step
  double step_end_error_ma_m = 0;
  AltitudeStats stats;
};

StepsRun run_steps(uint64_t seed, const std::vector<SensorOffset>& offsets) {
  const sim::Scenario sc = sim::load_scenario("baro-steps");
  const Site site = parse_site_text(site_with_offsets(sc.site, offsets, {}), "calibrated site");
  TruthHeights truth;
  std::vector<altitude_t> out;
  AltitudeEstimator est([&](const altitude_t& a) { out.push_back(a); });
  est.set_site(site);
  // 003 section 2.5: each stream through a 150-sample moving average, then (2.2) with the
  // reference's temperature; the tag paired with the reference's latest average.
  std::deque<double> tag_window, ref_window;
  double ref_avg = NAN, ref_temperature = NAN;
  std::vector<std::pair<utime_t, double>> ma_out;
  const double tag_offset = offsets.empty() ? 0.0 : offsets.front().offset_pa;
  auto push = [](std::deque<double>& w, double v) {
    w.push_back(v);
    if (w.size() > 150) w.pop_front();
    return std::accumulate(w.begin(), w.end(), 0.0) / static_cast<double>(w.size());
  };
  test::run_simulated(sc, seed,
                      {.truth = [&](const pose_t& p) { truth.add(p); },
                       .baro = [&](const baro_t& m) {
                         est.on_baro(m);
                         if (m.is_reference) {
                           ref_avg = push(ref_window, m.pressure_pa);
                           ref_temperature = m.temperature_c;
                         } else {
                           const double avg = push(tag_window, m.pressure_pa - tag_offset);
                           if (std::isnan(ref_avg)) return;
                           const double k = barometric::inverse_scale_height_per_m(
                               ref_temperature, 50, ref_avg, 9.81);
                           ma_out.emplace_back(m.utime,
                                               2.4 + barometric::height_above_m(ref_avg, avg, k));
                         }
                       }});
  est.finish();
  StepsRun r;
  r.stats = est.stats();
  std::vector<double> all, still, ma;
  const utime_t margin = s_to_utime(1.0);
  for (const auto& a : out) {
    const double e = a.height_m - truth.at(a.utime);
    all.push_back(e);
    if (!truth.moving_near(a.utime, margin)) still.push_back(e);
  }
  for (const auto& [t, h] : ma_out) ma.push_back(h - truth.at(t));
  r.all = errors_of(all);
  r.still = errors_of(still);
  r.moving_average = errors_of(ma);
  // Lag: for each step's end (the truth still again after moving), the mean error over the
  // second after it, worst step.
  auto lag_error = [&](const std::vector<std::pair<utime_t, double>>& series) {
    double worst = 0;
    for (size_t i = 1; i < series.size(); ++i) {
      const utime_t end = series[i].first;
      if (!(truth.moving_near(series[i - 1].first - margin / 2, margin / 2) &&
            !truth.moving_near(end - margin / 2, margin / 2)))
        continue;
      double sum = 0;
      int n = 0;
      for (size_t j = i; j < series.size() && series[j].first - end < s_to_utime(1.0); ++j) {
        sum += series[j].second - truth.at(series[j].first);
        ++n;
      }
      if (n > 0) worst = std::max(worst, std::abs(sum / n));
    }
    return worst;
  };
  std::vector<std::pair<utime_t, double>> est_series;
  for (const auto& a : out) est_series.emplace_back(a.utime, a.height_m);
  r.step_end_error_m = lag_error(est_series);
  r.step_end_error_ma_m = lag_error(ma_out);
  return r;
}

TEST(AltitudeAccuracy, CalibrationFindsTheTagsOffsetAfterSettling) {
  // The scenario's tag sensor reads 25 Pa high (003 found about 25 Pa).
  for (uint64_t seed : {1, 2, 3}) {
    const auto settled = calibrate(seed, 180);
    const auto unsettled = calibrate(seed, 0);
    ASSERT_EQ(settled.size(), 1u);
    EXPECT_EQ(settled[0].sensor_id, "T1");
    EXPECT_EQ(settled[0].used, 5399);  // minutes 4 to 12 at 10 Hz
    std::printf("seed %llu: offset %.3f Pa after 180 s settling, %.3f Pa with none; sigma %.3f\n",
                static_cast<unsigned long long>(seed), settled[0].offset_pa,
                unsettled[0].offset_pa, settled[0].sigma_pa);
    EXPECT_NEAR(settled[0].offset_pa, 25.0, 0.05) << "seed " << seed;
    EXPECT_NEAR(settled[0].offset_height_m, -2.12, 0.01);
    // The warm-up transient biases a mean over the whole capture.
    EXPECT_LT(std::abs(settled[0].offset_pa - 25.0), std::abs(unsettled[0].offset_pa - 25.0));
    // Differences of two BMP280 streams, 0.2 Pa each (003 section 2.2), the reference's
    // interpolated between two readings: 0.2 sqrt(1 + 2/3) = 0.258 Pa.
    EXPECT_NEAR(settled[0].sigma_pa, 0.258, 0.015);
  }
}

TEST(AltitudeAccuracy, BaroStepsAfterCalibrationMeetsTheIssueGoal) {
  for (uint64_t seed : {1, 2, 3}) {
    const auto offsets = calibrate(seed, 180);
    const StepsRun r = run_steps(seed, offsets);
    std::printf(
        "seed %llu: %d heights: mean %+.4f m, sigma %.4f m, max |e| %.3f m; still: mean %+.4f, "
        "sigma %.4f; 003's moving average: mean %+.4f, sigma %.4f, max |e| %.3f; error in the "
        "second after a step: %.3f m (moving average %.3f m)\n",
        static_cast<unsigned long long>(seed), r.all.n, r.all.mean_m, r.all.sigma_m,
        r.all.max_abs_m, r.still.mean_m, r.still.sigma_m, r.moving_average.mean_m,
        r.moving_average.sigma_m, r.moving_average.max_abs_m, r.step_end_error_m,
        r.step_end_error_ma_m);
    // 9200 tag readings, each published once (the first waits for the reference).
    EXPECT_GE(r.all.n, 9190);
    EXPECT_EQ(r.stats.dropped_stale_reference + r.stats.dropped_invalid, 0);
    EXPECT_EQ(r.stats.restarts, 0);
    // The issue's goal: sigma <= 0.10 m, and no offset in the mean (uncalibrated: -2.12 m).
    EXPECT_LE(r.all.sigma_m, 0.10) << "seed " << seed;
    EXPECT_LE(std::abs(r.all.mean_m), 0.05) << "seed " << seed;
    EXPECT_LE(r.still.sigma_m, 0.03) << "seed " << seed;
    // Low lag: on the new height right after each step, where 003's 15 s moving average still
    // lags by most of the step (its section 2.5 recommends against it).
    EXPECT_LE(r.step_end_error_m, 0.03);
    EXPECT_GE(r.step_end_error_ma_m, 0.10);
    EXPECT_LT(r.all.sigma_m, r.moving_average.sigma_m);
  }
}

TEST(AltitudeAccuracy, WithoutCalibrationTheMeanCarriesTheOffset) {
  // The tag reads 25 Pa high: 2.12 m too low (003 reproduction target 4: 25 Pa ~ 2 m).
  const StepsRun r = run_steps(1, {});
  EXPECT_NEAR(r.all.mean_m, -2.12, 0.05);
  EXPECT_LE(r.all.sigma_m, 0.10);
}

}  // namespace
}  // namespace ips::altitude
