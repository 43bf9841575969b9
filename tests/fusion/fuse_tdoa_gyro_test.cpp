// ips-fuse's tightly coupled TDoA (models/tdoa.hpp, with ips-uwb-tdoa's clocks and blink grouping
// through TdoaEstimator's epoch sink) and the gyro's turn between displacements
// (gyro_heading.hpp, FuseFilter::predict_cv's turn).
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/sim/scenario.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "fusion/fuse_estimator.hpp"
#include "fusion/gyro_heading.hpp"
#include "fusion/models/tdoa.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::fusion {
namespace {

constexpr double kPi = 3.14159265358979323846;

// tdoa-hall-static: the tag stands at (3.0, 2.0, 1.2); each epoch's arrival differences are the
// hyperbolic range differences of that point, to within the reported noise.
TEST(TdoaEpochSink, EpochsAreTheRangeDifferencesOfTheTagsPoint) {
  const sim::Scenario sc = sim::load_scenario("tdoa-hall-static");
  uwb_tdoa::TdoaEstimator tdoa([](const pose_t&) { FAIL() << "no tracker: no poses"; },
                               [](const clock_t&) {});
  const Eigen::Vector3d p(3.0, 2.0, 1.2);
  int epochs = 0, checked = 0, outside = 0;
  double sum_sq_z = 0;
  tdoa.set_epoch_sink(
      [&](const uwb_tdoa::TdoaEpoch& e) {
        ++epochs;
        EXPECT_EQ(*e.tag_id, "T1");
        ASSERT_GE(e.count, 2);
        EXPECT_EQ(e.range_m[0], 0.0);  // relative to the earliest arrival
        for (int k = 1; k < e.count; ++k) {
          EXPECT_GE(e.range_m[k], 0.0);
          const double expected = (p - e.anchor[k]).norm() - (p - e.anchor[0]).norm();
          const double z = (e.range_m[k] - expected) / std::sqrt(e.var_m2[k] + e.var_m2[0]);
          sum_sq_z += z * z;
          ++checked;
          if (std::abs(z) > 5) ++outside;
        }
      },
      false);
  tdoa.set_site(sc.site);
  test::run_simulated(sc, 1, {.uwb_rx = [&](const uwb_rx_t& m) { tdoa.on_rx(m); }});
  // 120 s at 10 Hz, the first blinks before the clocks lock.
  EXPECT_GT(epochs, 1100);
  EXPECT_GT(checked, 5 * 1000);
  EXPECT_LT(outside, checked / 100);
  // The reported variances are the right size: normalised errors of about unit variance.
  const double nees = sum_sq_z / checked;
  std::printf("tdoa-hall-static: %d epochs, %d differences, mean z^2 %.3f\n", epochs, checked,
              nees);
  EXPECT_GT(nees, 0.3);
  EXPECT_LT(nees, 3.0);
  EXPECT_EQ(tdoa.stats().poses_out, 0);
}

FuseFilter planar_filter_at(double x, double y, double sigma) {
  FuseFilter f;
  f.planar = true;
  f.x.setZero();
  f.x << x, y, 1.2, 0, 0, 0, 0;
  f.P.setZero();
  f.P(0, 0) = f.P(1, 1) = sigma * sigma;
  f.P(2, 2) = f.P(5, 5) = 1e-12;
  f.P(3, 3) = f.P(4, 4) = 1.0;
  f.P(6, 6) = 0.1;
  return f;
}

TdoaArrivals arrivals_for(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& anchors,
                          double var_m2) {
  TdoaArrivals a;
  for (const auto& an : anchors) {
    a.anchor[a.count] = an;
    a.range_m[a.count] = (p - an).norm() + 7.0;  // any common offset: only differences count
    a.var_m2[a.count] = var_m2;
    ++a.count;
  }
  return a;
}

const std::vector<Eigen::Vector3d> kRoom = {
    {0.3, 0.3, 2.6}, {9.7, 0.3, 2.6}, {9.7, 7.7, 2.6}, {0.3, 7.7, 2.6}};

TEST(TdoaModel, ExactDifferencesPullTheEstimateToThePoint) {
  const Eigen::Vector3d truth(4.0, 3.0, 1.2);
  FuseFilter f = planar_filter_at(4.3, 2.8, 0.5);
  const TdoaArrivals a = arrivals_for(truth, kRoom, 0.05 * 0.05);
  for (int i = 0; i < 5; ++i) {
    const TdoaUpdate u = update_tdoa(f, a, 16.0);
    ASSERT_TRUE(u.accepted);
    EXPECT_EQ(u.used, 3);
  }
  EXPECT_NEAR(f.x(0), 4.0, 0.01);
  EXPECT_NEAR(f.x(1), 3.0, 0.01);
  EXPECT_EQ(f.x(2), 1.2);  // planar: the height stays
  EXPECT_LT(f.P(0, 0), 0.05 * 0.05);
}

TEST(TdoaModel, AnOutlierReferenceIsReplacedByTheNextAnchor) {
  const Eigen::Vector3d truth(4.0, 3.0, 1.2);
  FuseFilter f = planar_filter_at(4.02, 3.01, 0.05);
  TdoaArrivals a = arrivals_for(truth, kRoom, 0.05 * 0.05);
  a.range_m[0] += 2.0;  // the nearest anchor's reception came by a 2 m longer path
  const TdoaUpdate u = update_tdoa(f, a, 16.0);
  ASSERT_TRUE(u.accepted);
  EXPECT_EQ(u.used, 2);   // against anchor 1: anchors 2 and 3
  EXPECT_EQ(u.gated, 1);  // anchor 0 itself
  EXPECT_NEAR(f.x(0), 4.0, 0.03);
  EXPECT_NEAR(f.x(1), 3.0, 0.03);
}

TEST(TdoaModel, DifferencesThatMostlyDisagreeAreNotApplied) {
  FuseFilter f = planar_filter_at(4.0, 3.0, 0.05);
  const FuseFilter before = f;
  const TdoaArrivals a = arrivals_for({7.0, 6.0, 1.2}, kRoom, 0.05 * 0.05);
  const TdoaUpdate u = update_tdoa(f, a, 16.0);
  EXPECT_FALSE(u.accepted);
  EXPECT_EQ(u.used, 0);
  EXPECT_EQ(f.x, before.x);
  EXPECT_EQ(f.P, before.P);
}

// imu_t-like samples of a phone held tilted 30 degrees about its x axis while the walker turns at
// `rate` rad/s about the vertical.
void feed_turning_phone(GyroHeading& g, utime_t t0, double seconds, double rate) {
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.5236, Eigen::Vector3d::UnitX()).matrix();
  for (int i = 0; i <= static_cast<int>(seconds * 100); ++i) {
    // World up and the turn, in the device frame.
    const Eigen::Vector3d up = tilt.transpose() * Eigen::Vector3d(0, 0, 9.81);
    const Eigen::Vector3d gyro = tilt.transpose() * Eigen::Vector3d(0, 0, rate);
    ASSERT_TRUE(g.add(t0 + i * 10000, gyro, up));
  }
}

TEST(GyroHeading, TheTurnAboutTheVerticalWhateverThePhonesTilt) {
  GyroHeading g;
  const utime_t t0 = s_to_utime(1000.0);
  feed_turning_phone(g, t0, 3.0, 0.5);
  const auto turn = g.turn(t0 + s_to_utime(1.0), t0 + s_to_utime(2.5));
  ASSERT_TRUE(turn);
  EXPECT_NEAR(*turn, 0.75, 1e-6);
  // Between samples: interpolated.
  EXPECT_NEAR(*g.turn(t0 + 5000, t0 + 1'005'000), 0.5, 1e-6);
  // Outside the series: nothing.
  EXPECT_FALSE(g.turn(t0 - 1, t0 + s_to_utime(1.0)));
  EXPECT_FALSE(g.turn(t0, t0 + s_to_utime(3.2)));
  // Not after the previous sample, or not finite: not used.
  EXPECT_FALSE(g.add(t0 + s_to_utime(3.0), {0, 0, 1}, {0, 0, 9.81}));
  EXPECT_FALSE(g.add(t0 + s_to_utime(3.1), {0, 0, std::nan("")}, {0, 0, 9.81}));
  // Beyond any MEMS gyro (2000 deg/s) or accelerometer (16 g): a corrupt sample.
  EXPECT_FALSE(g.add(t0 + s_to_utime(3.1), {0, 0, 40.0}, {0, 0, 9.81}));
  EXPECT_FALSE(g.add(t0 + s_to_utime(3.1), {0, 0, 1.0}, {0, 200.0, 9.81}));
  EXPECT_NEAR(*g.turn(t0, t0 + s_to_utime(3.0)), 1.5, 1e-6);
}

TEST(GyroHeading, AGapStartsANewSeries) {
  GyroHeading g;
  const utime_t t0 = s_to_utime(1000.0);
  feed_turning_phone(g, t0, 1.0, 0.5);
  feed_turning_phone(g, t0 + s_to_utime(2.0), 1.0, -0.5);
  EXPECT_FALSE(g.turn(t0 + s_to_utime(0.5), t0 + s_to_utime(2.5)));
  EXPECT_NEAR(*g.turn(t0 + s_to_utime(2.0), t0 + s_to_utime(3.0)), -0.5, 1e-6);
}

TEST(FuseFilterTurn, TheVelocityTurnsAndThePositionFollowsTheMidpoint) {
  FuseFilter f = planar_filter_at(0, 0, 0.1);
  f.x(3) = 1.0;  // 1 m/s along x
  f.predict_cv(1.0, 0.0, 0.0, kPi / 4, kPi / 2);
  EXPECT_NEAR(f.x(3), 0.0, 1e-12);
  EXPECT_NEAR(f.x(4), 1.0, 1e-12);
  EXPECT_NEAR(f.x(0), std::cos(kPi / 4), 1e-12);
  EXPECT_NEAR(f.x(1), std::sin(kPi / 4), 1e-12);
  // The velocity's covariance turned with it: x's variance became y's.
  FuseFilter g = planar_filter_at(0, 0, 0.1);
  g.P(3, 3) = 4.0;
  g.P(4, 4) = 1.0;
  g.predict_cv(0.5, 0.0, 0.0, kPi / 4, kPi / 2);
  EXPECT_NEAR(g.P(3, 3), 1.0, 1e-12);
  EXPECT_NEAR(g.P(4, 4), 4.0, 1e-12);
}

TEST(FuseEstimatorRx, BlinksBeforeASiteAreCountedAndPoseTdoaIsSupersededOnlyOnceBlinksAreFused) {
  FuseEstimator est([](const pose_t&) {});
  uwb_rx_t rx{};
  rx.utime = s_to_utime(1000.0);
  rx.anchor_id = "D1";
  rx.sender_id = "T1";
  rx.counter_hz = 63.8976e9;
  est.on_rx(rx);
  EXPECT_EQ(est.stats().dropped_no_site, 1);
  ble_aoa_t aoa{};
  aoa.utime = rx.utime;
  aoa.anchor_id = "B1";
  aoa.tag_id = "T1";
  est.on_aoa(aoa);
  EXPECT_EQ(est.stats().dropped_no_site, 2);
  // With a site: an anchor that is not a TDoA anchor of it is ips-uwb-tdoa's unknown anchor.
  // (The lab's site without T1's start pose: the track is to start from POSE_TDOA.)
  Site lab = sim::load_scenario("lab").site;
  for (Tag& tag : lab.tags) tag.start_position.setConstant(std::nan(""));
  est.set_site(lab);
  rx.anchor_id = "A1";
  est.on_rx(rx);
  EXPECT_EQ(est.tdoa_stats().dropped_unknown_anchor, 1);
  aoa.anchor_id = "A1";  // not a ble_aoa anchor
  aoa.azimuth_deg = 10;
  aoa.elevation_deg = 5;
  est.on_aoa(aoa);
  EXPECT_EQ(est.aoa_stats().dropped_unknown_anchor, 1);
  // No blinks fused yet: POSE_TDOA starts and updates the track.
  pose_t p{};
  p.utime = s_to_utime(1000.0);
  p.tag_id = "T1";
  p.position[0] = 4.0;
  p.position[1] = 3.0;
  p.position[2] = 1.2;
  p.position_cov[0] = p.position_cov[4] = p.position_cov[8] = 0.01;
  p.status = pose_t::STATUS_2D;
  est.on_pose(p, "tdoa");
  p.utime += 100000;
  est.on_pose(p, "tdoa");
  EXPECT_EQ(est.stats().poses_used, 1);
  EXPECT_EQ(est.stats().poses_superseded, 0);
  // IMU samples with NaN are counted.
  imu_t imu{};
  imu.utime = s_to_utime(1000.0);
  imu.device_id = "T1";
  imu.gyro[2] = std::nan("");
  est.on_imu(imu);
  EXPECT_EQ(est.stats().dropped_invalid, 1);
  EXPECT_EQ(est.stats().imu_used, 0);
  // A sample repeated (a LAN's duplicate) or older than the newest (reordered) is not invalid;
  // reordered within max_delay_s (1 s) it is routine, further back late (a fault).
  imu.gyro[2] = 0.1;
  imu.accel[2] = 9.81;
  est.on_imu(imu);
  EXPECT_EQ(est.stats().imu_used, 1);
  const int64_t faults_before = est.drop_reasons().faults();
  est.on_imu(imu);
  imu.utime -= 10000;
  est.on_imu(imu);
  EXPECT_EQ(est.stats().imu_used, 1);
  EXPECT_EQ(est.stats().dropped_invalid, 1);
  EXPECT_EQ(est.stats().dropped_imu_repeated, 1);
  EXPECT_EQ(est.stats().dropped_imu_reordered, 1);
  EXPECT_EQ(est.drop_reasons().count(DropReason::kDuplicate), 1);
  EXPECT_EQ(est.drop_reasons().count(DropReason::kReordered), 1);
  EXPECT_EQ(est.drop_reasons().faults(), faults_before);  // not degraded for it
  imu.utime -= s_to_utime(1.5);
  est.on_imu(imu);
  EXPECT_EQ(est.stats().dropped_imu_late, 1);
  EXPECT_EQ(est.drop_reasons().faults(), faults_before + 1);
}

}  // namespace
}  // namespace ips::fusion
