// ips-aoa-calibrate's fit (estimators/aoa/calibration_fit.hpp) on exact synthetic angle pairs:
// known polynomials recovered, outliers rejected and counted, the degree fallback, the valid
// interval; the collector's bookkeeping and errors; the site file it writes.
#include "estimators/aoa/calibration_fit.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ips::aoa {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::vector<AngleSample> sample_polynomial(const std::array<double, 4>& c, double from, double to,
                                           double step) {
  std::vector<AngleSample> s;
  for (double t = from; t <= to + 1e-9; t += step)
    s.push_back({t, c[0] + t * (c[1] + t * (c[2] + t * c[3]))});
  return s;
}

// A cubic of the measured angle close to the inverse of the chamber's rounded cubic (6.10),
// theta = -0.000046 Theta^3 + 0.0008 Theta^2 + Theta - 0.8 (source 000 section 4): at theta = 45
// it gives 48.2 (Table 6.6's cubic column: 49.4), at -45: -50.6 (-53.6).
constexpr std::array<double, 4> kInverseCubic{0.8, 0.985, -0.0008, 0.000046};

TEST(AngleCorrectionFit, RecoversAnExactCubicOfTheMeasuredAngle) {
  CalibrationFitOptions o;
  o.degree = 3;
  o.group_width_deg = 0.1;  // every sample its own reference angle: exact data stays exact
  const AngleFit f = fit_angle_correction(sample_polynomial(kInverseCubic, -52, 62, 1), o);
  ASSERT_TRUE(f.fitted) << f.failure;
  EXPECT_EQ(f.degree, 3);
  EXPECT_EQ(f.degree_note, "");
  EXPECT_EQ(f.samples, 115);
  EXPECT_EQ(f.used, 115);
  EXPECT_EQ(f.rejected, 0);
  EXPECT_EQ(f.groups, 115);
  // Coefficient k multiplies theta^k with |theta| up to 62: compare each term's size.
  for (int k = 0; k < 4; ++k)
    EXPECT_NEAR(f.correction.coefficients[k] * std::pow(62.0, k),
                kInverseCubic[k] * std::pow(62.0, k), 1e-9)
        << "c" << k;
  EXPECT_LT(f.rms_after_deg, 1e-9);
  EXPECT_DOUBLE_EQ(f.correction.valid_min_deg, -52.0);
  EXPECT_DOUBLE_EQ(f.correction.valid_max_deg, 62.0);
  EXPECT_EQ(f.correction.beyond, AngleCorrection::Beyond::kExtend);
  // The identity's error on this data: the cubic's departure from theta.
  EXPECT_GT(f.rms_before_deg, 1.0);
}

TEST(AngleCorrectionFit, DegreeZeroIsAConstantOffsetWithUnitSlope) {
  CalibrationFitOptions o;
  o.degree = 0;
  const AngleFit f = fit_angle_correction(sample_polynomial({-2.75, 1, 0, 0}, -40, 40, 2), o);
  ASSERT_TRUE(f.fitted) << f.failure;
  EXPECT_EQ(f.degree, 0);
  EXPECT_NEAR(f.correction.coefficients[0], -2.75, 1e-12);
  EXPECT_EQ(f.correction.coefficients[1], 1.0);
  EXPECT_EQ(f.correction.coefficients[2], 0.0);
  EXPECT_EQ(f.correction.coefficients[3], 0.0);
  EXPECT_NEAR(f.rms_before_deg, 2.75, 1e-12);
  EXPECT_NEAR(f.systematic_before_deg, 2.75, 1e-12);
  EXPECT_LT(f.rms_after_deg, 1e-12);
  EXPECT_EQ(format_angle_correction(f.correction),
            "{polynomial: [-2.75, 1], valid_deg: [-40, 40]}");
}

// Five reference angles (a static capture at five points), 60 samples each; the fit is on the
// group means, so an exact line comes back exactly whatever the group sizes.
TEST(AngleCorrectionFit, RejectsAndCountsInjectedOutliers) {
  const std::array<double, 4> line{1.5, 1.02, 0, 0};
  std::vector<AngleSample> s;
  for (double theta : {-30.0, -12.0, 4.0, 21.0, 37.0})
    for (int i = 0; i < 60; ++i) s.push_back({theta, line[0] + line[1] * theta});
  // 17 multipath-like outliers, 10 to 60 deg off, both signs, one at the edge (89 deg).
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> off(10, 60);
  for (int i = 0; i < 16; ++i) {
    const AngleSample& clean = s[static_cast<size_t>(i * 17)];
    s.push_back({std::clamp(clean.measured_deg + (i % 2 ? 1 : -1) * off(rng), -90.0, 90.0),
                 clean.true_deg});
  }
  s.push_back({89.0, line[0] + line[1] * 37.0});
  CalibrationFitOptions o;  // degree 1
  const AngleFit f = fit_angle_correction(s, o);
  ASSERT_TRUE(f.fitted) << f.failure;
  EXPECT_EQ(f.degree, 1);
  EXPECT_EQ(f.samples, 317);
  EXPECT_EQ(f.rejected, 17);
  EXPECT_EQ(f.used, 300);
  EXPECT_EQ(f.groups, 5);
  EXPECT_NEAR(f.correction.coefficients[0], 1.5, 1e-9);
  EXPECT_NEAR(f.correction.coefficients[1], 1.02, 1e-11);
  EXPECT_LT(f.rms_after_deg, 1e-9);
  // The valid interval spans the measured angles used: the outliers (e.g. the 89) are not in it.
  EXPECT_DOUBLE_EQ(f.correction.valid_min_deg, -30.0);
  EXPECT_DOUBLE_EQ(f.correction.valid_max_deg, 37.0);
}

// Gaussian noise (5 deg, the XPLR-AOA's figure) plus 10 % outliers 10..60 deg off: every outlier
// beyond 5 sigma goes, few clean samples do, and the offset comes back within its standard error.
TEST(AngleCorrectionFit, NoisyOffsetWithOutliers) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0, 5);
  std::uniform_real_distribution<double> uni(0, 1), off(10, 60);
  std::vector<AngleSample> s;
  int far_outliers = 0, outliers = 0;
  for (double truth : {-23.4, -11.5, 3.7, 17.9, 38.8})
    for (int i = 0; i < 600; ++i) {
      double m = truth - 2.0 + noise(rng);  // bias +2: the correction's c0 is -2
      if (uni(rng) < 0.1) {
        const double d = off(rng);
        m += uni(rng) < 0.5 ? d : -d;
        ++outliers;
        if (d > 25) ++far_outliers;
      }
      s.push_back({std::round(m), truth});
    }
  CalibrationFitOptions o;
  o.degree = 0;
  const AngleFit f = fit_angle_correction(s, o);
  ASSERT_TRUE(f.fitted);
  EXPECT_GE(f.rejected, far_outliers);
  EXPECT_LE(f.rejected, outliers + 30);  // and at most ~1 % of the clean ones (3 sigma: 0.27 %)
  // 2700 clean samples of 5 deg: standard error 0.1 deg.
  EXPECT_NEAR(f.correction.coefficients[0], 2.0, 0.35);
  EXPECT_LT(f.systematic_after_deg, f.systematic_before_deg);
}

TEST(AngleCorrectionFit, FallsBackToALowerDegreeWithTheReason) {
  CalibrationFitOptions o;
  o.degree = 3;
  // Three reference angles: a quadratic at most.
  std::vector<AngleSample> three;
  for (double t : {-20.0, 5.0, 30.0})
    for (int i = 0; i < 5; ++i) three.push_back({t, 1.0 + 1.1 * t});
  AngleFit f = fit_angle_correction(three, o);
  ASSERT_TRUE(f.fitted);
  EXPECT_EQ(f.degree_requested, 3);
  EXPECT_EQ(f.degree, 2);
  EXPECT_EQ(f.degree_note, "degree 3 needs 4 distinct reference angles, 3 here");
  EXPECT_NEAR(f.correction.coefficients[0], 1.0, 1e-9);
  EXPECT_NEAR(f.correction.coefficients[1], 1.1, 1e-9);
  EXPECT_NEAR(f.correction.coefficients[2], 0.0, 1e-9);

  // Two reference angles 6 deg apart: too narrow for a slope (10 deg per degree): an offset.
  o.degree = 1;
  std::vector<AngleSample> narrow;
  for (double t : {10.0, 16.0})
    for (int i = 0; i < 6; ++i) narrow.push_back({t, t + 3.0});
  f = fit_angle_correction(narrow, o);
  ASSERT_TRUE(f.fitted);
  EXPECT_EQ(f.degree, 0);
  EXPECT_EQ(f.degree_note, "degree 1 needs reference angles spanning 10.0 deg, 6.0 here");
  EXPECT_NEAR(f.correction.coefficients[0], 3.0, 1e-12);

  // One reference angle, one measured value: an offset, valid +-0.5 deg around it.
  std::vector<AngleSample> one(12, AngleSample{7.0, 9.5});
  f = fit_angle_correction(one, o);
  ASSERT_TRUE(f.fitted);
  EXPECT_EQ(f.degree, 0);
  EXPECT_EQ(f.degree_note, "degree 1 needs 2 distinct reference angles, 1 here");
  EXPECT_DOUBLE_EQ(f.correction.valid_min_deg, 6.5);
  EXPECT_DOUBLE_EQ(f.correction.valid_max_deg, 7.5);
}

// Issue 22: slopes like 0.26 or 1.61 from a few stop points are refused unless forced.
TEST(AngleCorrectionFit, ImplausibleSlopesAreRefusedUnlessForced) {
  CalibrationFitOptions o;
  for (const double slope : {0.26, 1.61}) {
    const auto samples = sample_polynomial({1.0, slope, 0, 0}, -40, 40, 0.5);
    const AngleFit refused = fit_angle_correction(samples, o);
    EXPECT_FALSE(refused.fitted) << slope;
    EXPECT_NE(refused.failure.find("implausible slope"), std::string::npos) << refused.failure;
    EXPECT_NE(refused.failure.find("--force"), std::string::npos) << refused.failure;
    CalibrationFitOptions forced = o;
    forced.force = true;
    const AngleFit kept = fit_angle_correction(samples, forced);
    ASSERT_TRUE(kept.fitted) << kept.failure;
    EXPECT_NEAR(kept.correction.coefficients[1], slope, 1e-9);
    EXPECT_NE(kept.slope_note.find("kept (--force)"), std::string::npos) << kept.slope_note;
  }
  // A plausible scale passes without a note.
  const AngleFit ok = fit_angle_correction(sample_polynomial({-2, 1.15, 0, 0}, -40, 40, 0.5), o);
  ASSERT_TRUE(ok.fitted) << ok.failure;
  EXPECT_EQ(ok.slope_note, "");
}

// Issue 22: four stop points, one of them spoiled (every sample 15 deg off, as a multipath
// reflection does): the start keeps the three that agree, the spoiled group is rejected, and the
// fit is the true offset.
TEST(AngleCorrectionFit, TheOutlierStepKeepsTheAgreeingMajority) {
  std::vector<AngleSample> s;
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 2.0);
  const std::array<double, 4> truth{-3.0, 1.0, 0, 0};
  for (const double theta_true : {-30.0, -10.0, 12.0, 35.0}) {
    for (int i = 0; i < 60; ++i) {
      // measured = (Theta - c0) / c1, plus noise; the point at -10 deg spoiled by +15 deg
      double measured = theta_true - truth[0] + noise(rng);
      if (theta_true == -10.0) measured += 15.0;
      s.push_back({std::round(measured), theta_true});
    }
  }
  CalibrationFitOptions o;
  const AngleFit f = fit_angle_correction(s, o);
  ASSERT_TRUE(f.fitted) << f.failure;
  EXPECT_EQ(f.start_left_out_group, 1);  // the group at -10 deg (second in order)
  EXPECT_GE(f.rejected, 55);             // the spoiled group, nearly all of it
  EXPECT_LE(f.rejected, 75);
  EXPECT_NEAR(f.correction.coefficients[1], 1.0, 0.05);
  EXPECT_NEAR(f.correction.coefficients[0], -3.0, 1.0);
}

TEST(AngleCorrectionFit, TooFewSamplesOrNonFiniteAreNotFitted) {
  CalibrationFitOptions o;
  std::vector<AngleSample> s = sample_polynomial({0, 1, 0, 0}, 0, 8, 1);  // 9 samples
  s.push_back({std::nan(""), 3.0});
  s.push_back({3.0, INFINITY});
  const AngleFit f = fit_angle_correction(s, o);
  EXPECT_FALSE(f.fitted);
  EXPECT_EQ(f.samples, 9);
  EXPECT_EQ(f.failure, "9 samples, fewer than the 10 required");
  EXPECT_FALSE(fit_angle_correction({}, o).fitted);
}

// The collector on a one-anchor site: the anchor at the origin facing +x, so a tag at (x, y, 0)
// has azimuth atan2(-y, x) (docs/scenarios/aoa-hall.md).
Site one_anchor_site() {
  return parse_site_text(
      "name: t\nanchors:\n"
      "  - {id: B1, kind: ble_aoa, position: [0, 0, 0], orientation_deg: [0, 0, 0]}\n"
      "  - {id: U1, kind: uwb, position: [1, 1, 0]}\n"
      "tags:\n  - {id: T1, height_m: 0}\n  - {id: T2}\n",
      "t.yaml");
}

ble_aoa_t event(const std::string& anchor, const std::string& tag, int64_t utime, double az,
                int16_t channel = 37) {
  ble_aoa_t m;
  m.utime = utime;
  m.anchor_id = anchor;
  m.tag_id = tag;
  m.azimuth_deg = static_cast<float>(az);
  m.elevation_deg = 0;
  m.channel = channel;
  return m;
}

TEST(CalibrationCollector, PairsEventsWithPointsAndCountsTheRest) {
  CalibrationFitOptions o;
  o.degree = 0;
  o.min_samples = 3;
  // T1 at (2, -2): azimuth +45 deg; from 10 s on at (2, 2): -45 deg.
  CalibrationCollector c({{"T1", {2, -2, std::nan("")}, 0, 9.5}, {"T1", {2, 2, 0}, 10, 20}}, false,
                         o);
  c.set_site(one_anchor_site());
  int64_t t = 0;
  auto add = [&](const ble_aoa_t& m, double t_s) { c.add(m, t_s); };
  for (int i = 0; i < 5; ++i, t += 100000) add(event("B1", "T1", t, 44.0), i * 0.1);
  add(event("B1", "T1", t - 80000, 10.0), 0.45);  // a duplicate 20 ms after the last: dropped
  for (int i = 0; i < 5; ++i, t += 100000)
    add(event("B1", "T1", t + 10000000, -46.0), 10 + i * 0.1);
  add(event("B1", "T1", t, 44.0), 9.8);          // between the windows
  add(event("B9", "T1", t, 44.0), 1.0);          // not a site anchor
  add(event("U1", "T1", t, 44.0), 1.0);          // not a ble_aoa anchor
  add(event("B1", "T2", t, 44.0), 1.0);          // no point, no --truth
  add(event("B1", "T1", t + 500000, NAN), 1.0);  // NaN azimuth
  const CalibrationResult r = c.fit();
  EXPECT_EQ(r.stats.events_in, 16);
  EXPECT_EQ(r.stats.outside_window, 1);
  EXPECT_EQ(r.stats.unknown_anchor, 2);
  EXPECT_EQ(r.stats.no_reference, 1);
  EXPECT_EQ(r.stats.invalid_angle, 1);
  ASSERT_EQ(r.points.size(), 2u);
  EXPECT_EQ(r.points[0].events, 7);  // 5 + the duplicate + the NaN one
  EXPECT_EQ(r.points[1].events, 5);
  EXPECT_DOUBLE_EQ(r.points[0].point.position.z(), 0.0);
  EXPECT_EQ(r.points[0].z_note, "the site's height_m of T1");
  ASSERT_EQ(r.anchors.size(), 1u);
  const AnchorFit& a = r.anchors[0];
  EXPECT_EQ(a.anchor_id, "B1");
  EXPECT_EQ(a.events, 11);
  EXPECT_EQ(a.duplicates, 1);
  ASSERT_TRUE(a.azimuth.fitted) << a.azimuth.failure;
  EXPECT_EQ(a.azimuth.used, 10);
  EXPECT_EQ(a.azimuth.groups, 2);
  EXPECT_NEAR(a.azimuth.correction.coefficients[0], 1.0, 1e-5);  // float angles
  EXPECT_FALSE(a.elevation.has_value());
}

TEST(CalibrationCollector, TruthIsInterpolatedAtTheEventTime) {
  CalibrationFitOptions o;
  o.degree = 1;
  o.min_samples = 3;
  o.group_width_deg = 0.01;
  o.truth_max_gap_s = 1.5;  // TRUTH at 1 Hz here
  CalibrationCollector c({}, true, o);
  c.set_site(one_anchor_site());
  // T2 walks from (5, -5) to (5, 5) in 10 s; TRUTH at 1 Hz.
  for (int k = 0; k <= 10; ++k) {
    pose_t p;
    p.utime = k * 1000000;
    p.tag_id = "T2";
    p.position[0] = 5;
    p.position[1] = -5 + k;
    p.position[2] = 0;
    c.add_truth(p);
  }
  for (int k = 0; k < 19; ++k) {  // every 0.5 s, measured = 0.5 + true angle
    const int64_t t = 250000 + k * 500000;
    const double y = -5 + 1e-6 * static_cast<double>(t);
    c.add(event("B1", "T2", t, 0.5 + std::atan2(-y, 5.0) / kDeg, static_cast<int16_t>(37 + k % 3)),
          0);
  }
  c.add(event("B1", "T2", 11000000, 0.0), 0);  // after the last TRUTH
  const CalibrationResult r = c.fit();
  EXPECT_EQ(r.stats.no_truth, 1);
  const AngleFit& f = r.anchors[0].azimuth;
  ASSERT_TRUE(f.fitted) << f.failure;
  EXPECT_EQ(f.used, 19);
  // Linear interpolation of a straight walk is exact; the angles are floats (1e-5 deg).
  EXPECT_NEAR(f.correction.coefficients[0], -0.5, 1e-4);
  EXPECT_NEAR(f.correction.coefficients[1], 1.0, 1e-5);
}

TEST(CalibrationCollector, InputErrors) {
  CalibrationFitOptions o;
  EXPECT_THROW(CalibrationCollector({{"T1", {0, 0, 0}, 0, 10}, {"T1", {1, 0, 0}, 5, 20}}, false, o),
               CalibrationError);
  EXPECT_THROW(CalibrationCollector({{"T1", {0, 0, 0}, 10, 5}}, false, o), CalibrationError);
  o.degree = 4;
  EXPECT_THROW(CalibrationCollector({}, true, o), CalibrationError);
  o.degree = 1;

  CalibrationCollector unknown({{"T9", {2, 0, 0}}}, false, o);
  unknown.set_site(one_anchor_site());
  unknown.add(event("B1", "T1", 0, 1.0), 0);
  try {
    unknown.fit();
    FAIL() << "no error for an unknown tag";
  } catch (const CalibrationError& e) {
    EXPECT_STREQ(e.what(), "unknown tag 'T9': not in the site's tags and no BLE_AOA event from it");
  }

  CalibrationCollector empty({{"T2", {2, 0, 0.5}, 100, 200}}, false, o);
  empty.set_site(one_anchor_site());
  empty.add(event("B1", "T2", 0, 1.0), 1.0);
  try {
    empty.fit();
    FAIL() << "no error for a point without events";
  } catch (const CalibrationError& e) {
    EXPECT_STREQ(e.what(),
                 "point T2 at (2.000, 0.000, 0.500) between 100 and 200 s: no BLE_AOA event of T2 "
                 "from a site anchor in its window (1 events of T2 in all)");
  }
  CalibrationCollector no_site({}, true, o);
  EXPECT_THROW(no_site.fit(), CalibrationError);
}

TEST(CalibratedSite, MergesTheBlockAndKeepsTheRest) {
  const Site site = parse_site_text(
      "name: t\nanchors:\n"
      "  - {id: B1, kind: ble_aoa, position: [0, 0, 2], orientation_deg: [0, 0, 45]}\n"
      "  - {id: B2, kind: ble_aoa, position: [5, 0, 2], orientation_deg: [0, 0, 135]}\n"
      "estimators:\n"
      "  uwb_twr: {gate_sigma: 4}\n"
      "  aoa:\n"
      "    calibration:\n"
      "      B2: {azimuth: {polynomial: [1, 1]}}\n"
      "      B1: {elevation: {polynomial: [0.5, 1]}}\n",
      "t.yaml");
  AnchorFit b1;
  b1.anchor_id = "B1";
  b1.azimuth.fitted = true;
  b1.azimuth.correction.coefficients = {-2.25, 1.0125, 0, 0};
  b1.azimuth.correction.valid_min_deg = -40;
  b1.azimuth.correction.valid_max_deg = 52;
  AnchorFit b2;  // not fitted: its entry stays
  b2.anchor_id = "B2";
  const std::string text = calibrated_site_yaml(site, {b1, b2}, {"line one", "line two"});
  EXPECT_EQ(text.rfind("# line one\n# line two\n", 0), 0u) << text;
  const Site back = parse_site_text(text, "back.yaml");
  EXPECT_EQ(back.anchors.size(), 2u);
  EXPECT_EQ(back.estimator_params("uwb_twr")["gate_sigma"].as_double(), 4.0);
  const auto cal = parse_calibration(back.estimator_params("aoa")["calibration"]);
  ASSERT_EQ(cal.size(), 2u);
  EXPECT_EQ(cal.at("B1").azimuth.coefficients, (std::array<double, 4>{-2.25, 1.0125, 0, 0}));
  EXPECT_EQ(cal.at("B1").azimuth.valid_min_deg, -40);
  EXPECT_EQ(cal.at("B1").azimuth.valid_max_deg, 52);
  EXPECT_EQ(cal.at("B1").elevation.coefficients, (std::array<double, 4>{0.5, 1, 0, 0}));
  EXPECT_EQ(cal.at("B2").azimuth.coefficients, (std::array<double, 4>{1, 1, 0, 0}));
  EXPECT_NE(text.find("azimuth: {polynomial: [-2.25, 1.0125], valid_deg: [-40, 52]}"),
            std::string::npos)
      << text;

  // A site without estimators gets the whole block.
  const Site bare = parse_site_text(
      "name: t\nanchors:\n  - {id: B1, kind: ble_aoa, position: [0, 0, 2]}\n", "bare.yaml");
  const Site with = parse_site_text(calibrated_site_yaml(bare, {b1}, {}), "with.yaml");
  EXPECT_EQ(parse_calibration(with.estimator_params("aoa")["calibration"])
                .at("B1")
                .azimuth.coefficients[0],
            -2.25);
}

}  // namespace
}  // namespace ips::aoa
