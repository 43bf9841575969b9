// AoaEstimator on exact synthetic events: the hall of source 000 (Table 7.2, yaws of (7.2)).
// Exact angles give the exact position; multipath copies are resolved by the duplicate policy;
// calibration polynomials undo a known bias; bad input is counted, never used.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <ips/ble_aoa_t.hpp>
#include <ips/pose_t.hpp>
#include <vector>

#include "core/geometry.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/aoa/epoch_grouper.hpp"
#include "estimators/aoa/models/aoa_bearing.hpp"

namespace ips::aoa {
namespace {

constexpr utime_t kT0 = 1767225600000000;  // 2026-01-01T00:00:00Z

const char* kHallSite = R"(
name: aoa-hall
anchors:
  - {id: A1, kind: ble_aoa, position: [0.000, 0.000, 1.683], orientation_deg: [0, 0, 60.73]}
  - {id: A2, kind: ble_aoa, position: [4.552, -0.119, 1.627], orientation_deg: [0, 0, 119.27]}
  - {id: A3, kind: ble_aoa, position: [-0.105, 8.126, 1.723], orientation_deg: [0, 0, -60.73]}
  - {id: A4, kind: ble_aoa, position: [4.651, 8.103, 1.681], orientation_deg: [0, 0, -119.27]}
  - {id: U1, kind: uwb, position: [1, 1, 2]}
tags:
  - {id: T1, height_m: 1.528}
)";

Site hall_site(const std::string& aoa_params = "") {
  Site site = parse_site_text(kHallSite, "hall");
  if (!aoa_params.empty()) site.estimators = parse_yaml_text("aoa: " + aoa_params, "params");
  return site;
}

ble_aoa_t event(const Site& site, const std::string& anchor, const std::string& tag,
                const Eigen::Vector3d& p, utime_t t, double az_offset_deg = 0, float rssi = -60) {
  const AnchorFrame f = anchor_frame(*site.find_anchor(anchor));
  ble_aoa_t m;
  m.utime = t;
  m.source = "test";
  m.anchor_id = anchor;
  m.tag_id = tag;
  m.azimuth_deg = static_cast<float>(
      rad_to_deg(predict_angle(f, p, AngleKind::kAzimuth).angle_rad) + az_offset_deg);
  m.elevation_deg =
      static_cast<float>(rad_to_deg(predict_angle(f, p, AngleKind::kElevation).angle_rad));
  m.rssi_dbm = rssi;
  m.channel = 37;
  m.anchor_uptime_ms = 1000;
  m.seq = 0;
  return m;
}

// The four anchors' exact events for position p at time t, 5 ms apart.
void advertise(AoaEstimator& est, const Site& site, const std::string& tag,
               const Eigen::Vector3d& p, utime_t t) {
  int k = 0;
  for (const char* a : {"A1", "A2", "A3", "A4"}) est.on_event(event(site, a, tag, p, t + 5000 * k++));
}

struct Collected {
  std::vector<pose_t> poses;
  AoaEstimator::PoseSink sink() {
    return [this](const pose_t& p) { poses.push_back(p); };
  }
};

// float angles in ble_aoa_t: 1e-7 relative, so micro-degrees, micrometres at these distances.
constexpr double kFloatTolM = 2e-5;

TEST(AoaEstimator, ExactAnglesGiveTheExactPositionPerEpoch) {
  for (const char* solver : {"lm", "gauss_newton", "bearing_lines"}) {
    Collected out;
    AoaEstimator est(out.sink());
    const Site site = hall_site(std::string("{method: per_epoch, solver: ") + solver +
                                ", converged_step_m: 1e-9}");
    est.set_site(site);
    const Eigen::Vector3d p(2.186, 3.369, 1.528);
    advertise(est, site, "T1", p, kT0);
    advertise(est, site, "T1", p, kT0 + 100000);
    est.finish();
    ASSERT_EQ(out.poses.size(), 2u) << solver;
    for (const pose_t& pose : out.poses) {
      EXPECT_NEAR(pose.position[0], p.x(), kFloatTolM) << solver;
      EXPECT_NEAR(pose.position[1], p.y(), kFloatTolM) << solver;
      EXPECT_EQ(pose.position[2], 1.528);  // 2D at the site's tag height
      EXPECT_EQ(pose.num_used, 4);
      EXPECT_TRUE(pose.status & pose_t::STATUS_2D);
      EXPECT_GT(pose.position_cov[0], 0.0);
      EXPECT_EQ(pose.tag_id, "T1");
      EXPECT_EQ(pose.source, "aoa");
    }
    EXPECT_EQ(out.poses[0].utime, kT0);  // the epoch's earliest event
    EXPECT_EQ(est.stats().epochs, 2);
    EXPECT_EQ(est.stats().angles_used, 8);
  }
}

TEST(AoaEstimator, EkfFollowsExactAnglesToTheExactPosition) {
  Collected out;
  AoaEstimator est(out.sink());
  const Site site = hall_site("{converged_step_m: 1e-9}");
  est.set_site(site);
  // Walk along y at 0.6 m/s (inside the hall), 10 advertisements a second, for 10 s.
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d p(2.0, 1.0 + 0.06 * i, 1.528);
    advertise(est, site, "T1", p, kT0 + i * 100000);
  }
  est.finish();
  ASSERT_EQ(out.poses.size(), 100u);
  const pose_t& last = out.poses.back();
  EXPECT_NEAR(last.position[0], 2.0, 1e-3);
  EXPECT_NEAR(last.position[1], 1.0 + 0.06 * 99, 1e-3);
  EXPECT_NEAR(last.velocity[1], 0.6, 0.02);
  EXPECT_NEAR(last.heading_rad, M_PI / 2, 0.02);
  EXPECT_EQ(est.stats().initialisations, 1);
  EXPECT_EQ(est.stats().rejected_gate, 0);
}

TEST(AoaEstimator, ThreeDimensionsFromElevationWhenTheSiteHasNoHeight) {
  Collected out;
  AoaEstimator est(out.sink());
  const Site site = hall_site("{method: per_epoch, converged_step_m: 1e-9}");
  est.set_site(site);
  const Eigen::Vector3d p(3.884, 3.599, 0.012);  // T2, on the floor
  advertise(est, site, "FLOORTAG", p, kT0);        // not in the site: no height, so 3D
  est.finish();
  ASSERT_EQ(out.poses.size(), 1u);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(out.poses[0].position[k], p(k), 1e-4) << k;
  EXPECT_FALSE(out.poses[0].status & pose_t::STATUS_2D);
  EXPECT_GT(out.poses[0].position_cov[8], 0.0);
}

TEST(AoaEstimator, MultipathCopiesAreResolvedByTheDuplicatePolicy) {
  // A2 reports twice: the direct angle, then a copy 30 deg off, later and 6 dB weaker.
  const Eigen::Vector3d p(2.186, 3.369, 1.528);
  struct Case {
    const char* policy;
    bool exact;  // the direct angle is kept
  };
  for (const Case c : {Case{"strongest", true}, Case{"first", true}, Case{"weakest", false}}) {
    Collected out;
    AoaEstimator est(out.sink());
    const Site site = hall_site(std::string("{method: per_epoch, duplicate: ") + c.policy +
                                ", converged_step_m: 1e-9}");
    est.set_site(site);
    est.on_event(event(site, "A1", "T1", p, kT0));
    est.on_event(event(site, "A2", "T1", p, kT0 + 3000, 0.0, -60));
    est.on_event(event(site, "A3", "T1", p, kT0 + 6000));
    est.on_event(event(site, "A2", "T1", p, kT0 + 20000, 30.0, -66));
    est.on_event(event(site, "A4", "T1", p, kT0 + 9000));
    est.finish();
    ASSERT_EQ(out.poses.size(), 1u) << c.policy;
    const double err = std::hypot(out.poses[0].position[0] - p.x(), out.poses[0].position[1] - p.y());
    if (c.exact) EXPECT_LT(err, kFloatTolM) << c.policy;
    else EXPECT_GT(err, 0.1) << c.policy;
    EXPECT_EQ(est.stats().duplicates, 1);
    EXPECT_EQ(out.poses[0].num_used, 4);
  }
}

TEST(AoaEstimator, NearestPolicyKeepsTheAngleClosestToTheTrack) {
  Collected out;
  AoaEstimator est(out.sink());
  const Site site = hall_site("{duplicate: nearest}");
  est.set_site(site);
  const Eigen::Vector3d p(2.186, 3.369, 1.528);
  for (int i = 0; i < 20; ++i) advertise(est, site, "T1", p, kT0 + i * 100000);
  // Now the copy is the stronger one: strongest would take it, nearest must not.
  const utime_t t = kT0 + 20 * 100000;
  est.on_event(event(site, "A1", "T1", p, t, 25.0, -50));
  est.on_event(event(site, "A1", "T1", p, t + 2000, 0.0, -70));
  est.on_event(event(site, "A2", "T1", p, t + 4000));
  est.finish();
  ASSERT_EQ(out.poses.size(), 21u);
  EXPECT_NEAR(out.poses.back().position[0], p.x(), 1e-3);
  EXPECT_NEAR(out.poses.back().position[1], p.y(), 1e-3);
  EXPECT_EQ(est.stats().rejected_gate, 0);
}

TEST(AoaEstimator, CalibrationPolynomialsUndoAKnownAnchorError) {
  // A3 reads 4 deg too high and 2 % too wide: measured = 1.02 * true + 4, so the correction is
  // true = (measured - 4) / 1.02.
  const Eigen::Vector3d p(2.267, 7.090, 1.528);
  const double c1 = 1.0 / 1.02, c0 = -4.0 / 1.02;
  for (bool calibrated : {false, true}) {
    Collected out;
    AoaEstimator est(out.sink());
    std::string params = "{method: per_epoch, converged_step_m: 1e-9";
    if (calibrated)
      params += ", calibration: {A3: {azimuth: {polynomial: [" + std::to_string(c0) + ", " +
                std::to_string(c1) + "]}}}";
    const Site site = hall_site(params + "}");
    est.set_site(site);
    const AnchorFrame f3 = anchor_frame(*site.find_anchor("A3"));
    const double true_az = rad_to_deg(predict_angle(f3, p, AngleKind::kAzimuth).angle_rad);
    est.on_event(event(site, "A1", "T1", p, kT0));
    est.on_event(event(site, "A2", "T1", p, kT0 + 1000));
    est.on_event(event(site, "A3", "T1", p, kT0 + 2000, 0.02 * true_az + 4.0));
    est.on_event(event(site, "A4", "T1", p, kT0 + 3000));
    est.finish();
    ASSERT_EQ(out.poses.size(), 1u);
    const double err = std::hypot(out.poses[0].position[0] - p.x(), out.poses[0].position[1] - p.y());
    if (calibrated) EXPECT_LT(err, 1e-4);  // std::to_string keeps 6 decimals of c0, c1
    else EXPECT_GT(err, 0.05);
  }
}

TEST(AoaEstimator, AngleCorrectionBeyondItsIntervalExtendsOrRejects) {
  AngleCorrection c;
  c.coefficients = {1.0, 1.1, 0.01, 0.0};
  c.valid_min_deg = -40;
  c.valid_max_deg = 50;
  EXPECT_DOUBLE_EQ(*c.apply(10), 1.0 + 11.0 + 1.0);
  // Beyond 50: the tangent at 50 (value 1 + 55 + 25 = 81, slope 1.1 + 1.0 = 2.1).
  EXPECT_DOUBLE_EQ(*c.apply(60), 81.0 + 2.1 * 10);
  c.beyond = AngleCorrection::Beyond::kReject;
  EXPECT_FALSE(c.apply(60));
  EXPECT_FALSE(c.apply(-41));
  EXPECT_FALSE(c.apply(std::nan("")));
  EXPECT_TRUE(AngleCorrection{}.is_identity());
  EXPECT_EQ(format_angle_correction(c),
            "{polynomial: [1, 1.1, 0.01], valid_deg: [-40, 50], beyond: reject}");
}

TEST(AoaEstimator, BadCalibrationAndParametersStopWithFileLineAndField) {
  AoaEstimator est([](const pose_t&) {});
  auto fails = [&](const std::string& params, const std::string& want) {
    try {
      est.set_site(hall_site(params));
      ADD_FAILURE() << "accepted: " << params;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  fails("{calibration: {A9: {azimuth: {polynomial: [1]}}}}", "no ble_aoa anchor 'A9'");
  fails("{calibration: {U1: {azimuth: {polynomial: [1]}}}}", "no ble_aoa anchor 'U1'");
  fails("{calibration: {A1: {azimuth: {polynomial: [1, 2, 3, 4, 5]}}}}", "1 to 4 coefficients");
  fails("{calibration: {A1: {azimuth: {polynomial: [0, 1], valid_deg: [10, -10]}}}}",
        "min < max");
  fails("{calibration: {A1: {azimuth: {polynomial: [0, 1], beyond: clamp}}}}",
        "expected extend or reject");
  fails("{calibration: {A1: {azimuth: {polynomial: [0, 1]}, tilt: 3}}}", "tilt");
  fails("{method: kalman}", "expected ekf or per_epoch");
  fails("{solver: foy}", "expected bearing_lines, gauss_newton, steepest_descent or lm");
  fails("{duplicate: loudest}", "expected strongest, first, weakest or nearest");
  fails("{azimuth_sigma_deg: -1}", "azimuth_sigma_deg");
  fails("{epoch_window_s: .nan}", "epoch_window_s");
  fails("{min_anchors: 1}", "min_anchors");
  fails("{gate_sigmaa: 3}", "gate_sigmaa");
  EXPECT_FALSE(est.has_site());  // nothing half-applied
}

TEST(AoaEstimator, BadEventsAreCountedNotUsed) {
  Collected out;
  AoaEstimator est(out.sink());
  const Eigen::Vector3d p(2.186, 3.369, 1.528);
  const Site site = hall_site("{method: per_epoch}");
  est.on_event(event(site, "A1", "T1", p, kT0));  // before any site
  est.set_site(site);
  ble_aoa_t m = event(site, "A1", "T1", p, kT0);
  m.azimuth_deg = NAN;
  est.on_event(m);
  m = event(site, "A1", "T1", p, kT0);
  m.azimuth_deg = 91;
  est.on_event(m);
  m = event(site, "A1", "T1", p, kT0);
  m.utime = -5;
  est.on_event(m);
  m = event(site, "A1", "", p, kT0);
  est.on_event(m);
  est.on_event(event(site, "A1", "T1", p, kT0));  // valid but alone: no fix
  m = event(site, "A1", "T1", p, kT0);
  m.anchor_id = "U1";  // a UWB anchor
  est.on_event(m);
  m.anchor_id = "ZZ";
  est.on_event(m);
  est.finish();
  EXPECT_TRUE(out.poses.empty());
  const AoaStats& s = est.stats();
  EXPECT_EQ(s.events_in, 8);
  EXPECT_EQ(s.dropped_no_site, 1);
  EXPECT_EQ(s.dropped_invalid, 4);
  EXPECT_EQ(s.dropped_unknown_anchor, 2);
  EXPECT_EQ(s.epochs_too_few_anchors, 1);
}

TEST(AoaEstimator, TagsAreTrackedApartAndTheirPosesComeOutInTimeOrder) {
  Collected out;
  AoaEstimator est(out.sink());
  const Site site = hall_site("{method: per_epoch, converged_step_m: 1e-9}");
  est.set_site(site);
  const Eigen::Vector3d pa(1.0, 2.0, 1.528), pb(3.5, 6.0, 1.528);
  for (int i = 0; i < 5; ++i) {
    // Interleaved: B's events fall inside A's epoch window and the other way round.
    const utime_t t = kT0 + i * 100000;
    const std::vector<std::pair<const char*, const char*>> order{
        {"A1", "T1"}, {"A1", "TB"}, {"A2", "T1"}, {"A2", "TB"},
        {"A3", "TB"}, {"A3", "T1"}, {"A4", "T1"}, {"A4", "TB"}};
    int k = 0;
    for (const auto& [a, tag] : order)
      est.on_event(event(site, a, tag, std::string(tag) == "T1" ? pa : pb, t + 2000 * k++));
  }
  est.finish();
  ASSERT_EQ(out.poses.size(), 10u);
  for (size_t i = 1; i < out.poses.size(); ++i)
    EXPECT_LE(out.poses[i - 1].utime, out.poses[i].utime);
  for (const pose_t& pose : out.poses) {
    const Eigen::Vector3d& want = pose.tag_id == "T1" ? pa : pb;
    EXPECT_NEAR(pose.position[0], want.x(), kFloatTolM) << pose.tag_id;
    EXPECT_NEAR(pose.position[1], want.y(), kFloatTolM) << pose.tag_id;
  }
  EXPECT_EQ(est.stats().duplicates, 0);
}

TEST(EpochGrouper, AnEpochIsEveryEventWithinTheWindowOfItsFirst) {
  std::vector<Epoch> epochs;
  EpochGrouper g(0.06, [&](Epoch& e) { epochs.push_back(e); });
  auto ev = [](utime_t t, size_t anchor) {
    AoaEvent e;
    e.utime = t;
    e.anchor = anchor;
    return e;
  };
  g.add("T", ev(kT0, 0));
  g.add("T", ev(kT0 + 25000, 1));
  g.add("T", ev(kT0 + 60000, 2));   // exactly the window: still in
  EXPECT_TRUE(epochs.empty());
  g.add("T", ev(kT0 + 100000, 0));  // the next advertisement closes the first epoch
  ASSERT_EQ(epochs.size(), 1u);
  EXPECT_EQ(epochs[0].utime, kT0);
  EXPECT_EQ(epochs[0].events.size(), 3u);
  g.flush(kT0 + 160000);            // the second's window ends now: not over yet
  EXPECT_EQ(epochs.size(), 1u);
  g.flush(kT0 + 160001);
  ASSERT_EQ(epochs.size(), 2u);
  EXPECT_EQ(epochs[1].events.size(), 1u);
  EXPECT_EQ(g.open_epochs(), 0u);
}

}  // namespace
}  // namespace ips::aoa

namespace ips::aoa {
namespace {

// Issue 22: one anchor's angles 10x noisier than configured (1 deg configured, 10 deg measured;
// the others at the configured 1 deg): within 10 s of data the consistency monitor names that
// anchor and the setting, the others stay quiet; with learning off the estimator is degraded.
TEST(AoaEstimator, AnAnchorTenTimesNoisierThanConfiguredIsNamedWithin10s) {
  for (const bool learn : {true, false}) {
    Collected out;
    AoaEstimator est(out.sink());
    const Site site = hall_site(std::string("{azimuth_sigma_deg: 1, edge_sigma_gain: 0, ") +
                                "learn_noise: " + (learn ? "true" : "false") + "}");
    est.set_site(site);
    std::mt19937 rng(7);
    std::normal_distribution<double> unit(0.0, 1.0);
    std::string named;
    double named_after_s = -1;
    for (int i = 0; i < 100; ++i) {  // 10 s at 10 Hz, standing still
      const Eigen::Vector3d p(2.186, 3.369, 1.528);
      const utime_t t = kT0 + i * 100000;
      int k = 0;
      for (const char* a : {"A1", "A2", "A3", "A4"})
        est.on_event(event(site, a, "T1", p, t + 5000 * k++,
                           (std::string(a) == "A3" ? 10.0 : 1.0) * unit(rng)));
      est.flush(t + 90000);
      if (named_after_s < 0 && est.consistency().problems().find("A3") != std::string::npos) {
        named = est.consistency().problems();
        named_after_s = 0.1 * i;
      }
    }
    est.finish();
    ASSERT_GE(named_after_s, 0) << "learn " << learn << ": " << est.consistency().summary();
    EXPECT_LE(named_after_s, 10.0);
    EXPECT_NE(named.find("ANGLE A3"), std::string::npos) << named;
    EXPECT_NE(named.find("azimuth_sigma_deg"), std::string::npos) << named;
    for (const char* quiet : {"ANGLE A1", "ANGLE A2", "ANGLE A4"})
      EXPECT_EQ(est.consistency().problems().find(quiet), std::string::npos)
          << est.consistency().problems();
    if (!learn) {
      EXPECT_TRUE(est.consistency().degraded()) << est.consistency().problems();
    }
    EXPECT_FALSE(out.poses.empty());
  }
}

}  // namespace
}  // namespace ips::aoa

namespace ips::aoa {
namespace {

// Issue 22: angles that fit no position (random within the field of view) never give a pose
// outside the site's box, in 3D (no tag height) too, and never one on an anchor.
TEST(AoaEstimator, NonsenseAnglesStayInsideTheSiteAndOffTheAnchors) {
  for (const char* params : {"{mode: 3d}", "{mode: 3d, method: per_epoch}", "{}"}) {
    Collected out;
    AoaEstimator est(out.sink());
    const Site site = hall_site(params);
    est.set_site(site);
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> angle(-85.0, 85.0);
    for (int i = 0; i < 600; ++i) {
      const utime_t t = kT0 + i * 100000;
      int k = 0;
      for (const char* a : {"A1", "A2", "A3", "A4"}) {
        ble_aoa_t m = event(site, a, "T1", Eigen::Vector3d(2, 4, 1), t + 5000 * k++);
        m.azimuth_deg = static_cast<float>(angle(rng));
        m.elevation_deg = static_cast<float>(angle(rng) / 2);
        est.on_event(m);
      }
    }
    est.finish();
    for (const pose_t& p : out.poses) {
      ASSERT_GE(p.position[0], -0.105 - 1.0) << params;
      ASSERT_LE(p.position[0], 4.651 + 1.0) << params;
      ASSERT_GE(p.position[1], -0.119 - 1.0) << params;
      ASSERT_LE(p.position[1], 8.126 + 1.0) << params;
      ASSERT_GE(p.position[2], 1.627 - 3.0) << params;
      ASSERT_LE(p.position[2], 1.723 + 1.0) << params;
      for (const char* a : {"A1", "A2", "A3", "A4"}) {
        const Eigen::Vector3d& ap = site.find_anchor(a)->position;
        EXPECT_GT(std::hypot(p.position[0] - ap.x(), p.position[1] - ap.y()), 0.05) << params;
      }
    }
  }
}

}  // namespace
}  // namespace ips::aoa
