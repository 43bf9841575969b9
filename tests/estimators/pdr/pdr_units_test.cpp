// The pieces of ips-pdr on exact synthetic signals: the Butterworth pre-filter (002: 9th order,
// 3 Hz), the step detectors, the step-length models, the orientation EKF, and the estimator's
// handling of bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <ips/imu_t.hpp>
#include <vector>

#include "core/geometry.hpp"
#include "estimators/pdr/butterworth.hpp"
#include "estimators/pdr/orientation_ekf.hpp"
#include "estimators/pdr/pdr_estimator.hpp"
#include "estimators/pdr/step_detector.hpp"
#include "estimators/pdr/step_length.hpp"

namespace ips::pdr {
namespace {

constexpr utime_t kT0 = 1767225600000000;

// Steady-state amplitude of a sinusoid through the filter.
double gain_at(int order, double fc, double fs, double f) {
  ButterworthLowPass lp(order, fc, fs);
  double peak = 0;
  const int n = static_cast<int>(fs * 40);
  for (int i = 0; i < n; ++i) {
    const double y = lp.step(std::sin(2 * M_PI * f * i / fs));
    if (i > n / 2) peak = std::max(peak, std::abs(y));
  }
  return peak;
}

TEST(Butterworth, MagnitudeIsTheButterworthCurve) {
  // |H(f)| = 1 / sqrt(1 + (f/fc)^(2N)) for the analog prototype; the bilinear transform warps
  // frequency, exact at DC and at fc, close elsewhere far below Nyquist.
  EXPECT_NEAR(gain_at(9, 3, 400, 3.0), 1 / std::sqrt(2.0), 2e-3);
  EXPECT_NEAR(gain_at(9, 3, 400, 1.8), 1 / std::sqrt(1 + std::pow(0.6, 18)), 2e-3);
  EXPECT_NEAR(gain_at(9, 3, 400, 6.0), 1 / std::sqrt(1 + std::pow(2.0, 18)), 2e-4);
  EXPECT_NEAR(gain_at(2, 5, 100, 5.0), 1 / std::sqrt(2.0), 2e-3);
  ButterworthLowPass dc(9, 3, 100);
  dc.reset(4.0);
  for (int i = 0; i < 10; ++i) EXPECT_NEAR(dc.step(4.0), 4.0, 1e-12);  // no start-up transient
  EXPECT_THROW(ButterworthLowPass(9, 60, 100), std::invalid_argument);
}

// A sine "vertical acceleration" at `hz`, amplitude `amp`, sampled at fs: still for 1 s, then
// 10 s of walking (whole cycles: the sine starts and ends at 0), then still again.
std::vector<DetectedStep> detect(const StepDetectorParams& p, double fs, double hz, double amp,
                                 double seconds) {
  StepDetector d(p, fs);
  std::vector<DetectedStep> out;
  for (int i = 0; i < static_cast<int>(seconds * fs); ++i) {
    const double t = i / fs;
    const double a =
        t < 1.0 || t >= 11.0 ? 0.0 : amp * std::sin(2 * M_PI * hz * (t - 1.0));
    if (auto s = d.add(kT0 + static_cast<utime_t>(t * 1e6), a)) out.push_back(*s);
  }
  return out;
}

TEST(StepDetector, PeaksCountOneStepPerCycleWithTheSourceThreshold) {
  StepDetectorParams p;
  p.adaptive = false;  // 002's fixed a_th
  const auto steps = detect(p, 100, 1.8, 2.87, 12.0);  // 10 s of walking at 1.8 Hz
  EXPECT_EQ(steps.size(), 18u);
  // Away from the start and the end (the filter rings at the onset), one step per cycle.
  for (size_t i = 2; i + 1 < steps.size(); ++i) EXPECT_NEAR(steps[i].interval_s, 1 / 1.8, 0.011);
  // The 1.8 Hz cosine passes the 3 Hz filter almost untouched: a_max - a_min = 2 A.
  EXPECT_NEAR(steps[5].a_max - steps[5].a_min, 2 * 2.87, 0.02);
  EXPECT_TRUE(detect(p, 100, 1.8, 1.9, 12.0).empty());  // below a_th = 2: no step
}

// The adaptive threshold (issue 22): gentle hand-held steps (+-0.8 m/s^2, below 002's fixed
// 2 m/s^2) are all counted, as are strong ones; a phone at rest, whose signal is only sensor
// noise (0.05 m/s^2 rms), counts none (the floor), and neither does a constant offset.
TEST(StepDetector, AdaptiveThresholdFollowsTheTracesOwnDynamics) {
  StepDetectorParams p;
  ASSERT_TRUE(p.adaptive);
  EXPECT_EQ(detect(p, 100, 1.8, 0.8, 12.0).size(), 18u);
  EXPECT_EQ(detect(p, 100, 1.8, 6.0, 12.0).size(), 18u);
  EXPECT_EQ(detect(p, 100, 2.2, 0.8, 12.0).size(), 22u);
  StepDetector rest(p, 100);
  uint64_t lcg = 12345;
  int steps = 0;
  for (int i = 0; i < 3000; ++i) {
    lcg = lcg * 6364136223846793005ULL + 1442695040888963407ULL;
    const double u = static_cast<double>(lcg >> 11) / 9007199254740992.0;  // [0, 1)
    const double noise = 0.05 * std::sqrt(12.0) * (u - 0.5) + 0.3;          // offset 0.3
    if (rest.add(kT0 + i * 10000, noise)) ++steps;
  }
  EXPECT_EQ(steps, 0);
}

TEST(StepDetector, NoTwoStepsWithin033Seconds) {
  StepDetectorParams p;
  p.filter_cutoff_hz = 10;  // let a 4 Hz signal through
  const auto steps = detect(p, 200, 4.0, 3.0, 12.0);
  ASSERT_GT(steps.size(), 5u);
  for (size_t i = 1; i < steps.size(); ++i) EXPECT_GE(steps[i].interval_s, 0.33);
}

TEST(StepDetector, ZeroCrossingCountsTheSameSteps) {
  StepDetectorParams p;
  p.kind = StepDetectorKind::kZeroCrossing;
  EXPECT_EQ(detect(p, 100, 1.8, 2.87, 12.0).size(), 18u);
  EXPECT_TRUE(detect(p, 100, 1.8, 0.9, 12.0).empty());  // troughs above -1 m/s^2
}

// Steps counted with the ones the cadence adds (DetectedStep::missed), each with its time.
std::vector<DetectedStep> detect_signal(const StepDetectorParams& p, double fs, double seconds,
                                        const std::function<double(double)>& signal) {
  StepDetector d(p, fs);
  std::vector<DetectedStep> out;
  for (int i = 0; i < static_cast<int>(seconds * fs); ++i) {
    const double t = i / fs;
    if (auto s = d.add(kT0 + static_cast<utime_t>(t * 1e6), signal(t)))
      for (const DetectedStep& x : with_missed(*s)) out.push_back(x);
  }
  return out;
}

// A swinging arm at the start of a walk: the arm's pendulum swing at half the step frequency
// adds to the footfalls, so every other valley between two steps is too shallow to re-arm the
// hysteresis and the peaks show one step per stride. The steps are still in the signal (the
// autocorrelation has a positive peak at the step period): the cadence counts the one between.
TEST(StepDetector, SwingingArmStrideCountsBothStepsOfEachStride) {
  const double hz = 1.8;  // steps; the arm swings at 0.9 Hz
  const auto arm = [hz](double t) {
    if (t < 1.0 || t >= 21.0) return 0.0;
    const double u = t - 1.0;
    return 1.0 * std::sin(M_PI * hz * u) + 1.5 * std::cos(2 * M_PI * hz * u);
  };
  StepDetectorParams p;
  p.cadence_fill = false;
  const auto peaks = detect_signal(p, 100, 22, arm);
  // Both steps while the running spread still grows, then one per stride.
  EXPECT_LE(peaks.size(), 24u);
  p.cadence_fill = true;
  const auto steps = detect_signal(p, 100, 22, arm);
  // 36 steps in 20 s, give or take one where the signal starts and stops abruptly.
  EXPECT_NEAR(static_cast<double>(steps.size()), 36.0, 1.0);
  // Every step, counted or missed, about one step period after the previous one.
  for (size_t i = steps.size() / 2; i + 1 < steps.size(); ++i)
    EXPECT_NEAR(utime_to_s(steps[i + 1].utime - steps[i].utime), 1 / hz, 0.06) << i;
}

// Gentle hand-held steps where now and then a footfall is too soft for the adaptive threshold:
// the walk's cadence counts each of them; the step period is the signal's own.
TEST(StepDetector, GentleWalkCountsTheSoftStepsFromItsCadence) {
  const double hz = 1.7;
  const auto gentle = [hz](double t) {
    if (t < 1.0 || t >= 21.0) return 0.0;
    const double u = t - 1.0;
    const int step = static_cast<int>(u * hz);
    const bool soft = step == 6 || step == 13 || step == 19 || step == 26 || step == 31;
    const double amp = soft ? 0.05 : 1.2;  // m/s^2
    return -amp * std::cos(2 * M_PI * hz * u);  // one hump per step
  };
  StepDetectorParams p;
  p.cadence_fill = false;
  const auto peaks = detect_signal(p, 100, 22, gentle);
  EXPECT_NEAR(static_cast<double>(peaks.size()), 34 - 5, 1.0);  // 34 steps, 5 soft
  p.cadence_fill = true;
  const auto steps = detect_signal(p, 100, 22, gentle);
  EXPECT_NEAR(static_cast<double>(steps.size()), 34.0, 1.0);
  int missed = 0;
  for (const DetectedStep& s : steps) missed += s.missed;
  EXPECT_EQ(missed, 0);  // with_missed hands each out as a step of its own
  StepDetector d(p, 100);
  for (int i = 0; i < 2000; ++i) {
    const double t = i / 100.0;
    d.add(kT0 + static_cast<utime_t>(t * 1e6), gentle(t));
  }
  double corr = 0;
  EXPECT_NEAR(d.step_period(&corr), 1 / hz, 0.03);
  EXPECT_GT(corr, 0.5);
}

// What the cadence must not do: double a slow walk (one hump per step, 0.9 Hz: the half lag
// is anti-correlated), count through a pause, or count anything at rest.
TEST(StepDetector, CadenceAddsNothingToASlowWalkAPauseOrRest) {
  StepDetectorParams p;
  ASSERT_TRUE(p.cadence_fill);
  const auto slow = detect_signal(p, 100, 12, [](double t) {
    return t < 1.0 || t >= 11.0 ? 0.0 : 2.0 * std::sin(2 * M_PI * 0.9 * (t - 1.0));
  });
  EXPECT_EQ(slow.size(), 9u);
  const auto with_pause = [](double t) {
    const bool walking = (t >= 1.0 && t < 11.0) || (t >= 14.0 && t < 24.0);
    return walking ? 1.0 * std::sin(2 * M_PI * 1.8 * (t - 1.0)) : 0.0;
  };
  const auto steps = detect_signal(p, 100, 25, with_pause);
  EXPECT_NEAR(static_cast<double>(steps.size()), 36.0, 1.0);
  for (const DetectedStep& s : steps) EXPECT_EQ(s.missed, 0);
  StepDetector rest(p, 100);
  for (int i = 0; i < 3000; ++i)
    EXPECT_FALSE(rest.add(kT0 + i * 10000, 0.02 * std::sin(i * 0.7)));
  EXPECT_EQ(rest.missed_steps(), 0);
}

TEST(StepLength, ModelsOfTheSource) {
  DetectedStep s;
  // 002's calibration read as modified Weinberg: SL = (a_max - a_min)^(1/4) - 0.828.
  s.a_max = 0.5 * std::pow(0.72 + 0.828, 4);
  s.a_min = -s.a_max;
  s.interval_s = 0.5;
  StepLengthParams p;
  EXPECT_NEAR(step_length(p, s), 0.72, 1e-12);
  p.model = StepModel::kWeinberg;
  p.k = 0.5;
  EXPECT_NEAR(step_length(p, s), 0.5 * (0.72 + 0.828), 1e-12);
  p.model = StepModel::kStatic;
  p.k = 0.415;
  p.height_m = 1.8;
  EXPECT_NEAR(step_length(p, s), 0.747, 1e-12);  // 002 (3.1): K h
  p.model = StepModel::kTian;
  p.k = 0.35;
  EXPECT_NEAR(step_length(p, s), 0.35 * 1.8 * std::sqrt(2.0), 1e-12);
  p.model = StepModel::kLevi;
  EXPECT_NEAR(step_length(p, s), 0.7 + 0.3 * (2.0 - 1.8), 1e-12);
  p.model = StepModel::kKang;
  p.k = 1.0;
  p.k2 = 0.2;
  EXPECT_NEAR(step_length(p, s), std::log10(s.a_max - s.a_min) - 0.2, 1e-12);
  p.model = StepModel::kModifiedWeinberg;
  p.k2 = 5;  // absurd: clamped to the walking range
  EXPECT_EQ(step_length(p, s), p.min_m);
  for (const char* n : {"static", "weinberg", "modified_weinberg", "kang", "kim", "scarlett",
                        "tian", "levi"})
    EXPECT_STREQ(step_model_name(*parse_step_model(n)), n);
}

TEST(OrientationEkf, GravityJacobianMatchesFiniteDifferences) {
  // h(dtheta) = (Exp(dtheta) R)' e_z; the filter's H is R' skew(e_z).
  OrientationEkf ekf;
  const Eigen::Vector3d accel = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 0.5).normalized()) *
                                Eigen::Vector3d(0, 0, 9.81);
  ekf.initialise(accel, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(NAN), EarthField{},
                 0.4, 0.01);
  const Eigen::Matrix3d R = ekf.q().toRotationMatrix();
  const Eigen::Matrix3d H = R.transpose() * skew(Eigen::Vector3d::UnitZ());
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d(k) = 1e-6;
    const Eigen::Vector3d hp = (rotation_exp(d) * ekf.q()).toRotationMatrix().transpose().col(2);
    const Eigen::Vector3d hm = (rotation_exp(-d) * ekf.q()).toRotationMatrix().transpose().col(2);
    EXPECT_LT(((hp - hm) / 2e-6 - H.col(k)).norm(), 1e-8) << k;
  }
  // Initialised from gravity alone: R' e_z is the measured direction.
  EXPECT_LT((R.transpose().col(2) - accel.normalized()).norm(), 1e-12);
  EXPECT_NEAR(ekf.heading_of(Eigen::Vector3d::UnitX()),
              std::atan2((R.col(0)).y(), (R.col(0)).x()), 1e-12);
}

TEST(OrientationEkf, TriadHeadingFromTheEarthField) {
  // A flat phone turned so its top points 30 deg east of north: the field's horizontal part is
  // seen rotated; TRIAD gives the top's heading (from +x = East, CCW) 90 - 30 = 60 deg, plus the
  // declination, since the field points to magnetic north.
  EarthField field;
  field.declination_deg = 0;
  const double top_heading = deg_to_rad(60);
  const Eigen::Matrix3d R =  // body -> world: device y along top_heading
      Eigen::AngleAxisd(top_heading - M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d mag = R.transpose() * field.world();
  OrientationEkf ekf;
  ekf.initialise(Eigen::Vector3d(0, 0, 9.81), Eigen::Vector3d::Zero(), mag, field, 0, 0.01);
  EXPECT_NEAR(ekf.heading_of(Eigen::Vector3d::UnitY()), top_heading, 1e-9);
}

TEST(OrientationEkf, GyroBiasIsLearnedWhileStill) {
  OrientationEkf ekf;
  ekf.initialise(Eigen::Vector3d(0, 0, 9.81), Eigen::Vector3d::Zero(),
                 Eigen::Vector3d::Constant(NAN), EarthField{}, 0, 0.05);
  const Eigen::Vector3d bias(0.01, -0.02, 0.015);
  OrientationNoise n;
  for (int i = 0; i < 500; ++i) {  // 5 s still at 100 Hz, the gyro reading only its bias
    ekf.predict(bias, 0.01, n);
    ekf.update_gravity(Eigen::Vector3d(0, 0, 9.81), n.gravity_sigma_still);
    ekf.update_zero_rate(bias, n.zero_rate_sigma_rad_s);
  }
  EXPECT_LT((ekf.bias() - bias).norm(), 1e-4);
}

TEST(OrientationEkf, DisturbedFieldIsRefused) {
  EarthField field;
  OrientationEkf ekf;
  ekf.initialise(Eigen::Vector3d(0, 0, 9.81), Eigen::Vector3d::Zero(), field.world(), field, 0,
                 0.01);
  EXPECT_TRUE(ekf.update_mag_heading(field.world(), field, 0.15, deg_to_rad(8), 0.2));
  EXPECT_FALSE(ekf.update_mag_heading(1.3 * field.world(), field, 0.15, deg_to_rad(8), 0.2));
  const Eigen::Vector3d flat(0, field.magnitude_ut, 0);  // right norm, dip 0 instead of 66
  EXPECT_FALSE(ekf.update_mag_heading(flat, field, 0.15, deg_to_rad(8), 0.2));
}

// The quasi-static field check on a synthetic walk along x (world-frame field per 0.72 m step,
// as the gyro-turned magnetometer gives it): the Earth field with the sensor's noise passes;
// walking through a disturbance that varies over metres (3 uT, 4 m period, like walk-square's
// building) is refused; one with the norm or the dip changing is refused too.
TEST(OrientationEkf, QuasiStaticFieldCheck) {
  const EarthField field;
  const double head = deg_to_rad(5), dip = deg_to_rad(3), norm_ut = 2.0;
  auto walk = [&](const std::function<Eigen::Vector3d(double)>& disturbance) {
    std::vector<Eigen::Vector3d> steps;
    for (int i = 0; i < 5; ++i) {
      const double x = 0.72 * i;
      // The step mean of ~50 readings of 0.4 uT noise: ~0.06 uT.
      const Eigen::Vector3d noise(0.06 * std::sin(7.1 * i), 0.06 * std::cos(5.3 * i), 0.05);
      steps.push_back(field.world() + disturbance(x) + noise);
    }
    return check_quasi_static(steps, head, norm_ut, dip);
  };
  const auto clean = walk([](double) { return Eigen::Vector3d::Zero(); });
  EXPECT_TRUE(clean.ok);
  EXPECT_LT(rad_to_deg(clean.heading_spread_rad), 1.0);
  EXPECT_NEAR(clean.mean.x(), field.world().x(), 0.1);
  const auto disturbed = walk([](double x) {
    return Eigen::Vector3d(3 * std::sin(2 * M_PI * x / 4), 3 * std::cos(2 * M_PI * x / 4), 0);
  });
  EXPECT_FALSE(disturbed.ok);
  EXPECT_GT(rad_to_deg(disturbed.heading_spread_rad), 5.0);
  // Along the field's horizontal direction: the heading barely moves, the norm and dip do.
  const Eigen::Vector3d along =
      Eigen::Vector3d(field.world().x(), field.world().y(), 0).normalized();
  const auto norm_only = walk([&](double x) { return 4.0 * std::sin(2 * M_PI * x / 4) * along; });
  EXPECT_FALSE(norm_only.ok);
  EXPECT_LT(rad_to_deg(norm_only.heading_spread_rad), 1.0);
  EXPECT_GT(norm_only.norm_spread_ut, norm_ut);
  // A disturbance that is the same all along passes this check (nothing varies): the norm and
  // dip checks and the learned noise stand against it.
  EXPECT_TRUE(walk([](double) { return Eigen::Vector3d(1.0, -1.0, 0); }).ok);
  // One step is not a window.
  EXPECT_FALSE(check_quasi_static({field.world()}, head, norm_ut, dip).ok);
}

TEST(PdrEstimator, BadSamplesAreCountedNotUsed) {
  int poses = 0;
  PdrEstimator est([](const step_t&) {}, [&](const pose_t&) { ++poses; });
  imu_t m{};
  m.device_id = "P1";
  m.device_utime = -1;
  for (int k = 0; k < 3; ++k) {
    m.accel[k] = k == 2 ? 9.81 : 0.0;
    m.gyro[k] = 0;
    m.mag_ut[k] = NAN;
  }
  m.utime = kT0;
  est.on_imu(m);  // before a site
  est.set_site(parse_site_text("name: s\nanchors: []\ntags:\n  - {id: P1, height_m: 1.1}\n", "s"));
  est.on_imu(m);
  est.on_imu(m);  // the same time again: a duplicate
  m.utime = kT0 + 10000;
  est.on_imu(m);
  m.utime = kT0 + 5000;  // reordered on the way, within max_gap_s (0.5 s): routine
  est.on_imu(m);
  m.utime = kT0 - 1000000;  // a second back: late
  est.on_imu(m);
  m.utime = kT0 + 20000;
  m.gyro[0] = NAN;
  est.on_imu(m);
  m.gyro[0] = 0;
  m.device_id = "";
  est.on_imu(m);
  const PdrStats& s = est.stats();
  EXPECT_EQ(s.samples_in, 8);
  EXPECT_EQ(s.dropped_no_site, 1);
  EXPECT_EQ(s.dropped_repeated, 1);
  EXPECT_EQ(s.dropped_reordered, 1);
  EXPECT_EQ(s.dropped_time, 1);
  EXPECT_EQ(s.drop_reasons().faults(), s.dropped_no_site + s.dropped_time + s.dropped_invalid);
  EXPECT_EQ(s.dropped_invalid, 2);
  EXPECT_EQ(poses, 0);
}

// An IMU too slow for the 3 Hz step filter (5 Hz here; at least 12 Hz is needed) is refused at
// alignment, counted, and nothing is published (found by fuzz_lcm_messages: the filter threw).
TEST(PdrEstimator, AnImuTooSlowForTheStepFilterIsRefused) {
  int steps = 0;
  PdrEstimator est([&](const step_t&) { ++steps; }, [](const pose_t&) {});
  est.set_site(parse_site_text("name: s\nanchors: []\ntags:\n  - {id: P1, height_m: 1.1}\n", "s"));
  imu_t m{};
  m.device_id = "P1";
  m.device_utime = -1;
  for (int k = 0; k < 3; ++k) {
    m.accel[k] = k == 2 ? 9.81 : 0.0;
    m.gyro[k] = 0;
    m.mag_ut[k] = NAN;
  }
  for (int i = 0; i < 50; ++i) {  // 10 s at 5 Hz, still
    m.utime = kT0 + i * 200000;
    est.on_imu(m);
  }
  EXPECT_EQ(est.stats().alignments, 0);
  EXPECT_GE(est.stats().alignments_too_slow, 1);
  EXPECT_EQ(steps, 0);
}

// A phone with an accelerometer only (gyroscope NaN, as in the Oxford step counter dataset):
// the steps are counted, from the first sample on (the walk starts before the alignment ends:
// the alignment window is replayed), published with heading_rad NaN, and no POSE_PDR. The
// accelerometer reads 2 % high: gravity is the phone's own mean |a|.
TEST(PdrEstimator, AccelerometerOnlyCountsStepsWithHeadingUnknown) {
  std::vector<step_t> steps;
  int poses = 0;
  PdrEstimator est([&](const step_t& s) { steps.push_back(s); }, [&](const pose_t&) { ++poses; });
  est.set_site(parse_site_text("name: s\nanchors: []\ntags:\n  - {id: P1, height_m: 1.1}\n", "s"));
  imu_t m{};
  m.device_id = "P1";
  m.device_utime = -1;
  const double fs = 100, hz = 1.8, g = 9.81 * 1.02;
  for (int i = 0; i < static_cast<int>(20 * fs); ++i) {  // 20 s of walking from the start
    const double t = i / fs;
    m.utime = kT0 + static_cast<utime_t>(t * 1e6);
    const double up = g + 1.0 * std::sin(2 * M_PI * hz * t);
    m.accel[0] = 0.3 * std::cos(2 * M_PI * hz * t);
    m.accel[1] = up * std::sin(0.3);  // held tilted
    m.accel[2] = up * std::cos(0.3);
    for (int k = 0; k < 3; ++k) m.gyro[k] = m.mag_ut[k] = NAN;
    est.on_imu(m);
  }
  // 36 cycles; the first half cycle rises from rest and the filter's delay holds back the last.
  EXPECT_NEAR(static_cast<double>(steps.size()), 36.0, 1.0);
  EXPECT_EQ(poses, 0);
  for (const step_t& s : steps) {
    EXPECT_FALSE(s.heading_known);
    EXPECT_TRUE(std::isnan(s.heading_rad));
    EXPECT_GT(s.length_m, 0);
  }
  ASSERT_FALSE(steps.empty());
  EXPECT_LT(steps.front().utime, kT0 + 2000000);  // within the 2 s alignment: replayed
  EXPECT_EQ(est.stats().accel_only_tracks, 1);
  EXPECT_EQ(est.stats().steps_heading_unknown, static_cast<int64_t>(steps.size()));
  EXPECT_GT(est.stats().samples_replayed, 150);
  EXPECT_EQ(est.stats().samples_aligning, 0);
  EXPECT_EQ(est.stats().dropped_invalid, 0);
  EXPECT_EQ(est.accel_only_devices(), std::vector<std::string>{"P1"});
}

TEST(PdrEstimator, BadParametersStopWithTheField) {
  PdrEstimator est([](const step_t&) {}, [](const pose_t&) {});
  auto fails = [&](const std::string& params, const std::string& want) {
    Site site = parse_site_text("name: s\nanchors: []\n", "s");
    site.estimators = parse_yaml_text("pdr: " + params, "site.yaml");
    try {
      est.set_site(site);
      ADD_FAILURE() << params;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  fails("{detector: fft}", "expected peak or zero_crossing");
  fails("{step_model: magic}", "expected static, weinberg");
  fails("{filter_order: 2.5}", "must be an integer");
  fails("{filter_cutoff_hz: 0}", "filter_cutoff_hz");
  fails("{signal: sideways}", "expected vertical or norm");
  fails("{step_lenght: 1}", "step_lenght");
  fails("{mag_static_window_m: -1}", "mag_static_window_m");
  fails("{mag_correlation_m: -2}", "mag_correlation_m");
}

}  // namespace
}  // namespace ips::pdr
