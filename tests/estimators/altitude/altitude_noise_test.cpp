// ips-altitude's honesty (issue 22): per-sensor noise from the site or the sensor's type, the
// noise learned online and a too-small setting said by the consistency monitor, readings that
// share one stamp spread at the sensor's rate, the single-barometer (relative) mode, a
// reported sigma that covers the errors of a static sensor, and the still/moving detection: a
// still sensor averaged over still_window_s, a real change released within a second or two.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <functional>
#include <vector>

#include "core/barometric.hpp"
#include "estimators/altitude/altitude_estimator.hpp"

namespace ips::altitude {
namespace {

namespace b = barometric;
constexpr utime_t kT0 = 1767225600000000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Site site_with(const std::string& altitude_yaml, bool stations = true) {
  return parse_site_text(
      std::string("name: t\n"
                  "anchors: [{id: A1, kind: uwb_tdoa, position: [0, 0, 2.4]}]\n") +
          (stations ? "baro_stations: [{id: B1, position: [0, 0, 2.4]}]\n" : "") +
          "tags: [{id: T1}]\n" +
          (altitude_yaml.empty() ? std::string() : "estimators:\n  altitude: " + altitude_yaml + "\n"),
      "test site");
}

// The error parse_altitude_params gives for `estimators.altitude: YAML`, or "no error".
std::string param_error(const std::string& yaml) {
  try {
    parse_altitude_params(site_with(yaml).estimator_params("altitude"));
  } catch (const ConfigError& e) {
    return std::string(e.what());
  }
  return std::string("no error");
}

baro_t reading(const std::string& id, utime_t t, double p, bool ref = false) {
  baro_t m;
  m.utime = t;
  m.source = "test";
  m.sensor_id = id;
  m.pressure_pa = p;
  m.temperature_c = 21.0;
  m.humidity_pct = kNaN;
  m.is_reference = ref;
  m.known_height_m = ref ? 2.4 : kNaN;
  return m;
}

double pressure_at(double p_ref, double h_ref, double h) {
  return b::pressure_above_pa(p_ref, h - h_ref, b::inverse_scale_height_per_m(21, 50, p_ref, 9.81));
}

struct Fixture {
  std::vector<altitude_t> out;
  AltitudeEstimator est{[this](const altitude_t& a) { out.push_back(a); }};
};

utime_t ms(int64_t v) { return v * 1000; }

TEST(AltitudeNoise, TheSensorsTypeGivesItsDataSheetNoise) {
  EXPECT_EQ(sensor_type_sigma_pa("BMP180", -1), 3.0);
  EXPECT_EQ(sensor_type_sigma_pa("BMP180", 0), 6.0);
  EXPECT_EQ(sensor_type_sigma_pa("BMP180", 3), 3.0);
  EXPECT_NEAR(sensor_type_sigma_pa("MPL115A1", -1), 150 / std::sqrt(12.0), 0.5);
  EXPECT_TRUE(std::isnan(sensor_type_sigma_pa("XYZ", -1)));
  const AltitudeParams p = parse_altitude_params(
      site_with("{pressure_sigma_pa: 0.7, sensors: {T1: {type: BMP180, oversampling: 2}, "
                "T2: {type: BMP180, pressure_sigma_pa: 2.5}, T3: {rate_hz: 8}}}")
          .estimator_params("altitude"));
  EXPECT_EQ(p.sigma_pa("T1"), 4.0);
  EXPECT_EQ(p.sigma_pa("T2"), 2.5);
  EXPECT_EQ(p.sigma_pa("T3"), 0.7);
  EXPECT_EQ(p.sigma_pa("T9"), 0.7);
  EXPECT_EQ(p.sigma_setting("T1"), "sensors.T1.type BMP180 (pressure_sigma_pa 4)");
  EXPECT_EQ(p.sigma_setting("T2"), "sensors.T2.pressure_sigma_pa 2.5");
  EXPECT_EQ(p.sigma_setting("T9"), "pressure_sigma_pa 0.7");
  EXPECT_NE(param_error("{sensors: {T1: {type: BMP999}}}").find("unknown barometer type 'BMP999'"),
            std::string::npos);
  EXPECT_NE(param_error("{sensors: {T1: {type: BMP280, oversampling: 1}}}").find("BMP180 only"),
            std::string::npos);
  EXPECT_NE(param_error("{sensors: {T1: {sigma: 1}}}").find("sigma"), std::string::npos);
  EXPECT_NE(param_error("{mode: absolute}").find("auto, differential or relative"),
            std::string::npos);
}

// T1 static at 1.0 m, white pressure noise `noise_pa`, 10 Hz, against an exact reference.
void feed_static(Fixture& f, double noise_pa, int n, uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_pa);
  for (int i = 0; i < n; ++i) {
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, true));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), pressure_at(100900.0, 2.4, 1.0) + noise(rng)));
  }
  f.est.finish();
}

TEST(AltitudeNoise, ATenTimesTooSmallSigmaIsSaidWithinTenSeconds) {
  Fixture f;
  f.est.set_site(site_with("{pressure_sigma_pa: 0.5, learn_noise: false}"));
  feed_static(f, 5.0, 100);  // 10 s
  const std::string problems = f.est.consistency().problems();
  EXPECT_NE(problems.find("BARO T1: innovations"), std::string::npos) << problems;
  EXPECT_NE(problems.find("pressure_sigma_pa 0.5 looks too small"), std::string::npos) << problems;
  EXPECT_TRUE(f.est.consistency().degraded());
}

TEST(AltitudeNoise, LearningTakesTheSensorsNoiseAndTheSigmaCoversTheErrors) {
  Fixture f;
  f.est.set_site(site_with("{pressure_sigma_pa: 0.5}"));  // 10x too small, learned
  feed_static(f, 5.0, 1200);
  const auto& c = f.est.consistency();
  EXPECT_NEAR(std::sqrt(c.variance("BARO", "T1", 0.25)), 5.0, 1.0);
  EXPECT_FALSE(c.degraded()) << c.problems();
  // After the first 20 s: the height within 2 sigma of the truth at least 95 % of the time,
  // no made-up vertical speed, and a sigma near the filter's real spread.
  int inside = 0, n = 0;
  double sum = 0, sum2 = 0, speed2 = 0;
  for (size_t i = 200; i < f.out.size(); ++i) {
    const altitude_t& a = f.out[i];
    inside += std::abs(a.height_m - 1.0) <= 2 * a.height_std_m;
    ++n;
    sum += a.height_m;
    sum2 += a.height_m * a.height_m;
    speed2 += a.vertical_speed_mps * a.vertical_speed_mps;
  }
  ASSERT_GT(n, 900);
  EXPECT_LT(std::sqrt(speed2 / n), 0.5);  // m/s RMS: accel_sigma_mps2 0.5 on 5 Pa noise
  const double sd = std::sqrt(sum2 / n - (sum / n) * (sum / n));
  EXPECT_GE(static_cast<double>(inside) / n, 0.95);
  EXPECT_LT(f.out.back().height_std_m, 4 * sd + 0.05);
  // The filtered spread is well under one reading's (5 Pa: 0.42 m).
  EXPECT_LT(sd, 0.21);
}

TEST(AltitudeNoise, ReadingsSharingOneStampAreSpreadAtTheSensorsRate) {
  Fixture f;
  f.est.set_site(site_with("{}"));
  // The tag's lines arrive three at a time, every 300 ms, with one stamp; 10 Hz really. (Their
  // values differ by the sensor's last digit: the same stamp and values would be a copy.)
  for (int i = 0; i < 300; ++i) {
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, true));
    if (i % 3 == 2)
      for (int k = 0; k < 3; ++k)
        f.est.on_baro(reading("T1", kT0 + ms(100 * i), pressure_at(100900.0, 2.4, 1.0) + 0.01 * k));
  }
  f.est.finish();
  EXPECT_EQ(f.est.stats().dropped_out_of_order, 0);
  EXPECT_EQ(f.est.stats().retimed, 200);
  ASSERT_EQ(f.out.size(), 300u);
  for (size_t i = 1; i < f.out.size(); ++i) EXPECT_GT(f.out[i].utime, f.out[i - 1].utime);
  // Once the rate is known (after a second), the spread readings are 100 ms apart.
  EXPECT_NEAR(static_cast<double>(f.out[151].utime - f.out[150].utime), 1e5, 2e4);
  EXPECT_NEAR(f.out.back().height_m, 1.0, 0.01);
  // A configured rate is used from the start; an older stamp is still out of order.
  Fixture g;
  g.est.set_site(site_with("{sensors: {T1: {rate_hz: 20}}}"));
  g.est.on_baro(reading("B1", kT0, 100900.0, true));
  g.est.on_baro(reading("T1", kT0 + ms(10), 100900.0));
  g.est.on_baro(reading("T1", kT0 + ms(10), 100900.01));
  g.est.on_baro(reading("T1", kT0 + ms(5), 100900.0));
  g.est.on_baro(reading("B1", kT0 + ms(100), 100900.0, true));
  g.est.finish();
  ASSERT_EQ(g.out.size(), 2u);
  EXPECT_EQ(g.out[1].utime - g.out[0].utime, ms(50));
  EXPECT_EQ(g.est.stats().dropped_out_of_order, 1);
}

TEST(AltitudeNoise, ASingleBarometerGivesHeightsRelativeToItsFirstReadings) {
  Fixture f;
  f.est.set_site(site_with("{sensors: {T1: {pressure_sigma_pa: 1}}}", /*stations=*/false));
  EXPECT_TRUE(f.est.relative());
  // 10 Hz; 20 s still, then 3 m up at 0.5 m/s, then still for 20 s.
  const double p0 = 98000.0;
  for (int i = 0; i < 460; ++i) {
    const double s = i * 0.1;
    const double h = s < 20 ? 0.0 : s < 26 ? 0.5 * (s - 20) : 3.0;
    f.est.on_baro(reading("T1", kT0 + ms(100 * i), pressure_at(p0, 0.0, h)));
  }
  f.est.finish();
  ASSERT_GT(f.out.size(), 400u);
  EXPECT_EQ(f.out.front().source, "altitude");
  EXPECT_TRUE(f.out.front().relative);
  EXPECT_NEAR(f.out[100].height_m, 0.0, 0.02);
  EXPECT_NEAR(f.out.back().height_m, 3.0, 0.03);
  // The start level's error and the weather since are in the sigma: it grows with time.
  EXPECT_GT(f.out.back().height_std_m, f.out[100].height_std_m);
  EXPECT_EQ(f.est.stats().dropped_no_reference, 0);
  // With a station in the site (auto) or mode: differential, no reference means no altitude.
  Fixture g;
  g.est.set_site(site_with("{mode: differential}", false));
  EXPECT_FALSE(g.est.relative());
  g.est.on_baro(reading("T1", kT0, p0));
  g.est.finish();
  EXPECT_TRUE(g.out.empty());
  EXPECT_EQ(g.est.stats().dropped_no_reference, 1);
}

// A barometer like baro-loruro's BMP180 at rest: 9 Hz, white noise plus a slow wander (a
// first-order Gauss-Markov process, 3 Pa over 20 s: indoor air and the sensor's own drift).
// `height(s)`: the truth; relative mode (no station). Returns the estimator's output.
std::vector<altitude_t> run_relative(const std::function<double(double)>& height, double white_pa,
                                     double wander_pa, double seconds, uint32_t seed,
                                     Fixture& f) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  const double dt = 1 / 9.0, p0 = 97300.0, tau = 20.0;
  double w = wander_pa * unit(rng);
  for (int i = 0; i * dt < seconds; ++i) {
    w = w * std::exp(-dt / tau) + wander_pa * std::sqrt(1 - std::exp(-2 * dt / tau)) * unit(rng);
    f.est.on_baro(reading("T1", kT0 + static_cast<utime_t>(i * dt * 1e6),
                          pressure_at(p0, 0.0, height(i * dt)) + w + white_pa * unit(rng)));
  }
  f.est.finish();
  return f.out;
}

TEST(AltitudeStill, AStillSensorIsAveragedAndItsSigmaCoversTheWander) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    Fixture f;
    f.est.set_site(site_with("{sensors: {T1: {type: BMP180}}}", /*stations=*/false));
    const auto out = run_relative([](double) { return 0.0; }, 7.0, 3.0, 300, seed, f);
    ASSERT_GT(out.size(), 2600u);
    // The raw per-sample height noise: the readings' spread in m (white and wander, 11.5 Pa/m).
    const double raw_m = std::sqrt(7.0 * 7.0 + 3.0 * 3.0) / 11.5;
    double sum = 0, sum2 = 0;
    int inside = 0;
    for (const auto& a : out) {
      sum += a.height_m;
      sum2 += a.height_m * a.height_m;
      inside += std::abs(a.height_m) <= 2 * a.height_std_m;
    }
    const double n = static_cast<double>(out.size());
    const double sd = std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
    const double cov = inside / n;
    std::printf("seed %u: filtered spread %.3f m, raw %.3f m (ratio %.2f), cov2s %.3f, "
                "motion starts %lld, final sigma %.3f m\n",
                seed, sd, raw_m, sd / raw_m, cov,
                static_cast<long long>(f.est.stats().motion_starts), out.back().height_std_m);
    EXPECT_LE(sd, 0.5 * raw_m) << "seed " << seed;  // issue 22: at most half the raw spread
    EXPECT_GE(cov, 0.95) << "seed " << seed;
    EXPECT_LE(f.est.stats().motion_starts, 1) << "seed " << seed;  // no made-up motion
    EXPECT_EQ(out.back().vertical_speed_mps, 0.0);
  }
}

TEST(AltitudeStill, AWarmUpInTheFirstSecondIsInTheSigmaOfARelativeHeight) {
  // baro-loruro's oss_3: the first readings sit about 1 m (11 Pa) off the rest of the file and
  // settle over 40 s. Height 0 is the first second's mean, so every later height carries that
  // error; the long average's distance from 0 (the tag has not moved) goes into the sigma.
  Fixture f;
  f.est.set_site(site_with("{sensors: {T1: {type: BMP180}}}", /*stations=*/false));
  std::mt19937 rng(5);
  std::normal_distribution<double> unit(0.0, 1.0);
  const double dt = 1 / 9.0;
  for (int i = 0; i * dt < 300; ++i) {
    const double s = i * dt;
    f.est.on_baro(reading("T1", kT0 + static_cast<utime_t>(s * 1e6),
                          97300.0 - 11.0 * std::exp(-s / 15.0) + 3.0 * unit(rng)));
  }
  f.est.finish();
  int inside = 0, n = 0;
  for (const auto& a : f.out) {
    // The first minute: the error still unseen; after two, the weather drift's share of the
    // sigma (reference_drift_pa_per_s) alone would cover it.
    const double s = utime_to_s(a.utime - kT0);
    if (s < 60 || s > 120) continue;
    ++n;
    inside += std::abs(a.height_m) <= 2 * a.height_std_m;
  }
  ASSERT_GT(n, 500);
  std::printf("warm-up: cov2s %.3f from 60 to 120 s, final height %.2f m sigma %.2f m\n",
              static_cast<double>(inside) / n, f.out.back().height_m, f.out.back().height_std_m);
  EXPECT_GE(static_cast<double>(inside) / n, 0.95);
  EXPECT_NEAR(f.out.back().height_m, -11.0 / 11.5, 0.3);  // the start level's error, kept
}

// The RMS error and the error's spread of the output over [from_s, to_s] (seconds after kT0).
struct Errors {
  double rms_m = 0, sd_m = 0;
};
Errors errors_over(const std::vector<altitude_t>& out, const std::function<double(double)>& height,
                   double from_s, double to_s) {
  double sum = 0, sum2 = 0;
  int n = 0;
  for (const auto& a : out) {
    const double s = utime_to_s(a.utime - kT0);
    if (s < from_s || s > to_s) continue;
    const double e = a.height_m - height(s);
    sum += e;
    sum2 += e * e;
    ++n;
  }
  if (n == 0) return {};
  return {std::sqrt(sum2 / n), std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)))};
}

TEST(AltitudeStill, ALiftOrStairsAreReleasedWithinSeconds) {
  // 60 s still, then 6 m at `speed` (a lift 1 m/s; stairs 0.3 m/s), then 60 s still; a quiet
  // sensor (1 Pa white, 0.5 Pa of wander) and a noisy one (baro-loruro's oss 0: 7 Pa, 3 Pa).
  // Against the constant-velocity filter alone (still_window_s 0) on the same readings.
  struct Case {
    double speed, white, wander, detect_s;
  };
  for (const Case c : {Case{1.0, 1.0, 0.5, 1.0}, Case{0.3, 1.0, 0.5, 1.5},
                       Case{1.0, 7.0, 3.0, 2.0}, Case{0.3, 7.0, 3.0, 6.0}}) {
    const double end_s = 60 + 6 / c.speed;
    auto height = [&](double s) { return s < 60 ? 0.0 : s < end_s ? c.speed * (s - 60) : 6.0; };
    Fixture f, cv;
    f.est.set_site(site_with("{sensors: {T1: {pressure_sigma_pa: 1}}}", /*stations=*/false));
    cv.est.set_site(site_with("{sensors: {T1: {pressure_sigma_pa: 1}}, still_window_s: 0}",
                              /*stations=*/false));
    const auto out = run_relative(height, c.white, c.wander, end_s + 60, 7, f);
    const auto out_cv = run_relative(height, c.white, c.wander, end_s + 60, 7, cv);
    // Released: the first height after the start from the moving model (a vertical speed).
    double detect = NAN;
    for (const auto& a : out) {
      const double s = utime_to_s(a.utime - kT0);
      if (s >= 60 && a.vertical_speed_mps != 0.0) {
        detect = s - 60;
        break;
      }
    }
    // Still again: the share of the heights 10 to 60 s after the change from the still model.
    int still = 0, n = 0;
    for (const auto& a : out) {
      const double s = utime_to_s(a.utime - kT0);
      if (s < end_s + 10) continue;
      ++n;
      still += a.vertical_speed_mps == 0.0;
    }
    const Errors moving = errors_over(out, height, 60, end_s + 10);
    const Errors moving_cv = errors_over(out_cv, height, 60, end_s + 10);
    const Errors after = errors_over(out, height, end_s + 10, end_s + 60);
    const Errors after_cv = errors_over(out_cv, height, end_s + 10, end_s + 60);
    std::printf("speed %.1f m/s, noise %.0f Pa: released %.2f s after the start; RMS error from "
                "the start to 10 s after the end %.3f m (CV filter alone %.3f m); spread 10 to "
                "60 s after %.3f m (CV alone %.3f m), %.0f %% still; motion starts %lld\n",
                c.speed, c.white, detect, moving.rms_m, moving_cv.rms_m, after.sd_m,
                after_cv.sd_m, 100.0 * still / n,
                static_cast<long long>(f.est.stats().motion_starts));
    EXPECT_LE(detect, c.detect_s) << "speed " << c.speed << " noise " << c.white;
    EXPECT_GE(f.est.stats().motion_starts, 1);
    // Tracking the change: the detection delay costs a little against the CV filter alone.
    EXPECT_LE(moving.rms_m, 1.5 * moving_cv.rms_m + c.speed * c.detect_s / 4)
        << "speed " << c.speed << " noise " << c.white;
    // Still again once still_after_s (10 s) has shown no change: averaged from then on, a
    // smaller spread than the CV filter's. The return is slow where the sensor wanders (its
    // height over 10 s must agree within the CV filter's own noise): measured, not tuned.
    EXPECT_LE(after.sd_m, 0.85 * after_cv.sd_m) << "speed " << c.speed << " noise " << c.white;
    EXPECT_GE(still, 0.2 * n);
  }
}

TEST(AltitudeStill, StillWindowZeroKeepsTheConstantVelocityFilterOnly) {
  Fixture f;
  f.est.set_site(site_with("{still_window_s: 0}", /*stations=*/false));
  run_relative([](double) { return 0.0; }, 3.0, 0.0, 30, 1, f);
  EXPECT_EQ(f.est.stats().motion_starts, 0);
  ASSERT_FALSE(f.out.empty());
  EXPECT_NE(f.out.back().vertical_speed_mps, 0.0);  // the CV filter's own speed
  EXPECT_NE(param_error("{motion_sigma: 0.5}").find("motion_sigma"), std::string::npos);
  EXPECT_NE(param_error("{still_window_s: -1}").find("still_window_s"), std::string::npos);
  EXPECT_EQ(param_error("{still_window_s: 60, motion_window_s: 2, still_after_s: 3, "
                     "wander_learn_s: 30}"),
            "no error");
}

}  // namespace
}  // namespace ips::altitude
