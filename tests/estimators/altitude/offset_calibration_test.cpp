// OffsetCalibration on synthetic captures (003_baro.md section 2.4): exact offsets under a
// weather change, the settling window, a sensor at a known height, the choice of reference,
// and writing the offsets into the site.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/barometric.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/altitude/offset_calibration.hpp"

namespace ips::altitude {
namespace {

constexpr utime_t kT0 = 1767225600000000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

baro_t reading(const std::string& id, utime_t t, double p, bool ref = false,
               double known_h = kNaN) {
  baro_t m;
  m.utime = t;
  m.source = "test";
  m.sensor_id = id;
  m.pressure_pa = p;
  m.temperature_c = 21.0;
  m.humidity_pct = kNaN;
  m.is_reference = ref;
  m.known_height_m = known_h;
  return m;
}

// 12 min at 10 Hz: the weather falls 6 Pa; T1 reads 25 Pa high with a 10 Pa warm-up decaying
// over 30 s, T2 2 Pa low; a reference at 2.4 m. Readings of one second interleaved.
void capture(OffsetCalibration& cal, double t2_height_m = kNaN) {
  const double k = barometric::inverse_scale_height_per_m(21.0, 50, 100900.0, 9.81);
  for (int i = 0; i < 7200; ++i) {
    const double t_s = 0.1 * i;
    const double weather = 100900.0 - 6.0 * t_s / 720.0;
    const utime_t t = kT0 + s_to_utime(t_s);
    cal.on_baro(reading("B1", t, weather, true, 2.4));
    const double weather_t1 = 100900.0 - 6.0 * (t_s + 0.03) / 720.0;
    cal.on_baro(reading("T1", t + 30000, weather_t1 + 25.0 + 10.0 * std::exp(-t_s / 30.0)));
    const double weather_t2 = 100900.0 - 6.0 * (t_s + 0.06) / 720.0;
    const double at_t2 = std::isnan(t2_height_m)
                             ? weather_t2
                             : barometric::pressure_above_pa(weather_t2, t2_height_m - 2.4, k);
    cal.on_baro(reading("T2", t + 60000, at_t2 - 2.0));
  }
}

TEST(OffsetCalibration, OffsetsOfEverySensorAfterSettling) {
  OffsetCalibration cal({});
  capture(cal);
  const auto offsets = cal.finish();
  EXPECT_EQ(cal.reference_id(), "B1");
  ASSERT_EQ(offsets.size(), 2u);
  EXPECT_EQ(offsets[0].sensor_id, "T1");
  EXPECT_EQ(offsets[0].readings, 7200);
  EXPECT_EQ(offsets[0].used, 5400);  // from 180.03 s on
  EXPECT_NEAR(offsets[0].window_start_s, 180.03, 1e-9);  // T1's first reading + 180 s
  // The warm-up is 10 exp(-6) = 0.025 Pa at 180 s: the mean of what is left is tiny.
  EXPECT_NEAR(offsets[0].offset_pa, 25.0, 0.002);
  EXPECT_NEAR(offsets[0].sigma_pa, 0.0, 0.005);
  EXPECT_NEAR(offsets[1].offset_pa, -2.0, 1e-6);
  EXPECT_NEAR(offsets[1].offset_height_m, 0.17, 0.005);  // reads low: it would seem higher
  EXPECT_NEAR(offsets[1].drift_pa_per_min, 0.0, 1e-6);
}

TEST(OffsetCalibration, WithoutSettlingTheWarmUpBiasesTheOffset) {
  OffsetCalibrationOptions o;
  o.settle_s = 0;
  OffsetCalibration cal(o);
  capture(cal);
  const auto offsets = cal.finish();
  // 10 Pa * 30 s / 720 s of warm-up in the mean; and a drift over the window.
  EXPECT_NEAR(offsets[0].offset_pa, 25.0 + 10.0 * 30.0 / 720.0, 0.01);
  EXPECT_LT(offsets[0].drift_pa_per_min, -0.01);
}

TEST(OffsetCalibration, ASpanLimitsTheWindow) {
  OffsetCalibrationOptions o;
  o.span_s = 60;
  OffsetCalibration cal(o);
  capture(cal);
  EXPECT_EQ(cal.finish()[1].used, 601);
}

TEST(OffsetCalibration, ASensorAtAKnownHeightIsNotChargedTheHeightDifference) {
  OffsetCalibrationOptions o;
  o.heights_m["T2"] = 0.82;
  OffsetCalibration cal(o);
  capture(cal, 0.82);
  const auto offsets = cal.finish();
  EXPECT_NEAR(offsets[1].offset_pa, -2.0, 1e-3);
  // 1.58 m below the reference, at 11.67 Pa/m (21 C, 50 %, 100.9 kPa).
  EXPECT_NEAR(offsets[1].expected_difference_pa, 18.436, 0.01);
}

TEST(OffsetCalibration, TheReferenceMustBeClear) {
  {
    OffsetCalibration cal({});
    cal.on_baro(reading("T1", kT0, 100000.0));
    EXPECT_THROW(
        {
          try {
            cal.finish();
          } catch (const OffsetCalibrationError& e) {
            EXPECT_NE(std::string(e.what()).find("no reference station in the log"),
                      std::string::npos);
            throw;
          }
        },
        OffsetCalibrationError);
  }
  {
    OffsetCalibration cal({});
    cal.on_baro(reading("B1", kT0, 100000.0, true, 2.4));
    cal.on_baro(reading("B2", kT0, 100000.0, true, 2.4));
    try {
      cal.finish();
      ADD_FAILURE() << "no error";
    } catch (const OffsetCalibrationError& e) {
      EXPECT_STREQ(e.what(), "several reference stations in the log (B1, B2): choose one with "
                             "--reference ID");
    }
  }
  {
    OffsetCalibrationOptions o;
    o.reference = "B9";
    OffsetCalibration cal(o);
    cal.on_baro(reading("B1", kT0, 100000.0, true, 2.4));
    try {
      cal.finish();
      ADD_FAILURE() << "no error";
    } catch (const OffsetCalibrationError& e) {
      EXPECT_STREQ(e.what(), "reference 'B9' has no reading in the log (sensors heard: B1)");
    }
  }
  {
    // Any sensor can be named the reference (two tag sensors side by side).
    OffsetCalibrationOptions o;
    o.reference = "T2";
    o.settle_s = 0;
    OffsetCalibration cal(o);
    capture(cal);
    const auto offsets = cal.finish();
    ASSERT_EQ(offsets.size(), 2u);
    EXPECT_EQ(offsets[0].sensor_id, "B1");
    EXPECT_NEAR(offsets[0].offset_pa, 2.0, 1e-6);
  }
}

TEST(OffsetCalibration, BadReadingsAreCounted) {
  OffsetCalibration cal({});
  cal.on_baro(reading("T1", kT0, 0.0));
  cal.on_baro(reading("T1", kT0, kNaN));
  cal.on_baro(reading("", kT0, 100000.0));
  cal.on_baro(reading("T1", kT0, 100000.0));
  cal.on_baro(reading("T1", kT0, 100000.0));
  EXPECT_EQ(cal.dropped(), 4);
}

TEST(OffsetCalibration, TheOffsetsGoIntoTheSiteAndBackIntoTheEstimator) {
  const Site site = parse_site_text(
      "name: s\nanchors: []\nbaro_stations: [{id: B1, position: [0, 0, 2.4]}]\n"
      "tags: [{id: T1}]\nestimators:\n  altitude: {gate_sigma: 4, offsets_pa: {T9: 1.5}}\n"
      "  pdr: {step_k: 0.5}\n",
      "in");
  SensorOffset t1;
  t1.sensor_id = "T1";
  t1.used = 10;
  t1.offset_pa = 24.98765;
  SensorOffset t2;
  t2.sensor_id = "T2";  // nothing in its window: left out
  const std::string text = site_with_offsets(site, {t1, t2}, {"calibrated", "second line"});
  EXPECT_EQ(text.rfind("# calibrated\n# second line\n", 0), 0u) << text;
  const Site back = parse_site_text(text, "out");
  const AltitudeParams p = parse_altitude_params(back.estimator_params("altitude"));
  EXPECT_EQ(p.offsets_pa.size(), 2u);
  EXPECT_DOUBLE_EQ(p.offsets_pa.at("T1"), 24.988);
  EXPECT_DOUBLE_EQ(p.offsets_pa.at("T9"), 1.5);
  EXPECT_EQ(p.gate_sigma, 4.0);
  EXPECT_EQ(back.estimator_params("pdr").get_double("step_k", 0), 0.5);
  // A site whose estimators is not a map cannot take them.
  Site odd = site;
  odd.yaml_text = "name: s\nestimators: [1]\n";
  EXPECT_THROW(site_with_offsets(odd, {t1}, {}), ConfigError);
}

}  // namespace
}  // namespace ips::altitude
