// ips-aoa-calibrate's fit on the simulator: aoa-hall-calibration (five tags standing at the
// hall's surveyed points, docs/scenarios/aoa-hall.md) recovers each anchor's injected or drawn
// bias, and the calibration carries over to the walk in aoa-hall with the same seed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "drivers/sim/scenario.hpp"
#include "drivers/sim/sensor_model.hpp"
#include "estimators/aoa/calibration_fit.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::aoa {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Table 7.2's five tag points (source 000 section 5), z as surveyed.
const std::vector<ReferencePoint> kHallPoints = {{"T1", {2.186, 3.369, 1.528}},
                                                 {"T2", {3.884, 3.599, 0.012}},
                                                 {"T3", {2.267, 7.090, 0.036}},
                                                 {"T4", {0.355, 3.446, 0.028}},
                                                 {"T5", {2.060, 0.831, -0.009}}};

sim::Scenario scenario(const std::string& name, const std::string& add_to_ble_aoa = "") {
  std::string text = sim::builtin_scenario_text(name);
  if (!add_to_ble_aoa.empty()) {
    const std::string key = "    bias_sigma_deg: 3.0\n";
    const auto at = text.find(key);
    EXPECT_NE(at, std::string::npos);
    text.insert(at + key.size(), add_to_ble_aoa);
  }
  return sim::parse_scenario_text(text, name + ".yaml");
}

CalibrationResult calibrate(const sim::Scenario& sc, uint64_t seed, CalibrationFitOptions o,
                            std::vector<ReferencePoint> points, bool truth) {
  CalibrationCollector c(std::move(points), truth, o);
  c.set_site(sc.site);
  test::SimHandlers h;
  h.ble_aoa = [&](const ble_aoa_t& m) { c.add(m, utime_to_s(m.utime - test::kSimStart)); };
  if (truth) h.truth = [&](const pose_t& p) { c.add_truth(p); };
  test::run_simulated(sc, seed, h);
  return c.fit();
}

// The simulator's azimuth edge compression theta + c2 theta^2 + c3 theta^3 (cubic (6.10) without
// its constant; drivers/sim/models/ble_aoa.cpp defaults): a degree-0 fit absorbs its mean over
// the points as well as the bias.
double compression(double theta) {
  return 0.0008 * theta * theta - 0.000046 * theta * theta * theta;
}

// The expected degree-0 offsets: minus the bias minus the mean compression over the 5 points
// (equal weights: every point has ~570 samples per anchor).
double expected_offset(const Site& site, const std::string& anchor, double bias, AngleKind kind) {
  const AnchorFrame f = anchor_frame(*site.find_anchor(anchor));
  double mean = 0;
  for (const auto& p : kHallPoints) {
    const double t = predict_angle(f, p.position, kind).angle_rad / kDeg;
    mean += kind == AngleKind::kAzimuth ? compression(t) : 0.0;
  }
  return -bias - mean / static_cast<double>(kHallPoints.size());
}

// The tolerance of a fitted offset: 4 standard errors of a mean of `used` samples with the fit's
// robust sigma (5 deg noise growing towards the edge, 1 deg rounding), and never above 0.5 deg
// so that the test means something.
double offset_tolerance(const AngleFit& f) {
  const double tol = 4.0 * f.robust_sigma_deg / std::sqrt(static_cast<double>(f.used));
  EXPECT_LT(tol, 0.5);
  return tol;
}

TEST(CalibrationSim, RecoversInjectedAnchorBiases) {
  const std::map<std::string, std::pair<double, double>> bias = {
      {"A1", {2.5, -1.0}}, {"A2", {-4.0, 2.0}}, {"A3", {1.0, 0.5}}, {"A4", {-1.5, -3.0}}};
  const sim::Scenario sc = scenario("aoa-hall-calibration",
                                    "    anchor_bias_deg: {A1: [2.5, -1.0], A2: [-4.0, 2.0], A3: "
                                    "[1.0, 0.5], A4: [-1.5, -3.0]}\n");
  CalibrationFitOptions o;
  o.degree = 0;
  o.elevation = true;
  const CalibrationResult r = calibrate(sc, 7, o, kHallPoints, false);
  ASSERT_EQ(r.anchors.size(), 4u);
  EXPECT_EQ(r.stats.events_in - r.stats.invalid_angle - r.stats.out_of_view,
            r.anchors[0].events + r.anchors[1].events + r.anchors[2].events + r.anchors[3].events);
  for (const auto& a : r.anchors) {
    SCOPED_TRACE(a.anchor_id);
    const auto [b_az, b_el] = bias.at(a.anchor_id);
    ASSERT_TRUE(a.azimuth.fitted) << a.azimuth.failure;
    ASSERT_TRUE(a.elevation && a.elevation->fitted);
    EXPECT_EQ(a.azimuth.groups, 5);
    // ~600 advertisements per tag less 5 % lost, 5 tags; multipath (10 %) dropped as duplicates.
    EXPECT_GT(a.azimuth.used, 2700);
    EXPECT_NEAR(static_cast<double>(a.duplicates) / static_cast<double>(a.events), 0.091, 0.02);
    const double want_az = expected_offset(sc.site, a.anchor_id, b_az, AngleKind::kAzimuth);
    const double want_el = expected_offset(sc.site, a.anchor_id, b_el, AngleKind::kElevation);
    EXPECT_NEAR(a.azimuth.correction.coefficients[0], want_az, offset_tolerance(a.azimuth));
    EXPECT_NEAR(a.elevation->correction.coefficients[0], want_el, offset_tolerance(*a.elevation));
    std::printf("%s az: c0 %+.3f want %+.3f (bias %+.1f), sys %.2f -> %.2f, rms %.2f -> %.2f\n",
                a.anchor_id.c_str(), a.azimuth.correction.coefficients[0], want_az, b_az,
                a.azimuth.systematic_before_deg, a.azimuth.systematic_after_deg,
                a.azimuth.rms_before_deg, a.azimuth.rms_after_deg);
    std::printf("%s el: c0 %+.3f want %+.3f\n", a.anchor_id.c_str(),
                a.elevation->correction.coefficients[0], want_el);
  }
}

// The scenario as shipped: biases drawn per anchor from N(0, 3 deg), the way the simulator draws
// them (first normal of the stream "BLE_AOA anchor <id>").
TEST(CalibrationSim, RecoversDrawnAnchorBiases) {
  const sim::Scenario sc = scenario("aoa-hall-calibration");
  for (uint64_t seed : {1u, 2u}) {
    CalibrationFitOptions o;
    o.degree = 0;
    const CalibrationResult r = calibrate(sc, seed, o, kHallPoints, false);
    o.degree = 1;
    const CalibrationResult linear = calibrate(sc, seed, o, kHallPoints, false);
    for (size_t i = 0; i < r.anchors.size(); ++i) {
      const AnchorFit& a = r.anchors[i];
      SCOPED_TRACE(a.anchor_id + " seed " + std::to_string(seed));
      std::mt19937_64 rng = sim::stream_rng(seed, "BLE_AOA anchor " + a.anchor_id);
      std::normal_distribution<double> gauss(0.0, 1.0);
      const double drawn = 3.0 * gauss(rng);
      ASSERT_TRUE(a.azimuth.fitted);
      const double want = expected_offset(sc.site, a.anchor_id, drawn, AngleKind::kAzimuth);
      EXPECT_NEAR(a.azimuth.correction.coefficients[0], want, offset_tolerance(a.azimuth));
      // What an offset leaves is the edge compression it cannot follow (4.2 deg at -40 deg);
      // a line (degree 1) follows most of it (A2 spans -40..19 deg: ~1 deg left).
      const AngleFit& line = linear.anchors[i].azimuth;
      ASSERT_TRUE(line.fitted);
      EXPECT_LT(line.systematic_after_deg, 1.2);
      EXPECT_LT(line.systematic_after_deg, a.azimuth.systematic_after_deg);
      std::printf(
          "seed %d %s: drawn bias %+.3f, c0 %+.3f want %+.3f, sys %.2f -> %.2f (degree 0)"
          ", %.2f (degree 1: %+.3f %+.5f theta)\n",
          static_cast<int>(seed), a.anchor_id.c_str(), drawn, a.azimuth.correction.coefficients[0],
          want, a.azimuth.systematic_before_deg, a.azimuth.systematic_after_deg,
          line.systematic_after_deg, line.correction.coefficients[0],
          line.correction.coefficients[1]);
    }
  }
}

// The workflow: calibrate (degree 1, the default) on the static capture, use the result on the
// walk of aoa-hall with the same seed (same anchor biases). Measured on the walk with TRUTH, the
// systematic azimuth error left per anchor (a degree-0 fit on the corrected angles) drops below
// 0.6 deg, from the bias it had.
TEST(CalibrationSim, CalibrationCarriesOverToTheWalk) {
  const uint64_t seed = 3;
  CalibrationFitOptions o;  // degree 1
  const CalibrationResult cal =
      calibrate(scenario("aoa-hall-calibration"), seed, o, kHallPoints, false);
  std::map<std::string, AngleCorrection> correction;
  for (const auto& a : cal.anchors) {
    ASSERT_TRUE(a.azimuth.fitted);
    EXPECT_EQ(a.azimuth.degree, 1);
    correction[a.anchor_id] = a.azimuth.correction;
  }

  const sim::Scenario walk = scenario("aoa-hall");
  CalibrationFitOptions o0;
  o0.degree = 0;
  CalibrationCollector raw({}, true, o0), corrected({}, true, o0);
  raw.set_site(walk.site);
  corrected.set_site(walk.site);
  test::SimHandlers h;
  h.ble_aoa = [&](const ble_aoa_t& m) {
    raw.add(m, 0);
    ble_aoa_t c = m;
    const auto v = correction.at(m.anchor_id).apply(m.azimuth_deg);
    c.azimuth_deg = v ? static_cast<float>(*v) : NAN;
    corrected.add(c, 0);
  };
  h.truth = [&](const pose_t& p) {
    raw.add_truth(p);
    corrected.add_truth(p);
  };
  test::run_simulated(walk, seed, h);
  const CalibrationResult before = raw.fit(), after = corrected.fit();
  for (size_t i = 0; i < before.anchors.size(); ++i) {
    const AngleFit& b = before.anchors[i].azimuth;
    const AngleFit& a = after.anchors[i].azimuth;
    SCOPED_TRACE(before.anchors[i].anchor_id);
    ASSERT_TRUE(b.fitted && a.fitted);
    std::mt19937_64 rng = sim::stream_rng(seed, "BLE_AOA anchor " + before.anchors[i].anchor_id);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double drawn = 3.0 * gauss(rng);
    // The walk sees the bias (plus the mean edge compression along it, < 1 deg) and, corrected,
    // no longer. (The systematic figures on a walk also hold the noise of 1-deg bins of ~15
    // samples, ~1.4 deg: only the offset is compared.)
    EXPECT_NEAR(b.correction.coefficients[0], -drawn, 1.0);
    EXPECT_LT(std::abs(a.correction.coefficients[0]), 0.6);
    EXPECT_LT(a.systematic_before_deg, b.systematic_before_deg + 0.05);
    std::printf("walk %s: bias %+.2f; offset left raw %+.2f, calibrated %+.2f; sys %.2f -> %.2f\n",
                before.anchors[i].anchor_id.c_str(), drawn, b.correction.coefficients[0],
                a.correction.coefficients[0], b.systematic_before_deg, a.systematic_before_deg);
  }
}

}  // namespace
}  // namespace ips::aoa
