// AltitudeEstimator on synthetic readings made with the hypsometric equation
// (core/barometric.hpp): exact heights, time alignment with the reference, a stale or missing
// reference, offsets, temperature, floors, gating, bad input and parameters.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "core/barometric.hpp"
#include "estimators/altitude/altitude_estimator.hpp"

namespace ips::altitude {
namespace {

namespace b = barometric;
constexpr utime_t kT0 = 1767225600000000;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Site site_with(const std::string& altitude_yaml = "") {
  return parse_site_text(
      "name: t\n"
      "anchors: [{id: A1, kind: uwb_tdoa, position: [0, 0, 2.4]}]\n"
      "baro_stations: [{id: B1, position: [0, 0, 2.4]}, {id: B2, position: [5, 0, 0.5]}]\n"
      "tags: [{id: T1}]\n" +
          (altitude_yaml.empty() ? std::string() : "estimators:\n  altitude: " + altitude_yaml + "\n"),
      "test site");
}

baro_t reading(const std::string& id, utime_t t, double p, double tc = 21.0, bool ref = false,
               double known_h = kNaN) {
  baro_t m;
  m.utime = t;
  m.source = "test";
  m.sensor_id = id;
  m.pressure_pa = p;
  m.temperature_c = tc;
  m.humidity_pct = kNaN;
  m.is_reference = ref;
  m.known_height_m = known_h;
  return m;
}

// The air of the tests: 21 C, 50 % (the estimator's default humidity).
struct Air {
  double tc = 21.0;
  double k(double p_ref) const { return b::inverse_scale_height_per_m(tc, 50, p_ref, 9.81); }
  double at(double p_ref, double h_ref, double h) const {
    return b::pressure_above_pa(p_ref, h - h_ref, k(p_ref));
  }
};

struct Fixture {
  std::vector<altitude_t> out;
  AltitudeEstimator est{[this](const altitude_t& a) { out.push_back(a); }};
};

utime_t ms(int64_t v) { return v * 1000; }

TEST(AltitudeEstimator, ExactReadingsGiveTheExactHeight) {
  Fixture f;
  f.est.set_site(site_with());
  Air air;
  // 10 Hz each, the tag 40 ms after the reference; the weather falls 1 Pa per minute.
  for (int i = 0; i < 100; ++i) {
    const double p_ref = 100900.0 - i * 0.1 / 60.0;
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), p_ref, 21.0, true, 2.4));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 40), air.at(p_ref, 2.4, 1.07), 25.0));
  }
  ASSERT_GE(f.out.size(), 98u);
  const altitude_t& a = f.out.back();
  EXPECT_EQ(a.tag_id, "T1");
  EXPECT_EQ(a.source, "altitude");
  EXPECT_EQ(a.utime, kT0 + ms(9840));  // the last waits for the next reference reading
  EXPECT_NEAR(a.height_m, 1.07, 2e-3);
  EXPECT_NEAR(a.vertical_speed_mps, 0.0, 5e-3);
  EXPECT_GT(a.height_std_m, 0.0);
  EXPECT_LT(a.height_std_m, 0.04);  // pressure_sigma_pa 0.5 is 4.2 cm per reading
  EXPECT_FALSE(a.floor_valid);
  EXPECT_EQ(f.est.stats().used, static_cast<int64_t>(f.out.size()));
}

TEST(AltitudeEstimator, TheReferenceIsInterpolatedToTheTagsTime) {
  // A fast pressure ramp (10 Pa/s, a door or the ventilation): holding the reference's previous
  // reading for 90 ms would put the tag 0.9 Pa, about 8 cm, too low.
  Fixture f;
  f.est.set_site(site_with("{accel_sigma_mps2: 0.01}"));
  Air air;
  for (int i = 0; i < 60; ++i) {
    const utime_t t = kT0 + ms(100 * i);
    f.est.on_baro(reading("B1", t, 100900.0 + 10.0 * 0.1 * i, 21.0, true, 2.4));
    const double p_ref_at_tag = 100900.0 + 10.0 * (0.1 * i + 0.09);
    f.est.on_baro(reading("T1", t + ms(90), air.at(p_ref_at_tag, 2.4, 1.0)));
  }
  ASSERT_FALSE(f.out.empty());
  for (size_t i = 10; i < f.out.size(); ++i) EXPECT_NEAR(f.out[i].height_m, 1.0, 3e-3) << i;
}

TEST(AltitudeEstimator, ATagReadingWaitsForTheReferenceThenForAtMostAlignWait) {
  Fixture f;
  f.est.set_site(site_with("{align_wait_s: 0.5}"));
  Air air;
  f.est.on_baro(reading("B1", kT0, 100900.0, 21.0, true, 2.4));
  f.est.on_baro(reading("T1", kT0 + ms(50), air.at(100900.0, 2.4, 1.0)));
  EXPECT_TRUE(f.out.empty());  // waits for B1's next reading
  f.est.on_baro(reading("B1", kT0 + ms(100), 100900.0, 21.0, true, 2.4));
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.out[0].utime, kT0 + ms(50));
  // B1 falls silent: T1's readings are used once 0.5 s of message time has passed, on the held
  // reading.
  f.est.on_baro(reading("T1", kT0 + ms(150), air.at(100900.0, 2.4, 1.0)));
  f.est.on_baro(reading("T1", kT0 + ms(600), air.at(100900.0, 2.4, 1.0)));
  EXPECT_EQ(f.out.size(), 1u);
  f.est.on_baro(reading("T1", kT0 + ms(700), air.at(100900.0, 2.4, 1.0)));
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.out[1].utime, kT0 + ms(150));
  f.est.finish();  // the end of a log: the rest on the held reading
  EXPECT_EQ(f.out.size(), 4u);
}

TEST(AltitudeEstimator, AStaleReferenceIsDetectedReportedAndRecoveredFrom) {
  Fixture f;
  f.est.set_site(site_with("{max_reference_age_s: 2, align_wait_s: 0.2}"));
  Air air;
  auto second = [&](int s, bool with_ref) {
    for (int i = 0; i < 10; ++i) {
      const utime_t t = kT0 + ms(1000 * s + 100 * i);
      if (with_ref) f.est.on_baro(reading("B1", t, 100900.0, 21.0, true, 2.4));
      f.est.on_baro(reading("T1", t + ms(30), air.at(100900.0, 2.4, 1.3)));
    }
  };
  for (int s = 0; s < 3; ++s) second(s, true);
  const size_t before = f.out.size();
  EXPECT_TRUE(f.est.take_problem().empty());
  for (int s = 3; s < 8; ++s) second(s, false);
  // Held up to 2 s after B1's last reading (2.9 s): T1's readings at 2.93 and 3.03 to 4.83 s;
  // then stale.
  EXPECT_EQ(f.out.size(), before + 20);
  EXPECT_GT(f.est.stats().dropped_stale_reference, 20);
  const std::string problem = f.est.take_problem();
  EXPECT_NE(problem.find("reference B1 stale: its newest reading is"), std::string::npos) << problem;
  EXPECT_NE(problem.find("older than T1's"), std::string::npos) << problem;
  const int64_t stale = f.est.stats().dropped_stale_reference;
  for (int s = 8; s < 10; ++s) second(s, true);
  EXPECT_LE(f.est.stats().dropped_stale_reference, stale + 1);  // the reading just before B1 is back
  EXPECT_NEAR(f.out.back().height_m, 1.3, 5e-3);
  EXPECT_EQ(f.out.back().utime, kT0 + ms(9930 - 100));
}

TEST(AltitudeEstimator, NoReferenceAtAllIsCountedAndSaid) {
  Fixture f;
  f.est.set_site(site_with("{align_wait_s: 0.1}"));
  for (int i = 0; i < 5; ++i) f.est.on_baro(reading("T1", kT0 + ms(100 * i), 100000.0));
  EXPECT_TRUE(f.out.empty());
  EXPECT_EQ(f.est.stats().dropped_no_reference, 4);  // the last one still waits
  EXPECT_EQ(f.est.take_problem(), "no reference barometer heard yet: no altitude for T1");
}

TEST(AltitudeEstimator, TheStationHeightComesFromTheSiteWhenTheReadingLacksIt) {
  Fixture f;
  f.est.set_site(site_with());
  Air air;
  for (int i = 0; i < 30; ++i) {
    f.est.on_baro(reading("B2", kT0 + ms(100 * i), 101000.0, 21.0, true));  // site: z = 0.5
    f.est.on_baro(reading("X9", kT0 + ms(100 * i + 1), 101000.0, 21.0, true));  // unknown
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), air.at(101000.0, 0.5, 3.0)));
  }
  ASSERT_FALSE(f.out.empty());
  EXPECT_NEAR(f.out.back().height_m, 3.0, 2e-3);
  EXPECT_EQ(f.est.stats().dropped_reference_without_height, 30);
}

TEST(AltitudeEstimator, CalibratedOffsetsAreSubtracted) {
  // T1 reads 25 Pa high, B1 3 Pa low: 003 (5.2) for both.
  Fixture f;
  f.est.set_site(site_with("{offsets_pa: {T1: 25.0, B1: -3.0}}"));
  Air air;
  for (int i = 0; i < 50; ++i) {
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0 - 3.0, 21.0, true, 2.4));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), air.at(100900.0, 2.4, 0.82) + 25.0));
  }
  EXPECT_NEAR(f.out.back().height_m, 0.82, 2e-3);
}

TEST(AltitudeEstimator, TheReferencesTemperatureIsUsedAndTenDegreesOffIsSevenCentimetres) {
  // 003 section 2.2: a 2 m difference read with the air 10 C off its true temperature is about
  // 7 cm wrong. The air is 29.85 C at 40 %; the tag stands 2 m below the reference.
  auto final_height = [](double reference_temperature_c) {
    Fixture f;
    f.est.set_site(site_with("{temperature_c: 19.85, humidity_pct: 40}"));
    const double k = b::inverse_scale_height_per_m(29.85, 40, 100900.0, 9.81);
    for (int i = 0; i < 50; ++i) {
      f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, reference_temperature_c, true, 2.4));
      f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50),
                            b::pressure_above_pa(100900.0, -2.0, k), kNaN));
    }
    return f.out.back().height_m;
  };
  EXPECT_NEAR(final_height(29.85), 0.4, 2e-3);
  // Unknown temperature: the site's 19.85 C. 2 m comes out as 2 T_v(293 K) / T_v(303 K) =
  // 1.9285 m (the virtual temperatures at 40 %: 294.02 and 304.92 K).
  const double off = final_height(kNaN);
  EXPECT_NEAR(2.4 - off, 1.9285, 2e-3);
  EXPECT_NEAR(off - 0.4, 0.0715, 2e-3);
}

TEST(AltitudeEstimator, FloorsFromTheSiteWithDwell) {
  Fixture f;
  f.est.set_site(site_with(
      "{floors: {heights_m: [-3.0, 0.0, 3.5, 7.0], first_index: -1, carry_height_m: 1.0, "
      "dwell_s: 2.0}, accel_sigma_mps2: 2.0}"));
  Air air;
  // 10 s on floor 0 (h = 1.0), a lift up 3.5 m at 1 m/s, 10 s on floor 1.
  double h = 1.0;
  std::vector<std::pair<double, int>> floors;  // time s, floor
  for (int i = 0; i < 250; ++i) {
    const double t = 0.1 * i;
    if (t >= 10.0 && t < 13.5) h = 1.0 + (t - 10.0);
    if (t >= 13.5) h = 4.5;
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, 21.0, true, 2.4));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), air.at(100900.0, 2.4, h)));
    if (!f.out.empty() && f.out.back().floor_valid)
      floors.emplace_back(utime_to_s(f.out.back().utime - kT0), f.out.back().floor);
  }
  ASSERT_FALSE(floors.empty());
  EXPECT_EQ(floors.front().second, 0);
  EXPECT_EQ(floors.back().second, 1);
  // Floor 1 is nearest from h = 3.25 + ... (halfway: 1.0 + 1.75 = 2.75 m, at t = 11.75 s), then
  // 2 s of dwell.
  double changed = -1;
  for (const auto& [t, fl] : floors)
    if (fl == 1 && changed < 0) changed = t;
  EXPECT_NEAR(changed, 13.75, 0.3);
  for (const auto& [t, fl] : floors) EXPECT_TRUE(fl == 0 || fl == 1) << t;
}

TEST(AltitudeEstimator, AJumpIsGatedThenTakenAfterMaxRejections) {
  Fixture f;
  f.est.set_site(site_with("{max_rejections: 5, gate_sigma: 5}"));
  Air air;
  for (int i = 0; i < 40; ++i) {
    const double h = i < 20 ? 1.0 : 4.0;  // 3 m in 0.1 s: no tag moves so
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, 21.0, true, 2.4));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), air.at(100900.0, 2.4, h)));
  }
  EXPECT_EQ(f.est.stats().rejected, 5);  // the fifth restarts the track
  EXPECT_EQ(f.est.stats().restarts, 1);
  EXPECT_NEAR(f.out.back().height_m, 4.0, 2e-3);
}

TEST(AltitudeEstimator, ThePreferredReferenceAndTheFallback) {
  Fixture f;
  f.est.set_site(site_with("{reference: B2, max_reference_age_s: 1, align_wait_s: 0.2}"));
  Air air;
  for (int i = 0; i < 60; ++i) {
    const utime_t t = kT0 + ms(100 * i);
    f.est.on_baro(reading("B1", t, 100900.0, 21.0, true, 2.4));
    if (i < 20) f.est.on_baro(reading("B2", t + ms(10), air.at(100900.0, 2.4, 0.5), 21.0, true));
    f.est.on_baro(reading("T1", t + ms(50), air.at(100900.0, 2.4, 1.5)));
  }
  EXPECT_EQ(f.est.stats().reference_switches, 1);  // B2 -> B1 when B2 went stale
  EXPECT_EQ(f.est.stats().dropped_stale_reference, 0);
  EXPECT_NEAR(f.out.back().height_m, 1.5, 2e-3);
}

TEST(AltitudeEstimator, BadReadingsAreCountedNeverUsed) {
  Fixture f;
  f.est.on_baro(reading("T1", kT0, 100000.0));
  EXPECT_EQ(f.est.stats().dropped_no_site, 1);
  f.est.set_site(site_with());
  const double bad_pressures[] = {0.0, -5.0, kNaN, std::numeric_limits<double>::infinity(),
                                  29999.0, 125001.0};
  for (double p : bad_pressures) f.est.on_baro(reading("T1", kT0, p));
  f.est.on_baro(reading("T1", kT0, 100000.0, 150.0));  // temperature
  baro_t wet = reading("T1", kT0, 100000.0);
  wet.humidity_pct = 101.0;
  f.est.on_baro(wet);
  f.est.on_baro(reading("", kT0, 100000.0));
  f.est.on_baro(reading("T1", -1, 100000.0));
  EXPECT_EQ(f.est.stats().dropped_invalid, 10);
  f.est.on_baro(reading("T1", kT0 + 10, 100000.0));
  f.est.on_baro(reading("T1", kT0 + 10, 100000.1));  // the same stamp: spread, not dropped
  f.est.on_baro(reading("T1", kT0 + 5, 100000.0));
  EXPECT_EQ(f.est.stats().dropped_out_of_order, 1);
  EXPECT_EQ(f.est.stats().retimed, 1);
  EXPECT_EQ(f.est.stats().dropped_duplicate, 0);
  EXPECT_TRUE(f.out.empty());
}

// A LAN repeats datagrams: the previous reading again (its stamp and values) is a copy, counted as
// a duplicate (routine), not a second reading spread at the sensor's rate. Every reading delivered
// twice gives the altitudes of every reading once.
TEST(AltitudeEstimator, ACopiedReadingIsADuplicateNotASecondReading) {
  Fixture once, twice;
  once.est.set_site(site_with());
  twice.est.set_site(site_with());
  Air air;
  int copies = 0;
  for (int i = 0; i < 100; ++i) {
    const utime_t t = kT0 + ms(100 * i);
    const baro_t ref = reading("B1", t, 100900.0 - i * 0.01, 21.0, true, 2.4);
    const baro_t tag = reading("T1", t + ms(40), air.at(100900.0 - i * 0.01, 2.4, 1.0 + 0.001 * i));
    for (const baro_t& m : {ref, tag}) {
      once.est.on_baro(m);
      twice.est.on_baro(m);
      twice.est.on_baro(m);
      ++copies;
    }
  }
  once.est.finish();
  twice.est.finish();
  EXPECT_EQ(twice.est.stats().dropped_duplicate, copies);
  EXPECT_EQ(twice.est.drop_reasons().count(DropReason::kDuplicate), copies);
  EXPECT_EQ(twice.est.stats().retimed, 0);
  EXPECT_EQ(once.est.stats().dropped_duplicate, 0);
  ASSERT_GT(once.out.size(), 90u);
  ASSERT_EQ(twice.out.size(), once.out.size());
  for (size_t k = 0; k < once.out.size(); ++k) {
    EXPECT_EQ(twice.out[k].utime, once.out[k].utime) << k;
    EXPECT_EQ(twice.out[k].height_m, once.out[k].height_m) << k;
  }
}

TEST(AltitudeEstimator, TagsAndStationsAreBoundedByMaxTags) {
  Fixture f;
  f.est.set_site(site_with("{max_tags: 2}"));
  for (int i = 0; i < 4; ++i) f.est.on_baro(reading("T" + std::to_string(i), kT0, 100000.0));
  EXPECT_EQ(f.est.stats().dropped_too_many_tags, 2);
}

TEST(AltitudeEstimator, PublishPeriodThinsTheOutput) {
  Fixture f;
  f.est.set_site(site_with("{publish_period_s: 1.0}"));
  Air air;
  for (int i = 0; i < 100; ++i) {
    f.est.on_baro(reading("B1", kT0 + ms(100 * i), 100900.0, 21.0, true, 2.4));
    f.est.on_baro(reading("T1", kT0 + ms(100 * i + 50), air.at(100900.0, 2.4, 1.0)));
  }
  EXPECT_EQ(f.out.size(), 10u);
  EXPECT_EQ(f.est.stats().used, 99);
}

TEST(AltitudeParams, BadValuesNameTheField) {
  auto error_of = [](const std::string& yaml) {
    try {
      parse_altitude_params(site_with(yaml).estimator_params("altitude"));
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("{humidity_pct: 120}").find("estimators.altitude.humidity_pct: must be in [0, 100]"),
            std::string::npos)
      << error_of("{humidity_pct: 120}");
  EXPECT_NE(error_of("{offsets_pa: {T1: 1e6}}").find("estimators.altitude.offsets_pa.T1"),
            std::string::npos);
  EXPECT_NE(error_of("{offsets_pa: [1, 2]}").find("expected a map of sensor id: Pa"),
            std::string::npos);
  EXPECT_NE(error_of("{floors: {heights_m: [0, 3, 2]}}").find("floor heights must be ascending"),
            std::string::npos);
  EXPECT_NE(error_of("{floors: {first_index: 0}}").find("heights_m"), std::string::npos);
  EXPECT_NE(error_of("{presure_sigma_pa: 1}").find("presure_sigma_pa"), std::string::npos);
  EXPECT_NE(error_of("{max_rejections: 0}").find("max_rejections: must be in [1, 1000000]"),
            std::string::npos);
  EXPECT_EQ(error_of("{reference: B1, gate_sigma: 4}"), "no error");
  // A bad site leaves the estimator with its previous one.
  Fixture f;
  f.est.set_site(site_with("{gate_sigma: 4}"));
  EXPECT_THROW(f.est.set_site(site_with("{gate_sigma: 0}")), ConfigError);
  EXPECT_EQ(f.est.params().gate_sigma, 4.0);
}

}  // namespace
}  // namespace ips::altitude
