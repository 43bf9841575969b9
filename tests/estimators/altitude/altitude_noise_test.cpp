// ips-altitude's honesty (issue 22): per-sensor noise from the site or the sensor's type, the
// noise learned online and a too-small setting said by the consistency monitor, readings that
// share one stamp spread at the sensor's rate, the single-barometer (relative) mode, and a
// reported sigma that covers the errors of a static sensor.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
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
  auto error_of = [](const std::string& yaml) {
    try {
      parse_altitude_params(site_with(yaml).estimator_params("altitude"));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("{sensors: {T1: {type: BMP999}}}").find("unknown barometer type 'BMP999'"),
            std::string::npos);
  EXPECT_NE(error_of("{sensors: {T1: {type: BMP280, oversampling: 1}}}").find("BMP180 only"),
            std::string::npos);
  EXPECT_NE(error_of("{sensors: {T1: {sigma: 1}}}").find("sigma"), std::string::npos);
  EXPECT_NE(error_of("{mode: absolute}").find("auto, differential or relative"),
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
  // The tag's lines arrive three at a time, every 300 ms, with one stamp; 10 Hz really.
  for (int i = 0; i < 300; ++i) {
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, true));
    if (i % 3 == 2)
      for (int k = 0; k < 3; ++k)
        f.est.on_baro(reading("T1", kT0 + ms(100 * i), pressure_at(100900.0, 2.4, 1.0)));
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
  g.est.on_baro(reading("T1", kT0 + ms(10), 100900.0));
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

}  // namespace
}  // namespace ips::altitude
