// ips-ins on exact synthetic data (001 section 2, the OpenShoe ZUPT INS): the stance detector,
// a still IMU, a pure rotation about z, a zero-velocity update, a noise-free walk from the
// simulator's foot model, parameters, start poses and bad input.
#include "estimators/ins/ins_estimator.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <ips/imu_t.hpp>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/geometry.hpp"
#include "drivers/sim/scenario.hpp"
#include "estimators/ins/models/zero_velocity.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::ins {
namespace {

constexpr double kG = 9.81;
constexpr double kDt = 0.005;  // 200 Hz, 001's Ts
constexpr utime_t kT0 = test::kSimStart;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A site whose estimators.ins section is `ins_yaml`, with one tag F1 (its start pose, if any,
// in `start`: e.g. "start_position: [1, 2, 0.1], start_heading_deg: 30").
Site site_with(const std::string& ins_yaml, const std::string& start = "") {
  return parse_site_text("name: t\nanchors: []\ntags: [{id: F1" +
                             (start.empty() ? std::string() : ", " + start) +
                             "}]\nestimators:\n  ins: " + ins_yaml + "\n",
                         "site.yaml");
}

imu_t sample(utime_t t, const Eigen::Vector3d& f, const Eigen::Vector3d& w,
             const std::string& id = "F1") {
  imu_t m;
  m.utime = t;
  m.source = "test";
  m.device_id = id;
  m.device_utime = -1;
  for (int k = 0; k < 3; ++k) {
    m.accel[k] = f(k);
    m.gyro[k] = w(k);
    m.mag_ut[k] = kNaN;
  }
  return m;
}

utime_t at(int64_t k) { return kT0 + k * s_to_utime(kDt); }

struct Harness {
  std::vector<pose_t> poses;
  InsEstimator est{[this](const pose_t& p) { poses.push_back(p); }};
};

// --- stance detector ---------------------------------------------------------------------------

TEST(StanceDetector, StillIsStanceOnlyOnceTheWindowIsFullAndSwingIsNot) {
  StanceDetector d;  // OpenShoe: W = 3, 0.01 m/s^2, 0.1 deg/s, 3e4
  const Eigen::Vector3d g(0, 0, kG);
  EXPECT_FALSE(d.add(g, Eigen::Vector3d::Zero()));
  EXPECT_FALSE(d.add(g, Eigen::Vector3d::Zero()));
  EXPECT_TRUE(d.add(g, Eigen::Vector3d::Zero()));
  EXPECT_EQ(d.statistic(), 0.0);
  // Tilted still foot: gravity is removed along the window's mean direction.
  EXPECT_TRUE(
      d.add(Eigen::Vector3d(0, kG * std::sin(0.3), kG * std::cos(0.3)), Eigen::Vector3d::Zero()));
  d.reset();
  // One sample of 1 m/s^2 more along gravity in a window of 3: gravity is g along the mean
  // direction (+z), so only that sample deviates: (1/3) 1^2 / 0.01^2 = 3333: stance (< 3e4).
  d.add(g, Eigen::Vector3d::Zero());
  d.add(g, Eigen::Vector3d::Zero());
  EXPECT_TRUE(d.add(g + Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::Zero()));
  EXPECT_NEAR(d.statistic(), (1.0 / 3) / 1e-4, 1e-6);
  // 5 m/s^2 sideways in one sample of a still window: the mean tilts by 0.17 rad, the samples
  // deviate from g along it by 1.65, 1.65 and 3.36 m/s^2: (2.71 + 2.71 + 11.3) / 3 / 1e-4 =
  // 5.6e4, beyond the threshold.
  d.reset();
  d.add(g, Eigen::Vector3d::Zero());
  d.add(g, Eigen::Vector3d::Zero());
  EXPECT_FALSE(d.add(g + Eigen::Vector3d(5, 0, 0), Eigen::Vector3d::Zero()));
  EXPECT_NEAR(d.statistic(), 5.6e4, 0.1e4);
  // A swing: 5 rad/s of pitch rate alone scores 5^2 / (0.1 deg/s)^2 / 3 = 2.7e6 per sample.
  EXPECT_FALSE(d.add(g, Eigen::Vector3d(5, 0, 0)));
  EXPECT_GT(d.statistic(), 1e6);
}

// --- a still IMU -------------------------------------------------------------------------------

// A foot standing still, tilted (roll 5 deg, pitch -8 deg), with a gyro bias: 10 s still
// (alignment, bias), a quarter turn on the spot in 0.5 s (navigation proper starts), then 10 s
// still under ZUPTs. It stays in stance and stays put. Noise-free nothing can move at all. With the
// simulator's default noise (0.0125 m/s^2, 0.0017 rad/s per sample) each ZUPT leaves a velocity
// of a few sigma_a dt, which moves the position by ~sigma_a dt^2 = 3e-7 m per sample: a random
// walk of sqrt(2000) 3e-7 = 1.4e-5 m over the last 10 s; bound 1 mm. During the turn (0.5 s
// without ZUPT) white accelerometer noise integrates to sigma_a dt sqrt(n^3/3) = 4e-4 m with
// n = 100 samples; bound 2 cm from the start for the whole run.
TEST(InsEstimator, AStillImuStaysPutInStanceAndFindsTheGyroBias) {
  for (const bool noisy : {false, true}) {
    Harness r;
    r.est.set_site(
        site_with("{alignment_s: 1}", "start_position: [1, 2, 0.1], start_heading_deg: 30"));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(deg_to_rad(5), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(deg_to_rad(-8), Eigen::Vector3d::UnitX()));
    const Eigen::Vector3d f = q.conjugate() * Eigen::Vector3d(0, 0, kG);
    const Eigen::Vector3d turn = q.conjugate() * Eigen::Vector3d(0, 0, (M_PI / 2) / 0.5);
    const Eigen::Vector3d bias(0.004, -0.006, 0.003);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> n(0.0, 1.0);
    Eigen::Vector3d after_turn = Eigen::Vector3d::Zero();
    for (int k = 0; k < 4100; ++k) {
      const bool turning = k >= 2000 && k < 2100;
      Eigen::Vector3d fa = f, wg = bias + (turning ? turn : Eigen::Vector3d::Zero());
      if (noisy)
        for (int i = 0; i < 3; ++i) {
          fa(i) += 0.0125 * n(rng);
          wg(i) += 0.0017 * n(rng);
        }
      r.est.on_imu(sample(at(k), fa, wg));
      if (k == 2199) after_turn = r.est.track("F1")->position;
      if (k == 1999) {
        // Before the turn, still refining the alignment at the start pose.
        EXPECT_EQ(r.est.track("F1")->position, Eigen::Vector3d(1, 2, 0.1));
        // Gyro bias: the mean of 1998 still samples, sigma 0.0017 / sqrt(1998) = 3.8e-5 rad/s.
        EXPECT_LT((r.est.track("F1")->gyro_bias_rps - bias).cwiseAbs().maxCoeff(),
                  noisy ? 2e-4 : 1e-15);
      }
    }
    const auto t = r.est.track("F1");
    ASSERT_TRUE(t);
    EXPECT_TRUE(t->navigating);
    EXPECT_TRUE(t->in_stance);
    EXPECT_EQ(r.est.stats().alignments, 1);
    EXPECT_LT((t->position - after_turn).norm(), noisy ? 1e-3 : 1e-12) << "noisy " << noisy;
    EXPECT_LT((t->position - Eigen::Vector3d(1, 2, 0.1)).norm(), noisy ? 2e-2 : 1e-12);
    // The quarter turn: bias residual 4e-5 rad/s over 10 s and the gyro noise's random walk
    // sqrt(2000) 0.0017 dt = 4e-4 rad: 3e-3 rad.
    EXPECT_NEAR(t->heading_rad, deg_to_rad(120), noisy ? 3e-3 : 1e-9);
    // 10 Hz poses from the end of alignment_s (1 s) on: 19.5 s * 10 + 1.
    EXPECT_NEAR(static_cast<double>(r.poses.size()), 196, 1);
    ASSERT_FALSE(r.poses.empty());
    const pose_t& last = r.poses.back();
    EXPECT_EQ(last.source, "ins");
    EXPECT_EQ(last.tag_id, "F1");
    EXPECT_EQ(last.status, pose_t::STATUS_OK);  // 3D, ZUPTs used
    EXPECT_EQ(last.num_used, 20);               // a ZUPT per sample
    EXPECT_GT(last.position_cov[0], 0);
    EXPECT_LT(last.position_cov[0], 1e-3);
  }
}

// --- a pure rotation ---------------------------------------------------------------------------

// A still foot, level or pitched 20 deg, turned about the vertical at a constant rate for exactly
// 90 deg (300 samples of 5 ms): the heading of the toes advances by exactly 90 deg and, the
// specific force staying gravity, nothing moves. The rotation is integrated with the exact
// exponential, so the only error is rounding.
TEST(InsEstimator, APureRotationAboutZIntegratesToTheExactHeading) {
  for (const double pitch_deg : {0.0, 20.0}) {
    Harness r;
    r.est.set_site(
        site_with("{alignment_s: 0.5}", "start_position: [0, 0, 0], start_heading_deg: 30"));
    const Eigen::Quaterniond q0(Eigen::AngleAxisd(deg_to_rad(pitch_deg), Eigen::Vector3d::UnitX()));
    const Eigen::Vector3d f = q0.conjugate() * Eigen::Vector3d(0, 0, kG);
    const double rate = (M_PI / 2) / (300 * kDt);
    const Eigen::Vector3d w = q0.conjugate() * Eigen::Vector3d(0, 0, rate);
    int64_t k = 0;
    for (; k < 200; ++k) r.est.on_imu(sample(at(k), f, Eigen::Vector3d::Zero()));
    EXPECT_NEAR(r.est.track("F1")->heading_rad, deg_to_rad(30), 1e-12);
    for (int i = 0; i < 300; ++i, ++k) r.est.on_imu(sample(at(k), f, w));
    const auto t = r.est.track("F1");
    ASSERT_TRUE(t && t->navigating);
    EXPECT_NEAR(t->heading_rad, deg_to_rad(120), 1e-9) << "pitch " << pitch_deg;
    EXPECT_LT(t->position.norm(), 1e-9);
    EXPECT_LT(t->velocity.norm(), 1e-9);
  }
}

// --- the zero-velocity update ------------------------------------------------------------------

// After 0.5 s of a constant 1 m/s^2 push the filter has v = 0.5 m/s; a ZUPT at sigma 0.01 m/s
// sets it to R (P_vv + R)^-1 v (P_vv from the propagation, diagonal along x): near zero, and
// exactly the Kalman posterior.
TEST(ZeroVelocityUpdate, ResetsTheVelocityToTheKalmanPosterior) {
  StrapdownFilter f;
  ErrorCov P0 = ErrorCov::Identity() * 1e-4;
  f.reset(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero(), P0);
  for (int k = 0; k < 100; ++k)
    f.propagate(Eigen::Vector3d(1, 0, kG), Eigen::Vector3d::Zero(), kDt, kG, 0.5, 0.01);
  EXPECT_NEAR(f.velocity().x(), 0.5, 1e-12);
  EXPECT_NEAR(f.position().x(), 0.5 * 0.5 * 0.5, 1e-12);  // a t^2 / 2, exact for constant a
  const Eigen::Matrix3d Pvv = f.covariance().block<3, 3>(kVel, kVel);
  const Eigen::Vector3d expected =
      1e-4 * (Pvv + 1e-4 * Eigen::Matrix3d::Identity()).inverse() * f.velocity();
  const ZeroVelocityResult u = zero_velocity_update(f, 0.01);
  ASSERT_TRUE(u.accepted);
  EXPECT_LT((f.velocity() - expected).norm(), 1e-12);
  // One update leaves 3 % of it (R is 1/8 of P_vv; the correlated position error helps)...
  EXPECT_LT(f.velocity().norm(), 0.05 * 0.5);
  // The velocity error was correlated with the position error: the position moved back too.
  EXPECT_GT(u.position_correction_m, 0);
  EXPECT_LT(f.position().x(), 0.125);
  // And the velocity variance collapsed to about R.
  EXPECT_LT(f.covariance()(kVel, kVel), 1e-4);
  // An uncorrelated velocity error (P_vv = 1 m^2/s^2, nothing else correlated): one update
  // leaves exactly R / (P_vv + R) of it, 1e-4 of 0.5 m/s.
  ErrorCov P = ErrorCov::Identity() * 1e-4;
  P.block<3, 3>(kVel, kVel) = Eigen::Matrix3d::Identity();
  f.reset(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3), P);
  f.set_velocity(Eigen::Vector3d(0.5, -0.2, 0.1));
  ASSERT_TRUE(zero_velocity_update(f, 0.01).accepted);
  EXPECT_LT((f.velocity() - 1e-4 / (1 + 1e-4) * Eigen::Vector3d(0.5, -0.2, 0.1)).norm(), 1e-15);
  EXPECT_EQ(f.position(), Eigen::Vector3d(1, 2, 3));  // nothing correlated: nothing else moves
  EXPECT_NEAR(f.covariance()(kVel, kVel), 1e-4 / (1 + 1e-4), 1e-15);
}

// --- a noise-free walk from the simulator's foot model ----------------------------------------

struct NoiseFreeWalk {
  Eigen::Vector3d ins_end = Eigen::Vector3d::Zero();
  Eigen::Vector3d reference_end = Eigen::Vector3d::Zero();
  double max_stance_error_m = 0;  // |INS - reference| over every stance sample
  int stance_samples = 0;
  int imu_samples = 0;
  std::optional<InsTrackSummary> track;
  InsStats stats;
  std::vector<pose_t> poses;
};

// The simulator's foot model (drivers/sim/models/imu.cpp, mount: foot) with noise and biases set
// to 0, 200 Hz, 1.3 m/s, 0.72 m steps, after 3 s standing; the INS starts from the walker's
// start (toes along `heading_deg`, the foot 0.1 m up). The reference is the model's own
// kinematics: its output is the finite difference of its velocity and orientation, so the
// integration its header names (exact rotation, then Euler velocity and position) gives them
// back exactly (tests/drivers/sim/imu_model_test.cpp checks this).
NoiseFreeWalk noise_free_walk(const std::string& waypoints, double heading_deg, double duration_s) {
  const std::string start =
      "start_position: [0, 0, 0.1], start_heading_deg: " + std::to_string(heading_deg);
  const sim::Scenario sc = sim::parse_scenario_text(
      "duration_s: " + std::to_string(duration_s) +
          "\n"
          "site:\n"
          "  anchors: []\n"
          "  tags: [{id: P1, height_m: 0.1, " +
          start +
          "}]\n"
          "trajectories:\n"
          "  - {tag: P1, speed_mps: 1.3, start_s: 3, loop: false, waypoints: " +
          waypoints +
          "}\n"
          "sensors:\n"
          "  truth: {enabled: false}\n"
          "  imu: {mount: foot, rate_hz: 200, step_length_m: 0.72, accel_noise_mps2: 0, "
          "accel_bias_sigma_mps2: 0, gyro_noise_rps: 0, gyro_bias_sigma_rps: 0}\n",
      "walk.yaml");
  NoiseFreeWalk w;
  InsEstimator est([&](const pose_t& p) { w.poses.push_back(p); });
  est.set_site(sc.site);
  Eigen::Quaterniond q(
      Eigen::AngleAxisd(deg_to_rad(heading_deg) - M_PI / 2, Eigen::Vector3d::UnitZ()));
  Eigen::Vector3d v = Eigen::Vector3d::Zero(), p(0, 0, 0.1);
  sim::Simulator simulator(sc, 1, test::kSimStart);
  sim::SimEvent e;
  while (simulator.next(e)) {
    if (e.kind != "IMU") continue;
    imu_t m;
    EXPECT_EQ(m.decode(e.data.data(), 0, static_cast<int>(e.data.size())),
              static_cast<int>(e.data.size()));
    ++w.imu_samples;
    const Eigen::Vector3d rate(m.gyro[0], m.gyro[1], m.gyro[2]);
    const Eigen::Vector3d f(m.accel[0], m.accel[1], m.accel[2]);
    if (w.imu_samples > 1) {
      q = q * rotation_quaternion(rate * kDt);
      v += (q * f - kG * Eigen::Vector3d::UnitZ()) * kDt;
      p += v * kDt;
    }
    est.on_imu(m);
    const auto t = est.track("P1");
    if (t && t->navigating && t->in_stance) {
      ++w.stance_samples;
      w.max_stance_error_m = std::max(w.max_stance_error_m, (t->position - p).norm());
    }
  }
  w.track = est.track("P1");
  if (w.track) w.ins_end = w.track->position;
  w.reference_end = p;
  w.stats = est.stats();
  return w;
}

// Straight 30 m East: the foot lands on the walker's end point, and the INS lands it there to a
// millimetre over 21 strides.
TEST(InsEstimator, ReproducesANoiseFreeSimulatedStraightWalkToAMillimetre) {
  const NoiseFreeWalk w = noise_free_walk("[[0, 0], [30, 0]]", 0, 30);
  EXPECT_NEAR(w.imu_samples, 30 * 200, 1);
  ASSERT_TRUE(w.track);
  EXPECT_LT((w.reference_end - Eigen::Vector3d(30, 0, 0.1)).norm(), 1e-3);
  EXPECT_LT((w.ins_end - Eigen::Vector3d(30, 0, 0.1)).norm(), 1e-3);
  EXPECT_LT(w.max_stance_error_m, 1e-3);
  EXPECT_LT(w.track->velocity.norm(), 1e-6);
  EXPECT_NEAR(w.track->heading_rad, 0, 1e-6);
  // 21 strides of 30 / 21 = 1.43 m (the model stretches them to fit between the stops).
  EXPECT_EQ(w.track->strides, 21);
  EXPECT_NEAR(w.track->distance_m, 30, 1e-3);
  EXPECT_EQ(w.stats.zupts_failed, 0);
  ASSERT_FALSE(w.poses.empty());
  EXPECT_NEAR(w.poses.back().position[0], 30, 1e-3);
  // The start heading's 1 deg (initial_heading_sigma_deg) turns the whole track about its start:
  // 30 m out, 0.52 m across the walk (variance 0.274 m^2 on y), nothing along it (x).
  const pose_t& last = w.poses.back();
  EXPECT_NEAR(std::sqrt(last.position_cov[4]), 30 * deg_to_rad(1.0), 0.02);
  EXPECT_LT(last.position_cov[0], 0.01);
}

// An L walk, 20 m East then 10 m North, with the pivot of the corner in a stance: the foot's
// strides round the corner follow the smoothed heading, so it does not land exactly on the
// walker's end point (within 1 m), but the INS follows the model's foot to a millimetre at every
// stance.
TEST(InsEstimator, ReproducesANoiseFreeSimulatedTurnToAMillimetre) {
  const NoiseFreeWalk w = noise_free_walk("[[0, 0], [20, 0], [20, 10]]", 0, 32);
  ASSERT_TRUE(w.track);
  EXPECT_LT((w.reference_end - Eigen::Vector3d(20, 10, 0.1)).norm(), 1.0);
  EXPECT_LT((w.ins_end - w.reference_end).norm(), 1e-3);
  EXPECT_LT(w.max_stance_error_m, 1e-3);
  EXPECT_GT(w.stance_samples, 3000);
  EXPECT_NEAR(w.track->heading_rad, M_PI / 2, 1e-6);  // toes North after the turn
  EXPECT_EQ(w.stats.dropped_invalid + w.stats.gaps + w.stats.dropped_out_of_order, 0);
}

// --- parameters and start poses ----------------------------------------------------------------

std::string config_error(const std::string& ins_yaml) {
  try {
    InsEstimator est([](const pose_t&) {});
    est.set_site(site_with(ins_yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(InsParams, DefaultsAreTheSourcesAndEveryFieldIsChecked) {
  const InsParams p = parse_ins_params(YamlField(YAML::Node(), "x", "ins"));
  EXPECT_EQ(p.detector.window_samples, 3);
  EXPECT_DOUBLE_EQ(p.detector.threshold, 3e4);
  EXPECT_DOUBLE_EQ(p.zupt_sigma_mps, 0.01);
  EXPECT_DOUBLE_EQ(p.publish_period_s, 0.1);
  EXPECT_EQ(config_error("{detector_threshold: 1e4, publish_period_s: 0}"), "");
  EXPECT_EQ(config_error("{detektor_threshold: 1}")
                .rfind("site.yaml:5: estimators.ins.detektor_threshold: unknown field", 0),
            0u)
      << config_error("{detektor_threshold: 1}");
  EXPECT_EQ(config_error("{detector_window_samples: 65}"),
            "site.yaml:5: estimators.ins.detector_window_samples: must be in [1, 64]");
  EXPECT_EQ(config_error("{gravity_mps2: 1.6}"),
            "site.yaml:5: estimators.ins.gravity_mps2: must be in [9.700000, 9.900000]");
  EXPECT_EQ(config_error("{zupt_sigma_mps: .nan}"),
            "site.yaml:5: estimators.ins.zupt_sigma_mps: expected a finite number, got '.nan'");
  EXPECT_EQ(config_error("[1, 2]"),
            "site.yaml:5: estimators.ins: expected a map of ins parameters");
}

TEST(StartPose, FromTheSiteTagOrTheOriginCounted) {
  // The tag's start pose in the site (tags[].start_position, start_heading_deg); a tag without
  // one starts at the origin facing +x, counted.
  Harness r;
  r.est.set_site(site_with("{alignment_s: 0.5}", "start_position: [4, 5, 0.1], start_heading_deg: 90"));
  const Eigen::Vector3d f(0, 0, kG);
  for (int k = 0; k < 400; ++k) {
    r.est.on_imu(sample(kT0 + k * 5000, f, Eigen::Vector3d::Zero()));
    r.est.on_imu(sample(kT0 + k * 5000, f, Eigen::Vector3d::Zero(), "F9"));
  }
  ASSERT_FALSE(r.poses.empty());
  bool saw_f1 = false, saw_f9 = false;
  for (const pose_t& p : r.poses) {
    if (p.tag_id == "F1") {
      saw_f1 = true;
      EXPECT_NEAR(p.position[0], 4, 1e-9);
      EXPECT_NEAR(p.position[1], 5, 1e-9);
    } else if (p.tag_id == "F9") {
      saw_f9 = true;
      EXPECT_NEAR(p.position[0], 0, 1e-9);
      EXPECT_NEAR(p.position[1], 0, 1e-9);
    }
  }
  EXPECT_TRUE(saw_f1);
  EXPECT_TRUE(saw_f9);
  EXPECT_EQ(r.est.stats().tags_without_start_pose, 1);
}

// --- bad input ---------------------------------------------------------------------------------

TEST(InsEstimator, BadSamplesAreCountedAndNeverMoveTheTrack) {
  Harness r;
  const Eigen::Vector3d g(0, 0, kG), z = Eigen::Vector3d::Zero();
  r.est.on_imu(sample(at(0), g, z));  // no site yet
  EXPECT_EQ(r.est.stats().dropped_no_site, 1);
  r.est.set_site(site_with("{max_tags: 1, alignment_s: 0.1}"));
  int64_t k = 0;
  for (; k < 100; ++k) r.est.on_imu(sample(at(k), g, z));
  ASSERT_TRUE(r.est.track("F1") && r.est.track("F1")->navigating);
  EXPECT_EQ(r.est.stats().tags_without_start_pose, 1);  // the origin, facing +x
  r.est.on_imu(sample(at(k), Eigen::Vector3d(kNaN, 0, kG), z));
  r.est.on_imu(sample(at(k), g, Eigen::Vector3d(0, std::numeric_limits<double>::infinity(), 0)));
  r.est.on_imu(sample(at(k), Eigen::Vector3d(0, 0, 1e9), z));
  r.est.on_imu(sample(-5, g, z));
  imu_t nameless = sample(at(k), g, z, "");
  r.est.on_imu(nameless);
  EXPECT_EQ(r.est.stats().dropped_invalid, 5);
  // The newest sample is at(k - 1). One at its time is a duplicate; one before it within
  // max_gap_s (0.1 s) reordered on the way, routine (the next interval covers it); one further
  // back is late, a fault.
  r.est.on_imu(sample(at(k - 1), g, z));
  r.est.on_imu(sample(at(k - 3), g, z));
  r.est.on_imu(sample(at(k - 60), g, z));
  EXPECT_EQ(r.est.stats().dropped_repeated, 1);
  EXPECT_EQ(r.est.stats().dropped_reordered, 1);
  EXPECT_EQ(r.est.stats().dropped_out_of_order, 1);
  EXPECT_EQ(r.est.stats().drop_reasons().count(DropReason::kReordered), 1);
  EXPECT_EQ(r.est.stats().drop_reasons().count(DropReason::kLate), 1);
  r.est.on_imu(sample(at(k), g, z, "F2"));  // beyond max_tags
  EXPECT_EQ(r.est.stats().dropped_too_many_tags, 1);
  // A 2 s gap: counted, not integrated (a wild sample after it moves nothing).
  k += 400;
  r.est.on_imu(sample(at(k), Eigen::Vector3d(50, 0, kG), z));
  // (The device alone was silent 2 s: its time guard waits for two more samples to confirm the
  // new stamps, then hands all three over in order.)
  for (++k; k < 700; ++k) r.est.on_imu(sample(at(k), g, z));
  EXPECT_EQ(r.est.stats().gaps, 1);
  EXPECT_EQ(r.est.time_stats().reanchors, 1);
  EXPECT_EQ(r.est.time_stats().discarded, 0);
  const auto t = r.est.track("F1");
  EXPECT_LT(t->position.norm(), 1e-12);
  EXPECT_LT(t->velocity.norm(), 1e-12);
  for (const pose_t& p : r.poses) {
    for (double v : p.position) EXPECT_TRUE(std::isfinite(v));
    EXPECT_TRUE(std::isfinite(p.heading_rad));
  }
  // A new site restarts every track.
  r.est.set_site(site_with("{}"));
  EXPECT_FALSE(r.est.track("F1"));
  // A bad new site is refused and the old parameters stay.
  EXPECT_THROW(r.est.set_site(site_with("{max_tags: 0}")), ConfigError);
  EXPECT_EQ(r.est.params().max_tags, 1000);
}

TEST(InsEstimator, MovingBeforeTheAlignmentTimeRestartsIt) {
  Harness r;
  r.est.set_site(site_with("{alignment_s: 1}"));
  const Eigen::Vector3d g(0, 0, kG), z = Eigen::Vector3d::Zero();
  int64_t k = 0;
  for (; k < 100; ++k) r.est.on_imu(sample(at(k), g, z));      // 0.5 s still
  r.est.on_imu(sample(at(k++), g, Eigen::Vector3d(0, 0, 3)));  // a turn
  EXPECT_EQ(r.est.stats().alignment_restarts, 1);
  for (int i = 0; i < 150; ++i, ++k) r.est.on_imu(sample(at(k), g, z));
  EXPECT_FALSE(r.est.track("F1")->navigating);
  EXPECT_TRUE(r.poses.empty());
  for (int i = 0; i < 100; ++i, ++k) r.est.on_imu(sample(at(k), g, z));
  EXPECT_TRUE(r.est.track("F1")->navigating);
  EXPECT_EQ(r.est.stats().alignments, 1);
  EXPECT_FALSE(r.poses.empty());
}

// --- not a foot: no stance phases (issue 22) ------------------------------------------------------

// A phone carried in the hand while walking: the body bounces (2 m/s^2 vertical at the 2 Hz step
// rate, 0.5 m/s^2 sideways) and sways (up to ~0.4 rad/s, 23 deg/s), never still and never turning
// like a foot's swing (hundreds of deg/s).
std::pair<Eigen::Vector3d, Eigen::Vector3d> hand_held(double t, std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double w = 2 * M_PI;
  Eigen::Vector3d f(0.5 * std::sin(w * 1.0 * t), 0.3 * std::sin(w * 2.0 * t + 0.7),
                    kG + 2.0 * std::sin(w * 2.0 * t));
  Eigen::Vector3d g(0.3 * std::sin(w * 1.0 * t), 0.2 * std::sin(w * 1.0 * t + 1.0),
                    0.15 * std::sin(w * 0.5 * t));
  for (int i = 0; i < 3; ++i) {
    f(i) += 0.05 * n(rng);
    g(i) += 0.01 * n(rng);
  }
  return {f, g};
}

// The phone lies still on a table for 2 s (it aligns: a still IMU is a foot at rest as far as
// anyone can tell, and its poses are right), then is carried for 20 s. No POSE_INS after the
// first weak swing (its sway never turns it like a foot), and at the latest once the carrying is
// max_swing_s (5 s) old; the problem is said once it is stance_timeout_s (10 s) old; never "ok"
// with a track stuck at the start.
TEST(InsEstimator, AHandHeldPhoneGetsNoPoseAndASaidReason) {
  Harness r;
  r.est.set_site(site_with("{alignment_s: 1}"));
  std::mt19937_64 rng(3);
  const Eigen::Vector3d g(0, 0, kG), z = Eigen::Vector3d::Zero();
  int64_t k = 0;
  for (; k < 400; ++k) r.est.on_imu(sample(at(k), g, z));  // 2 s on the table
  ASSERT_TRUE(r.est.track("F1")->navigating);
  EXPECT_FALSE(r.poses.empty());
  EXPECT_EQ(r.est.problems(), "");
  const utime_t carried = at(k);
  std::string said_at_12s;
  for (int i = 0; i < 4000; ++i, ++k) {
    const auto [f, w] = hand_held(kDt * static_cast<double>(i), rng);
    r.est.on_imu(sample(at(k), f, w));
    if (i == 8 * 200) {
      EXPECT_EQ(r.est.problems(), "") << "said before stance_timeout_s";
    }
    if (i == 12 * 200) said_at_12s = r.est.problems();
  }
  for (const pose_t& p : r.poses)
    EXPECT_LE(p.utime, carried + s_to_utime(1.0)) << "a pose " << utime_to_s(p.utime - carried)
                                                       << " s into the carrying";
  EXPECT_GT(r.est.stats().poses_withheld, 150);
  EXPECT_GT(r.est.stats().weak_swings, 10);
  EXPECT_NE(said_at_12s.find("F1: no foot stance phase for"), std::string::npos) << said_at_12s;
  EXPECT_NE(said_at_12s.find("no POSE_INS"), std::string::npos) << said_at_12s;
  EXPECT_NE(r.est.problems().find("F1: no foot stance phase"), std::string::npos);
}

// Carried from the start: never still, so never aligned; said after stance_timeout_s (10 s).
TEST(InsEstimator, APhoneNeverAtRestIsSaidNotSilent) {
  Harness r;
  r.est.set_site(site_with("{alignment_s: 1}"));
  std::mt19937_64 rng(4);
  for (int64_t k = 0; k < 11 * 200; ++k) {
    const auto [f, w] = hand_held(kDt * static_cast<double>(k), rng);
    r.est.on_imu(sample(at(k), f, w));
    if (k == 9 * 200) {
      EXPECT_EQ(r.est.problems(), "");
    }
  }
  EXPECT_TRUE(r.poses.empty());
  EXPECT_FALSE(r.est.track("F1")->navigating);
  EXPECT_NE(r.est.problems().find("F1: never still for alignment_s 1 in 11.0 s of IMU data"),
            std::string::npos)
      << r.est.problems();
}

// Issue 23: the same phone is a note (HEALTH stays OK) unless the site declares it on a foot
// (estimators.ins.foot_imus), when it is a fault (HEALTH degraded).
TEST(InsEstimator, NoStanceIsAFaultOnlyForAnImuTheSiteDeclaresOnAFoot) {
  for (const char* params : {"{alignment_s: 1}", "{alignment_s: 1, foot_imus: [F1]}",
                             "{alignment_s: 1, foot_imus: [F9]}"}) {
    SCOPED_TRACE(params);
    Harness r;
    r.est.set_site(site_with(params));
    std::mt19937_64 rng(4);
    for (int64_t k = 0; k < 11 * 200; ++k) {
      const auto [f, w] = hand_held(kDt * static_cast<double>(k), rng);
      r.est.on_imu(sample(at(k), f, w));
    }
    const bool declared = std::string(params).find("[F1]") != std::string::npos;
    ASSERT_NE(r.est.problems(), "");
    EXPECT_EQ(r.est.foot_problems(), declared ? r.est.problems() : "");
    EXPECT_EQ(r.est.other_imu_notes(), declared ? "" : r.est.problems());
  }
  EXPECT_THROW(parse_ins_params(parse_yaml_text("foot_imus: F1", "site")), ConfigError);
}

// The ZUPT noise is the foot's own velocity in stance, which the IMU sees. A foot at rest whose
// velocity jitters by 0.01 m/s per axis (white, 200 Hz; the detector made blind to it by a large
// detector_accel_sigma_mps2): with zupt_sigma_mps 0.01 the ZUPT innovations agree (median NIS
// ~0.9x its chi-square median in a scalar model), with 0.001 (10x too small) they are ~20x, and
// problems() says so by name within 10 s of data. Nothing learned: a ZUPT is a vector.
TEST(InsEstimator, AZuptSigmaTenTimesTooSmallShowsInTheConsistencyMonitor) {
  for (const double sigma : {0.01, 0.001}) {
    Harness r;
    r.est.set_site(site_with("{alignment_s: 1, detector_accel_sigma_mps2: 100, zupt_sigma_mps: " +
                             std::to_string(sigma) + "}"));
    std::mt19937_64 rng(5);
    std::normal_distribution<double> n(0.0, 0.01);
    Eigen::Vector3d v_prev = Eigen::Vector3d::Zero();
    for (int64_t k = 0; k < 10 * 200; ++k) {
      const double t = kDt * static_cast<double>(k);
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      Eigen::Vector3d f(0, 0, kG);
      if (t >= 1.5 && t < 1.7) {
        w = Eigen::Vector3d(0, 0, 4.0);  // a turn on the spot: navigation starts
      } else if (t >= 1.2) {
        const Eigen::Vector3d v(n(rng), n(rng), n(rng));
        f += (v - v_prev) / kDt;
        v_prev = v;
      }
      r.est.on_imu(sample(at(k), f, w));
    }
    EXPECT_GT(r.est.stats().zupts, 1000);
    const std::string problems = r.est.consistency().problems();
    if (sigma == 0.01) {
      EXPECT_EQ(problems, "") << r.est.consistency().summary();
    } else {
      EXPECT_NE(problems.find("ZUPT F1"), std::string::npos) << problems;
      EXPECT_NE(problems.find("zupt_sigma_mps 0.001"), std::string::npos) << problems;
      EXPECT_TRUE(r.est.consistency().degraded());
    }
  }
}

}  // namespace
}  // namespace ips::ins
