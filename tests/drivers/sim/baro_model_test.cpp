// The barometer model (drivers/sim/models/baro.cpp) against its own parameters and the figures of
// ../shared/reference/003_baro.md (Marek 2024): the hypsometric gradient, BMP280 noise, per-sensor
// offsets, the common weather drift, reference stations and the temperature sensitivity.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <ips/baro_t.hpp>
#include <map>
#include <string>
#include <vector>

#include "drivers/sim/simulator.hpp"
#include "tests/drivers/sim/sim_test_support.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;

// A scenario with barometer stations `stations` (a YAML flow list), one tag T1 walking a loop at
// `tag_height_m`, TRUTH off and the baro section `baro` (a YAML flow map).
std::string scenario_text(const std::string& stations, const std::string& baro, double duration_s,
                          double tag_height_m = 1.2) {
  return "duration_s: " + std::to_string(duration_s) +
         "\n"
         "site_period_s: 3600\n"
         "site:\n"
         "  anchors:\n"
         "    - {id: A1, position: [0, 0, 2.4]}\n"
         "  baro_stations: " +
         stations +
         "\n"
         "  tags:\n"
         "    - {id: T1}\n"
         "trajectories:\n"
         "  - {tag: T1, height_m: " +
         std::to_string(tag_height_m) +
         ", waypoints: [[0, 0], [4, 0], [4, 3]]}\n"
         "sensors:\n"
         "  truth: {enabled: false}\n"
         "  baro: " +
         baro + "\n";
}

using Readings = std::map<std::string, std::vector<baro_t>>;  // by sensor_id

Readings run(const Scenario& sc, uint64_t seed) {
  Readings out;
  for (const auto& m : simulated_messages<baro_t>(sc, seed, "BARO")) out[m.sensor_id].push_back(m);
  return out;
}

Readings run(const std::string& text, uint64_t seed = 1) {
  return run(parse_scenario_text(text, "test.yaml"), seed);
}

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return s / static_cast<double>(v.size());
}
double sigma_of(const std::vector<double>& v) {
  const double m = mean_of(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}
std::vector<double> pressures(const std::vector<baro_t>& r) {
  std::vector<double> p;
  for (const auto& m : r) p.push_back(m.pressure_pa);
  return p;
}

// Moist-air density of the reference, (2.9) with T in K (Tetens' denominator Tc + 243.5 written
// as T - 29.65), and (2.2): the height above p0 implied by p_h. Written out here, apart from the
// model's virtual-temperature form, so that the two check each other.
double reference_density(double t_k, double phi, double p0) {
  const double m_d = 0.0289652, m_v = 0.018016, r = 8.314462618;
  const double e_sat = 611.2 * std::exp(17.67 * (t_k - 273.15) / (t_k - 29.65));
  return (p0 * m_d + phi * (m_v - m_d) * e_sat) / (r * t_k);
}
double reference_height(double p_h, double p0, double t_k, double phi = 0.4, double g = 9.81) {
  return -(p0 / (reference_density(t_k, phi, p0) * g)) * std::log(p_h / p0);
}

// Offsets, noise, rounding and weather off: the readings are the hypsometric equation alone.
const std::string kExact =
    "noise_sigma_pa: 0, resolution_pa: 0, offset_sigma_pa: 0, weather_walk_pa_10min: 0, "
    "temperature_noise_sigma_c: 0, temperature_offset_sigma_c: 0";

TEST(BaroModel, PressureGradientNearSeaLevelIsMinus11_8PaPerMetre) {
  // Reproduction target 1 of the reference: 293 K, 40 %, 101325 Pa, g = 9.81.
  // By hand: e_sat = 611.2 exp(17.67 * 19.85 / 263.35) = 2315.3 Pa, e = 0.4 e_sat = 926.1 Pa;
  // rho = (101325 * 0.0289652 - 926.1 * (0.0289652 - 0.018016)) / (8.314462618 * 293)
  //     = 2924.74 / 2436.14 = 1.20057 kg/m^3;  dp/dz = -rho g = -11.7776 Pa/m.
  EXPECT_NEAR(reference_density(293.0, 0.4, 101325.0), 1.20057, 1e-5);
  const auto r = run(scenario_text(
      "[{id: B0, position: [0, 0, 0]}, {id: B1, position: [3, 0, 1]}, "
      "{id: B10, position: [0, 5, 10]}]",
      "{" + kExact + ", temperature_c: 19.85, humidity_pct: 40, origin_pressure_pa: 101325}", 2));
  const double p0 = r.at("B0").front().pressure_pa;
  const double p1 = r.at("B1").front().pressure_pa;
  const double p10 = r.at("B10").front().pressure_pa;
  EXPECT_DOUBLE_EQ(p0, 101325.0);  // the origin pressure, at z = 0
  // Over 1 m the exponential differs from its tangent by 11.78 / (2 * 8603 m) = 0.0007 Pa.
  EXPECT_NEAR(p1 - p0, -11.7776, 0.002);
  EXPECT_NEAR((p10 - p0) / 10.0, -11.7776, 0.01);
  EXPECT_NEAR(p1 - p0, -11.8, 0.05);  // the "about -11.8 Pa/m"
  // And the reference's own inversion (2.2) gives the heights back.
  EXPECT_NEAR(reference_height(p1, p0, 293.0), 1.0, 1e-4);
  EXPECT_NEAR(reference_height(p10, p0, 293.0), 10.0, 1e-3);
  // The walking tag at 1.2 m reads what a station at 1.2 m would.
  const auto& tag = r.at("T1");
  ASSERT_FALSE(tag.empty());
  EXPECT_NEAR(reference_height(tag.front().pressure_pa, p0, 293.0), 1.2, 1e-4);
}

TEST(BaroModel, NoiseSigmaAndGivenOffsetAreRecovered) {
  // 10 Hz for 600 s: 6000 readings per sensor. The sample sigma's standard error is
  // 0.2 / sqrt(2 * 6000) = 0.0018 Pa, the mean's 0.2 / sqrt(6000) = 0.0026 Pa: 5-sigma tolerances.
  // Rounding to 0.016 Pa adds 0.016 / sqrt(12) = 0.005 Pa in quadrature (0.00006 Pa on sigma).
  const auto r =
      run(scenario_text("[{id: B0, position: [0, 0, 0]}, {id: B1, position: [0, 0, 2]}]",
                        "{weather_walk_pa_10min: 0, temperature_c: 19.85, offsets_pa: {B0: 31.5}, "
                        "temperature_noise_sigma_c: 0.1}",
                        600));
  for (const char* id : {"B0", "B1", "T1"}) {
    const auto p = pressures(r.at(id));
    ASSERT_NEAR(static_cast<double>(p.size()), 6000.0, 1.0) << id;
    EXPECT_NEAR(sigma_of(p), 0.2, 0.009) << id;
    std::vector<double> t;
    for (const auto& m : r.at(id)) t.push_back(m.temperature_c);
    EXPECT_NEAR(sigma_of(t), 0.1, 0.0046) << id;
    // Every reading is a multiple of the 0.016 Pa resolution.
    for (double x : p) ASSERT_NEAR(std::remainder(x, 0.016), 0.0, 1e-9) << id;
  }
  EXPECT_NEAR(mean_of(pressures(r.at("B0"))), 101325.0 + 31.5, 0.013);
}

TEST(BaroModel, OffsetsAreConstantPerSensorAndSpreadAsConfigured) {
  // 200 stations at z = 0, no noise or weather: each reading is 101325 Pa + the sensor's offset.
  // The 200 offsets' sample sigma has a standard error of 25 / sqrt(400) = 1.25 Pa, their mean
  // 25 / sqrt(200) = 1.8 Pa: tolerances of 4 standard errors. Temperatures likewise (0.5 C).
  std::string stations = "[";
  for (int i = 0; i < 200; ++i)
    stations +=
        (i ? ", " : "") + std::string("{id: S") + std::to_string(i) + ", position: [0, 0, 0]}";
  stations += "]";
  const auto r = run(scenario_text(stations,
                                   "{noise_sigma_pa: 0, resolution_pa: 0, offset_sigma_pa: 25, "
                                   "weather_walk_pa_10min: 0, temperature_noise_sigma_c: 0, "
                                   "temperature_offset_sigma_c: 0.5, rate_hz: 1, on_tags: false}",
                                   5));
  ASSERT_EQ(r.size(), 200u);
  std::vector<double> offsets, temperature_offsets;
  for (const auto& [id, readings] : r) {
    ASSERT_EQ(readings.size(), 5u) << id;
    for (const auto& m : readings) {
      EXPECT_EQ(m.pressure_pa, readings.front().pressure_pa) << id;  // constant
      EXPECT_EQ(m.temperature_c, readings.front().temperature_c) << id;
    }
    offsets.push_back(readings.front().pressure_pa - 101325.0);
    temperature_offsets.push_back(readings.front().temperature_c - 20.0);
  }
  EXPECT_NEAR(mean_of(offsets), 0.0, 7.2);
  EXPECT_NEAR(sigma_of(offsets), 25.0, 5.0);
  for (double o : offsets) EXPECT_LT(std::abs(o), 5 * 25.0);  // P(any of 200 beyond) ~ 1e-4
  EXPECT_NEAR(mean_of(temperature_offsets), 0.0, 0.144);
  EXPECT_NEAR(sigma_of(temperature_offsets), 0.5, 0.1);
}

TEST(BaroModel, WeatherDriftIsCommonSoCoLocatedSensorsDifferByNoiseAlone) {
  // Two stations side by side and a strong weather: a 20 Pa/h trend plus a 10 Pa / 10 min walk.
  // Each sensor wanders by tens of Pa over the hour; their difference keeps the noise of two
  // sensors, sqrt(2) * 0.2 = 0.283 Pa (36000 pairs: standard error 0.001 Pa), and no trend.
  // The two sample 50 ms apart, in which the weather moves by about 10 Pa * sqrt(0.05 / 600) =
  // 0.003 Pa: invisible here.
  const auto r = run(scenario_text(
      "[{id: B1, position: [0, 0, 1]}, {id: B2, position: [0.3, 0, 1]}]",
      "{resolution_pa: 0, weather_walk_pa_10min: 10, weather_trend_pa_per_h: 20, on_tags: false}",
      3600));
  const auto a = pressures(r.at("B1")), b = pressures(r.at("B2"));
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 36000u);
  std::vector<double> d(a.size());
  for (size_t i = 0; i < a.size(); ++i) d[i] = b[i] - a[i];
  EXPECT_NEAR(sigma_of(d), 0.283, 0.006);
  // The trend: the last 10 min minus the first 10 min, about 20 * 50 / 60 = 16.7 Pa for one sensor
  // (plus the walk's 10 * sqrt(5) = 22 Pa sigma), 0 +- 4 * 0.283 * sqrt(2 / 6000) = 0.02 Pa for
  // the difference.
  const auto first = [](const std::vector<double>& v) {
    return mean_of(std::vector<double>(v.begin(), v.begin() + 6000));
  };
  const auto last = [](const std::vector<double>& v) {
    return mean_of(std::vector<double>(v.end() - 6000, v.end()));
  };
  EXPECT_NEAR(last(d) - first(d), 0.0, 0.021);
  EXPECT_GT(sigma_of(a), 3.0);  // the weather is there, in each sensor
}

TEST(BaroModel, WeatherWalkAndTrendFollowTheirParameters) {
  // A station at the origin without offset or noise reads 101325 Pa + the weather. Random walk
  // alone: 1000 h at one reading per 100 s gives 6000 ten-minute changes, each N(0, 3 Pa); their
  // sample sigma has a standard error of 3 / sqrt(12000) = 0.027 Pa, their mean 3 / sqrt(6000) =
  // 0.039 Pa (5-sigma tolerances).
  const auto walk = pressures(run(scenario_text("[{id: B0, position: [0, 0, 0]}]",
                                                "{noise_sigma_pa: 0, resolution_pa: 0, "
                                                "offset_sigma_pa: 0, weather_walk_pa_10min: 3, "
                                                "rate_hz: 0.01, on_tags: false}",
                                                3.6e6))
                                  .at("B0"));
  ASSERT_EQ(walk.size(), 36000u);
  std::vector<double> changes;
  for (size_t i = 6; i < walk.size(); i += 6) changes.push_back(walk[i] - walk[i - 6]);
  EXPECT_NEAR(sigma_of(changes), 3.0, 0.14);
  EXPECT_NEAR(mean_of(changes), 0.0, 0.2);
  // Trend alone: exactly linear, -36 Pa/h.
  const auto trend = run(scenario_text("[{id: B0, position: [0, 0, 0]}]",
                                       "{noise_sigma_pa: 0, resolution_pa: 0, offset_sigma_pa: 0, "
                                       "weather_walk_pa_10min: 0, weather_trend_pa_per_h: -36, "
                                       "rate_hz: 0.01, on_tags: false}",
                                       36000))
                         .at("B0");
  ASSERT_EQ(trend.size(), 360u);
  for (const auto& m : trend)
    ASSERT_NEAR(m.pressure_pa, 101325.0 - 0.01 * utime_to_s(m.utime - kStart), 1e-6);
}

TEST(BaroModel, ReferenceStationsCarryTheirKnownHeightAndTagsDoNot) {
  const auto r = run(scenario_text("[{id: B1, position: [1, 2, 2.4]}]", "{}", 1));
  ASSERT_EQ(r.size(), 2u);
  for (const auto& m : r.at("B1")) {
    EXPECT_TRUE(m.is_reference);
    EXPECT_EQ(m.known_height_m, 2.4);
    EXPECT_EQ(m.source, kSimSource);
    EXPECT_TRUE(std::isnan(m.humidity_pct));  // not configured: unmeasured
    EXPECT_TRUE(std::isfinite(m.temperature_c));
  }
  ASSERT_EQ(r.at("T1").size(), 10u);  // 10 Hz by default
  for (const auto& m : r.at("T1")) {
    EXPECT_FALSE(m.is_reference);
    EXPECT_TRUE(std::isnan(m.known_height_m));
    EXPECT_TRUE(std::isnan(m.humidity_pct));
  }
  // Humidity when configured: the air's plus noise (1000 readings: mean 0.16 % standard error).
  const auto h = run(scenario_text("[]",
                                   "{humidity_reported: true, humidity_pct: 55, "
                                   "humidity_noise_sigma_pct: 5, rate_hz: 100}",
                                   10));
  std::vector<double> hum;
  for (const auto& m : h.at("T1")) hum.push_back(m.humidity_pct);
  ASSERT_EQ(hum.size(), 1000u);
  EXPECT_NEAR(mean_of(hum), 55.0, 0.7);
  EXPECT_NEAR(sigma_of(hum), 5.0, 0.5);
}

TEST(BaroModel, TenDegreesChangeTheHeightOfA2mDifferenceByAbout7cm) {
  // Reference section 2.2: a 2 m difference read with T wrong by 10 C is off by about 7 cm (3.5 %).
  // Here the air is at 10, 20 or 30 C, the sensors 2 m apart, and the height is computed from
  // their pressures with (2.2) at an assumed 20 C, as an estimator that ignores the temperature
  // would. By hand: h = 2 m * T_v(20 C) / T_v(air), with T_v = T / (1 - 0.378 e / p):
  // 2 * (293.15 * 1.00349) / (283.15 * 1.00183) = 2.0741 m, and at 30 C 1.9285 m.
  std::map<int, double> implied, with_measured_t;
  for (int t_c : {10, 20, 30}) {
    const auto r =
        run(scenario_text("[{id: B0, position: [0, 0, 0.4]}, {id: B2, position: [0, 0, 2.4]}]",
                          "{" + kExact + ", temperature_c: " + std::to_string(t_c) + "}", 1));
    const baro_t& low = r.at("B0").front();
    const baro_t& high = r.at("B2").front();
    implied[t_c] = reference_height(high.pressure_pa, low.pressure_pa, 293.15);
    with_measured_t[t_c] =
        reference_height(high.pressure_pa, low.pressure_pa, high.temperature_c + 273.15);
  }
  EXPECT_NEAR(implied[20], 2.0, 1e-3);
  EXPECT_NEAR(implied[10], 2.0741, 1e-3);
  EXPECT_NEAR(implied[30], 1.9285, 1e-3);
  EXPECT_NEAR(implied[10] - implied[20], 0.07, 0.005);  // "about 7 cm per 10 C"
  // With the reference station's own temperature reading the height comes back.
  for (const auto& [t_c, h] : with_measured_t) EXPECT_NEAR(h, 2.0, 1e-3) << t_c;
}

TEST(BaroStepsScenario, TagHeightStepsShowInTheDifferenceToTheReference) {
  // The built-in baro-steps: 1.82, 1.57, 1.32, 1.07, 0.82 m, 3 min each; reference B1 at 2.4 m;
  // the tag's sensor 25 Pa above the reference's. Over the middle 165 s of each step (1650
  // readings each) the mean of p_T - p_B has a standard error of 0.283 / sqrt(1650) = 0.007 Pa
  // (the weather cancels); each 0.25 m step lowers the tag and raises the difference by
  // rho g 0.25 m = 2.944 Pa (rho = 1.2006 kg/m^3, target 1 of 003).
  Scenario sc = load_scenario("baro-steps");
  std::erase_if(sc.sensors,
                [](const SensorSection& s) { return std::string(s.model->name) != "baro"; });
  const auto r = run(sc, 5);
  ASSERT_EQ(r.size(), 2u);
  const auto& tag = r.at("T1");
  const auto& ref = r.at("B1");
  ASSERT_EQ(tag.size(), ref.size());
  EXPECT_TRUE(ref.front().is_reference);
  EXPECT_EQ(ref.front().known_height_m, 2.4);
  const double heights[] = {1.82, 1.57, 1.32, 1.07, 0.82};
  double previous = 0;
  for (int step = 0; step < 5; ++step) {
    const double from_s = step * 185.0 + 10, to_s = from_s + 165;  // steps start at 0, 185, ...
    std::vector<double> d, p_tag, p_ref;
    for (size_t i = 0; i < tag.size(); ++i) {
      const double t = utime_to_s(tag[i].utime - kStart);
      if (t < from_s || t >= to_s) continue;
      d.push_back(tag[i].pressure_pa - ref[i].pressure_pa);
      p_tag.push_back(tag[i].pressure_pa - 25.0);  // the known offset, calibrated out
      p_ref.push_back(ref[i].pressure_pa);
    }
    ASSERT_NEAR(static_cast<double>(d.size()), 1650.0, 1.0);
    if (step) {
      EXPECT_NEAR(mean_of(d) - previous, 2.944, 0.04) << step;
    }
    previous = mean_of(d);
    // The reference's (2.2) from the reference station's height recovers the tag's height.
    const double z = 2.4 + reference_height(mean_of(p_tag), mean_of(p_ref), 293.0);
    EXPECT_NEAR(z, heights[step], 0.01) << step;
  }
}

TEST(BaroModel, SameSeedSameBytesAndSeedsDiffer) {
  const Scenario sc = parse_scenario_text(
      scenario_text("[{id: B1, position: [0, 0, 2.4]}]", "{}", 30), "test.yaml");
  const auto bytes = [&](uint64_t seed) {
    Simulator sim(sc, seed, kStart);
    std::vector<std::vector<uint8_t>> out;
    SimEvent e;
    while (sim.next(e))
      if (e.kind == "BARO") out.push_back(e.data);
    return out;
  };
  const auto a = bytes(7), b = bytes(7), c = bytes(8);
  ASSERT_EQ(a.size(), 600u);
  EXPECT_EQ(a, b);
  size_t differing = 0;
  for (size_t i = 0; i < a.size(); ++i) differing += a[i] != c[i];
  EXPECT_GT(differing, 590u);
}

TEST(BaroModel, BadParametersGiveExactErrors) {
  const auto error = [](const std::string& baro) {
    try {
      parse_scenario_text(scenario_text("[{id: B1, position: [0, 0, 2.4]}]", baro, 10), "my.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  // The baro section is on line 13.
  EXPECT_EQ(error("{noise_sigma_pa: -0.2}"),
            "my.yaml:13: sensors.baro.noise_sigma_pa: must be in [0, 1000]");
  EXPECT_EQ(error("{origin_pressure_pa: 1013.25}"),
            "my.yaml:13: sensors.baro.origin_pressure_pa: must be in [30000, 125000]");
  EXPECT_EQ(
      error("{offsets_pa: {T9: 3}}"),
      "my.yaml:13: sensors.baro.offsets_pa.T9: no barometer has this id (barometers: T1, B1)");
  EXPECT_EQ(error("{offsets_pa: {B1: lots}}"),
            "my.yaml:13: sensors.baro.offsets_pa.B1: expected a number, got 'lots'");
  EXPECT_EQ(error("{offsets_pa: [3]}"),
            "my.yaml:13: sensors.baro.offsets_pa: expected a map of sensor id: Pa");
  EXPECT_EQ(error("{noise_pa: 0.2}")
                .rfind("my.yaml:13: sensors.baro.noise_pa: unknown field (known: ", 0),
            0u);
  // A station named like a tag would make sensor_id ambiguous.
  try {
    parse_scenario_text(scenario_text("[{id: T1, position: [0, 0, 2.4]}]", "{}", 10), "my.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(),
                 "my.yaml:13: sensors.baro: baro station 'T1' has the id of a tag: BARO sensor ids "
                 "must be unique");
  }
}

}  // namespace
}  // namespace ips::sim
