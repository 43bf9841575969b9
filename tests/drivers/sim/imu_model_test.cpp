// The IMU model (drivers/sim/models/imu.cpp) against its own parameters and the figures of
// ../shared/reference/002_pdr.md (smartphone PDR: 002's step detector, Weinberg calibration,
// Prague's field) and 001_hybrid_uwb_ins.md (foot-mounted ZUPT INS): step count and cadence,
// gravity, gyro bias, yaw over a closed loop, the magnetic field, rates, the device clock, the foot
// stance phases, determinism and parameter errors.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <ips/imu_t.hpp>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "drivers/sim/simulator.hpp"
#include "tests/drivers/sim/sim_test_support.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;
constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.81;
constexpr double kDeg = kPi / 180;

// One walker P1 (plus `more_tags`, a YAML flow list of extra trajectories), TRUTH off, and the
// imu section `imu` (YAML flow map entries, without braces).
std::string scenario_text(const std::string& trajectory, const std::string& imu, double duration_s,
                          const std::string& more_tags = "") {
  return "duration_s: " + std::to_string(duration_s) +
         "\nsite_period_s: 3600\n"
         "site:\n"
         "  anchors: []\n"
         "  tags: [{id: P1}, {id: P2}]\n"
         "trajectories:\n"
         "  - {tag: P1, height_m: 1.1, " +
         trajectory + "}\n" + more_tags +
         "sensors:\n"
         "  truth: {enabled: false}\n"
         "  imu: {" +
         imu + "}\n";
}

// Standing at the origin facing +x for the whole run.
const std::string kStanding = "start_s: 1e6, waypoints: [[0, 0], [1, 0]]";

std::vector<imu_t> run(const Scenario& sc, uint64_t seed = 1, const std::string& device = "P1") {
  std::vector<imu_t> out;
  for (const auto& m : simulated_messages<imu_t>(sc, seed, "IMU"))
    if (m.device_id == device) out.push_back(m);
  return out;
}
std::vector<imu_t> run(const std::string& text, uint64_t seed = 1,
                       const std::string& device = "P1") {
  return run(parse_scenario_text(text, "test.yaml"), seed, device);
}

double t_of(const imu_t& m) { return utime_to_s(m.utime - kStart); }
Eigen::Vector3d accel(const imu_t& m) { return {m.accel[0], m.accel[1], m.accel[2]}; }
Eigen::Vector3d gyro(const imu_t& m) { return {m.gyro[0], m.gyro[1], m.gyro[2]}; }
Eigen::Vector3d mag(const imu_t& m) { return {m.mag_ut[0], m.mag_ut[1], m.mag_ut[2]}; }

struct Stats {
  double mean = 0, sigma = 0;
  size_t n = 0;
};
Stats stats(const std::vector<double>& v) {
  Stats s;
  s.n = v.size();
  for (double x : v) s.mean += x;
  s.mean /= static_cast<double>(s.n);
  for (double x : v) s.sigma += (x - s.mean) * (x - s.mean);
  s.sigma = std::sqrt(s.sigma / static_cast<double>(s.n - 1));
  return s;
}

// 002's peak detector (section 2.2) on the vertical acceleration of a level phone: a local
// maximum above a_th = 2 m/s^2, more than 0.33 s after the previous step. Returns peak times.
std::vector<double> step_peaks(const std::vector<imu_t>& imu) {
  std::vector<double> peaks;
  for (size_t k = 1; k + 1 < imu.size(); ++k) {
    const double a = imu[k].accel[2] - kG;
    if (a > 2.0 && a > imu[k - 1].accel[2] - kG && a >= imu[k + 1].accel[2] - kG &&
        (peaks.empty() || t_of(imu[k]) - peaks.back() > 0.33))
      peaks.push_back(t_of(imu[k]));
  }
  return peaks;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// walk-square: 10 s standing, 200 m at 1.3 m/s with 0.72 m steps, 10 s standing.
TEST(ImuModel, WalkSquareStepsMatchDistanceOverStepLengthAndTheCadence) {
  const auto imu = run(load_scenario("walk-square"));
  const auto peaks = step_peaks(imu);
  const double walk_start = 10.0, walk_end = 10.0 + 200.0 / 1.3;
  // Steps only while walking (the smoothing window is 1 s: the gait fades in over +-0.5 s).
  for (double t : peaks) {
    EXPECT_GT(t, walk_start - 0.5);
    EXPECT_LT(t, walk_end + 0.5);
  }
  // Step count: 200 / 0.72 = 277.8; the tolerance 2 % is 5.6 steps. The model loses
  // at most the fading first and last half steps.
  EXPECT_NEAR(static_cast<double>(peaks.size()), 200.0 / 0.72, 0.02 * 200.0 / 0.72);
  // Cadence: the configured 1.3 m/s / 0.72 m = 1.806 Hz, from the median step interval and from
  // the count over the walking time, each within 2 %.
  std::vector<double> intervals;
  for (size_t i = 1; i < peaks.size(); ++i) intervals.push_back(peaks[i] - peaks[i - 1]);
  const double cadence = 1.3 / 0.72;
  EXPECT_NEAR(1.0 / median(intervals), cadence, 0.02 * cadence);
  EXPECT_NEAR(static_cast<double>(peaks.size()) / (walk_end - walk_start), cadence, 0.02 * cadence);
  // The peaks reach the Weinberg amplitude, (0.72 + 0.828)^4 / 2 = 2.87 m/s^2 above the level read
  // standing (gravity + bias). Median over 277 peaks: noise adds 1.25 * 0.0125 / sqrt(277) =
  // 1e-3, sampling a peak up to 5 ms off loses 0.2 %; tolerance 0.02 m/s^2.
  std::vector<double> rest, at_peaks;
  size_t next_peak = 0;
  for (const auto& m : imu) {
    if (t_of(m) < walk_start - 0.6) rest.push_back(m.accel[2]);
    if (next_peak < peaks.size() && t_of(m) == peaks[next_peak]) {
      at_peaks.push_back(m.accel[2]);
      ++next_peak;
    }
  }
  ASSERT_EQ(at_peaks.size(), peaks.size());
  EXPECT_NEAR(median(at_peaks) - stats(rest).mean, std::pow(0.72 + 0.828, 4) / 2, 0.02);
}

TEST(ImuModel, WalkLoop840StepsMatchDistanceOverStepLength) {
  const auto imu = run(load_scenario("walk-loop-840"));
  // 400 Hz accelerometer and gyroscope, 100 Hz magnetometer (002 section 1).
  ASSERT_NEAR(static_cast<double>(imu.size()), 592 * 400, 1);
  int with_mag = 0;
  for (const auto& m : imu) with_mag += !std::isnan(m.mag_ut[0]);
  EXPECT_NEAR(with_mag, 592 * 100, 1);
  const auto peaks = step_peaks(imu);
  EXPECT_NEAR(static_cast<double>(peaks.size()), 840 / 0.8, 0.02 * 840 / 0.8);
}

TEST(ImuModel, AccelerometerReadsGravityWhileStanding) {
  // Configured bias, no random part; 1000 samples: the mean's standard error is
  // 0.0125 / sqrt(1000) = 4e-4 m/s^2, the tolerance 4 of them.
  const auto imu = run(scenario_text(kStanding,
                                     "rate_hz: 100, accel_noise_mps2: 0.0125, accel_bias_mps2: "
                                     "[0.02, -0.03, 0.01], accel_bias_sigma_mps2: 0",
                                     9.995));
  ASSERT_EQ(imu.size(), 1000u);
  const Eigen::Vector3d bias(0.02, -0.03, 0.01);
  for (int i = 0; i < 3; ++i) {
    std::vector<double> axis;
    for (const auto& m : imu) axis.push_back(m.accel[i]);
    const Stats s = stats(axis);
    EXPECT_NEAR(s.mean, bias[i] + (i == 2 ? kG : 0.0), 4 * 0.0125 / std::sqrt(1000.0)) << i;
    // The sample sigma's standard error is sigma / sqrt(2 n): 2.2 %; tolerance 4 of them.
    EXPECT_NEAR(s.sigma, 0.0125, 4 * 0.0125 / std::sqrt(2000.0)) << i;
  }
  // Tilted 30 deg (top edge up): gravity splits between y and z, |f| stays g.
  const auto tilted = run(scenario_text(
      kStanding, "pitch_deg: 30, accel_bias_sigma_mps2: 0, accel_noise_mps2: 0.0125", 9.995));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& m : tilted) sum += accel(m);
  const Eigen::Vector3d mean = sum / static_cast<double>(tilted.size());
  EXPECT_NEAR(mean.norm(), kG, 0.002);
  EXPECT_NEAR(std::atan2(mean.y(), mean.z()), 30 * kDeg, 0.002 / kG);
}

TEST(ImuModel, GyroBiasIsTheMeanWhileStandingStill) {
  // 002: the bias is the mean over an initial rest. 1000 samples, noise 0.0017 rad/s: standard
  // error 5.4e-5 rad/s, tolerance 4 of them.
  const auto imu = run(scenario_text(kStanding,
                                     "gyro_noise_rps: 0.0017, gyro_bias_rps: [0.01, -0.02, 0.005], "
                                     "gyro_bias_sigma_rps: 0",
                                     9.995));
  ASSERT_EQ(imu.size(), 1000u);
  const Eigen::Vector3d bias(0.01, -0.02, 0.005);
  for (int i = 0; i < 3; ++i) {
    std::vector<double> axis;
    for (const auto& m : imu) axis.push_back(m.gyro[i]);
    const Stats s = stats(axis);
    EXPECT_NEAR(s.mean, bias[i], 4 * 0.0017 / std::sqrt(1000.0)) << i;
    EXPECT_NEAR(s.sigma, 0.0017, 4 * 0.0017 / std::sqrt(2000.0)) << i;
  }
  // The random per-device part (sigma 0.005 rad/s) differs between devices and stays constant.
  const std::string two =
      scenario_text(kStanding, "gyro_noise_rps: 0.0017, gyro_bias_sigma_rps: 0.005", 9.995,
                    "  - {tag: P2, start_s: 1e6, waypoints: [[0, 0], [1, 0]]}\n");
  const auto p1 = run(two, 5, "P1"), p2 = run(two, 5, "P2");
  double m1 = 0, m2 = 0;
  for (size_t k = 0; k < p1.size(); ++k) {
    m1 += p1[k].gyro[2] / static_cast<double>(p1.size());
    m2 += p2[k].gyro[2] / static_cast<double>(p2.size());
  }
  EXPECT_GT(std::abs(m1 - m2), 8 * 0.0017 / std::sqrt(1000.0));  // distinct biases, not noise
  EXPECT_LT(std::abs(m1 - m2), 6 * 0.005 * std::sqrt(2.0));
}

TEST(ImuModel, YawRateIntegratesToOneTurnRoundAClosedSquare) {
  // A 50 x 50 m square walked counter-clockwise as a loop at 1.3 m/s (lap 153.8 s). Integrating
  // the gyro's z from the middle of the first leg to the same point one lap later gives 2 pi plus
  // bias * time; the noise adds 0.0017 * 0.01 * sqrt(15385) = 2.1e-3 rad (tolerance 4 of that).
  const double lap = 200 / 1.3;
  const auto imu =
      run(scenario_text("speed_mps: 1.3, waypoints: [[0, 0], [50, 0], [50, 50], [0, 50]]",
                        "gyro_noise_rps: 0.0017, gyro_bias_rps: [0, 0, 0.002], "
                        "gyro_bias_sigma_rps: 0",
                        20 + lap + 1));
  double yaw = 0;
  size_t n = 0;
  for (const auto& m : imu) {
    const double t = t_of(m);
    if (t > 20 && t <= 20 + lap) {
      yaw += m.gyro[2] * 0.01;
      ++n;
    }
  }
  const double span = static_cast<double>(n) * 0.01;
  EXPECT_NEAR(span, lap, 0.01);
  EXPECT_NEAR(yaw, 2 * kPi + 0.002 * span, 4 * 0.0017 * 0.01 * std::sqrt(static_cast<double>(n)));
}

TEST(ImuModel, MagnetometerShowsTheEarthFieldWhereUndisturbed) {
  // No smooth disturbance; an anomaly far from the 20 x 20 m loop. 6000 samples with 0.4 uT noise:
  // the magnitude's standard error is 0.005 uT, the dip's 0.4 / 50 / sqrt(6000) rad = 0.006 deg.
  const auto imu = run(scenario_text(
      "speed_mps: 1.3, waypoints: [[0, 0], [20, 0], [20, 20], [0, 20]]",
      "mag_field_ut: 50, mag_inclination_deg: 66, mag_declination_deg: 4.82, mag_noise_ut: 0.4, "
      "mag_disturbance_ut: 0, mag_anomalies: [{at: [100, 100], radius_m: 5, field_ut: [30, 0, 0]}]",
      59.995));
  ASSERT_EQ(imu.size(), 6000u);
  std::vector<double> magnitude, dip;
  for (const auto& m : imu) {
    const Eigen::Vector3d b = mag(m);
    magnitude.push_back(b.norm());
    dip.push_back(std::atan2(-b.z(), b.head<2>().norm()));  // level phone: z is up
  }
  EXPECT_NEAR(stats(magnitude).mean, 50.0, 0.03);
  EXPECT_NEAR(stats(dip).mean, 66 * kDeg, 0.05 * kDeg);
  // Standing facing +x with a 90 deg yaw offset, the phone's axes are the site's: the field reads
  // directly as B (cos I sin D, cos I cos D, -sin I).
  const auto aligned = run(scenario_text(
      kStanding, "yaw_offset_deg: 90, mag_noise_ut: 0.4, mag_disturbance_ut: 0", 9.995));
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& m : aligned) sum += mag(m);
  const Eigen::Vector3d mean = sum / static_cast<double>(aligned.size());
  const double inc = 66 * kDeg, dec = 4.82 * kDeg;
  const Eigen::Vector3d expected =
      50 *
      Eigen::Vector3d(std::cos(inc) * std::sin(dec), std::cos(inc) * std::cos(dec), -std::sin(inc));
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(mean[i], expected[i], 4 * 0.4 / std::sqrt(1000.0)) << i;
}

TEST(ImuModel, AnomalyZoneAddsItsFieldAtTheCentreAndNothingOutside) {
  // P1 stands at the anomaly's centre, P2 at 1.5 radii; both face +x (device yaw -90 deg).
  const std::string text = scenario_text(
      "start_s: 1e6, waypoints: [[5, 5], [6, 5]]",
      "mag_noise_ut: 0.4, mag_disturbance_ut: 0, mag_anomalies: [{at: [5, 5], radius_m: 2, "
      "field_ut: [10, -6, 8]}]",
      9.995, "  - {tag: P2, start_s: 1e6, waypoints: [[8, 5], [9, 5]]}\n");
  const Eigen::Quaterniond device(Eigen::AngleAxisd(-kPi / 2, Eigen::Vector3d::UnitZ()));
  const double inc = 66 * kDeg, dec = 4.82 * kDeg;
  const Eigen::Vector3d earth = 50 * Eigen::Vector3d(std::cos(inc) * std::sin(dec),
                                                     std::cos(inc) * std::cos(dec), -std::sin(inc));
  for (const auto& [tag, added] : std::map<std::string, Eigen::Vector3d>{
           {"P1", Eigen::Vector3d(10, -6, 8)}, {"P2", Eigen::Vector3d::Zero()}}) {
    const auto imu = run(text, 1, tag);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& m : imu) sum += mag(m);
    const Eigen::Vector3d mean = sum / static_cast<double>(imu.size());
    const Eigen::Vector3d expected = device.conjugate() * (earth + added);
    for (int i = 0; i < 3; ++i)
      EXPECT_NEAR(mean[i], expected[i], 4 * 0.4 / std::sqrt(1000.0)) << tag << i;
  }
}

TEST(ImuModel, SmoothDisturbanceHasTheConfiguredSpread) {
  // 3 uT per axis with a 2 m correlation length, along a 200 m square loop (about 100 correlation
  // lengths): the field is rotated back to the site frame with the known heading on the straight
  // legs, the Earth's field taken off. The realised field has exactly 3 uT per axis over all space;
  // along one path its 16 random modes leave a spread: over seeds 1 to 30 the per-axis RMS was
  // 3.0 +- 0.25 uT (2.3 to 3.7). Tolerance 25 %, 3 of those spreads. A standing walker sees a
  // constant field (only the 0.4 uT noise).
  const double inc = 66 * kDeg, dec = 4.82 * kDeg;
  const Eigen::Vector3d earth = 50 * Eigen::Vector3d(std::cos(inc) * std::sin(dec),
                                                     std::cos(inc) * std::cos(dec), -std::sin(inc));
  const std::string text =
      scenario_text("speed_mps: 1.3, waypoints: [[0, 0], [50, 0], [50, 50], [0, 50]]",
                    "mag_disturbance_ut: 3, mag_disturbance_length_m: 2, mag_noise_ut: 0.4", 154);
  const Scenario sc = parse_scenario_text(text, "test.yaml");
  const auto imu = run(sc, 3);
  std::vector<double> axes[3];
  for (const auto& m : imu) {
    if (std::isnan(m.mag_ut[0])) continue;
    const TrajectoryState st = sc.trajectories[0].path.at(t_of(m));
    // Skip 1 s round the corners, where the phone's yaw is between two legs.
    const double along = std::fmod(st.distance_m, 50.0);
    if (along < 1.3 || along > 50 - 1.3) continue;
    const Eigen::Quaterniond device(
        Eigen::AngleAxisd(st.heading_rad - kPi / 2, Eigen::Vector3d::UnitZ()));
    const Eigen::Vector3d d = device * mag(m) - earth;
    for (int i = 0; i < 3; ++i) axes[i].push_back(d[i]);
  }
  for (int i = 0; i < 3; ++i) {
    const Stats s = stats(axes[i]);
    const double rms = std::sqrt(s.sigma * s.sigma + s.mean * s.mean);
    EXPECT_NEAR(rms, std::sqrt(3.0 * 3.0 + 0.4 * 0.4), 0.25 * 3.0) << i;
  }
  const auto standing =
      run(scenario_text(kStanding, "mag_disturbance_ut: 3, mag_noise_ut: 0.4", 9.995));
  std::vector<double> x;
  for (const auto& m : standing) x.push_back(m.mag_ut[0]);
  EXPECT_NEAR(stats(x).sigma, 0.4, 4 * 0.4 / std::sqrt(2000.0));
}

TEST(ImuModel, RatesAndMagnetometerDecimation) {
  for (const double rate : {100.0, 400.0}) {
    const auto imu =
        run(scenario_text(kStanding, "rate_hz: " + std::to_string(rate) + ", mag_rate_hz: 25", 10));
    int in_10s = 0, with_mag = 0;
    for (size_t k = 0; k < imu.size(); ++k) {
      if (k) {
        EXPECT_EQ(imu[k].utime - imu[k - 1].utime, static_cast<int64_t>(1e6 / rate));
      }
      if (t_of(imu[k]) < 10) {
        ++in_10s;
        with_mag += !std::isnan(imu[k].mag_ut[0]);
      }
    }
    EXPECT_EQ(in_10s, static_cast<int>(10 * rate)) << rate;  // 100 Hz: 100 samples per second
    EXPECT_EQ(with_mag, 250) << rate;
    for (const auto& m : imu) {
      EXPECT_FALSE(std::isnan(m.accel[0]) || std::isnan(m.gyro[2]));
    }
  }
  // mag_rate_hz 0: no magnetometer at all.
  for (const auto& m : run(scenario_text(kStanding, "mag_rate_hz: 0", 1))) {
    EXPECT_TRUE(std::isnan(m.mag_ut[0]) && std::isnan(m.mag_ut[1]) && std::isnan(m.mag_ut[2]));
  }
}

TEST(ImuModel, DeviceClockIsAnOffsetFromUtime) {
  for (const auto& m : run(scenario_text(kStanding, "device_clock_offset_s: 1234.5", 2))) {
    EXPECT_EQ(m.device_utime - (m.utime - kStart), 1234500000);
  }
  // Default: the phone's uptime, one constant offset between 1 minute and 1 day.
  const auto imu = run(scenario_text(kStanding, "", 2));
  const int64_t offset = imu[0].device_utime - (imu[0].utime - kStart);
  EXPECT_GE(offset, 60000000);
  EXPECT_LE(offset, 86400000000);
  for (const auto& m : imu) {
    EXPECT_EQ(m.device_utime - (m.utime - kStart), offset);
  }
  // A drifting clock gains 100 us per second at 100 ppm.
  const auto fast =
      run(scenario_text(kStanding, "device_clock_offset_s: 0, device_clock_drift_ppm: 100", 2));
  EXPECT_EQ(fast.back().device_utime, 2000200);
}

TEST(ImuModel, ChangingOrientationShowsOnTheGyro) {
  // Standing, the phone swung +-30 deg in yaw with a 10 s period: its z rate is
  // 30 deg * 2 pi / 10 s * cos(2 pi t / 10); over the first quarter period it turns 30 deg.
  const auto imu = run(scenario_text(
      kStanding, "yaw_swing_deg: 30, yaw_swing_period_s: 10, gyro_bias_sigma_rps: 0", 9.995));
  double turned = 0, peak = 0;
  size_t n = 0;
  for (const auto& m : imu) {
    if (t_of(m) > 0 && t_of(m) <= 2.5) {
      turned += m.gyro[2] * 0.01;
      ++n;
    }
    peak = std::max(peak, m.gyro[2]);
  }
  EXPECT_NEAR(turned, 30 * kDeg, 4 * 0.0017 * 0.01 * std::sqrt(static_cast<double>(n)));
  EXPECT_NEAR(peak, 30 * kDeg * 2 * kPi / 10, 4 * 0.0017);
}

// Foot mount: strapdown integration of noise-free output (exact rotation, Euler velocity) along a
// straight 30 m walk. Every stance phase must show zero velocity and the stride length must be
// twice the step length, as a ZUPT INS expects (001 section 2).
TEST(ImuModel, FootMountHasStillStancePhasesAndConsistentStrides) {
  const auto imu = run(scenario_text(
      "speed_mps: 1.3, start_s: 2, loop: false, waypoints: [[0, 0], [30, 0]]",
      "mount: foot, rate_hz: 400, step_length_m: 0.72, swing_fraction: 0.4, accel_noise_mps2: 0, "
      "accel_bias_sigma_mps2: 0, gyro_noise_rps: 0, gyro_bias_sigma_rps: 0",
      30));
  Eigen::Quaterniond q(Eigen::AngleAxisd(-kPi / 2, Eigen::Vector3d::UnitZ()));  // facing +x
  Eigen::Vector3d v = Eigen::Vector3d::Zero(), p = Eigen::Vector3d::Zero();
  const double dt = 1.0 / 400;
  int stance = 0, walking = 0, stances_started = 0;
  bool was_still = true;
  double max_speed = 0, max_still_speed = 0;
  for (const auto& m : imu) {
    const Eigen::Vector3d w = gyro(m);
    if (w.norm() > 0) q = q * Eigen::Quaterniond(Eigen::AngleAxisd(w.norm() * dt, w.normalized()));
    v += (q * accel(m) - kG * Eigen::Vector3d::UnitZ()) * dt;
    p += v * dt;
    // Stance: the SHOE statistics of 001 are exactly zero without noise.
    const bool still = std::abs(accel(m).norm() - kG) < 1e-6 && w.norm() < 1e-6;
    const double t = t_of(m);
    if (t > 3 && t < 2 + 30 / 1.3 - 1) {  // steady walking
      ++walking;
      stance += still;
      stances_started += still && !was_still;
    }
    was_still = still;
    max_speed = std::max(max_speed, v.norm());
    if (still) max_still_speed = std::max(max_still_speed, v.norm());
  }
  EXPECT_LT(max_still_speed, 1e-6);
  EXPECT_NEAR(static_cast<double>(stance) / walking, 1 - 0.4, 0.01);
  // 21 strides of 30 / 21 = 1.43 m fill the 30 m between the start and the stop; the steady part
  // lasts 30/1.3 - 2 s, (30/1.3 - 2) s * 1.3 m/s / 1.43 m = 19.2 strides: 19 or 20 stances start.
  EXPECT_NEAR(stances_started, (30 / 1.3 - 2) * 1.3 / (30.0 / 21), 1.0);
  // The foot lands on the walker's end point, on the path, and stays there.
  EXPECT_NEAR(p.x(), 30, 1e-3);
  EXPECT_NEAR(p.y(), 0, 1e-3);
  EXPECT_NEAR(p.z(), 0, 1e-3);
  // Mean swing speed 1.3 / 0.4 = 3.25 m/s (the foot covers a stride in 40 % of its time), peak
  // twice that.
  EXPECT_NEAR(max_speed, 2 * 1.3 / 0.4, 0.01);
}

TEST(ImuModel, SameSeedSameBytesOtherSeedOtherNoise) {
  Scenario sc = load_scenario("walk-square");
  sc.duration_s = 30;
  auto collect = [&](uint64_t seed) { return simulated_events(sc, seed, "IMU"); };
  const auto a = collect(7), b = collect(7), c = collect(8);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), c.size());
  int differing = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].utime, b[i].utime);
    ASSERT_EQ(a[i].data, b[i].data) << "event " << i;
    differing += a[i].data != c[i].data;
  }
  EXPECT_EQ(differing, static_cast<int>(a.size()));
}

TEST(ImuModel, BadParametersNameFileLineFieldAndReason) {
  auto error = [](const std::string& imu) {
    try {
      parse_scenario_text(scenario_text(kStanding, imu, 10), "test.yaml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("mount: knee"),
            "test.yaml:10: sensors.imu.mount: expected hand or foot, got 'knee'");
  EXPECT_EQ(error("rate_hz: 100, mag_rate_hz: 200"),
            "test.yaml:10: sensors.imu.mag_rate_hz: must be in [0, 100]");
  EXPECT_EQ(error("rate_hz: 5"), "test.yaml:10: sensors.imu.rate_hz: must be in [10, 1000]");
  EXPECT_EQ(error("foot_lift_m: 0.1"),
            "test.yaml:10: sensors.imu.foot_lift_m: only with mount: foot");
  EXPECT_EQ(error("mount: foot, vertical_amplitude_mps2: 3"),
            "test.yaml:10: sensors.imu.vertical_amplitude_mps2: only with mount: hand");
  EXPECT_EQ(error("step_length_m: 0"),
            "test.yaml:10: sensors.imu.step_length_m: must be in [0.1, 3]");
  EXPECT_EQ(error("gyro_bias_rps: [0, 0]"),
            "test.yaml:10: sensors.imu.gyro_bias_rps: expected a list of 3 numbers [x, y, z]");
  EXPECT_EQ(error("accel_bias_mps2: [0, 0, 11]"),
            "test.yaml:10: sensors.imu.accel_bias_mps2: components must be in [-10, 10]");
  EXPECT_EQ(error("mag_anomalies: [{at: [0, 0], field_ut: [1, 2, 3]}]"),
            "test.yaml:10: sensors.imu.mag_anomalies[0].radius_m: field is required");
  EXPECT_EQ(error("gyro_noise: 0.1")
                .rfind("test.yaml:10: sensors.imu.gyro_noise: unknown field (known: ", 0),
            0u);
}

}  // namespace
}  // namespace ips::sim
