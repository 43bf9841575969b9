// The TDoA tracker (estimators/uwb_tdoa/tdoa_estimator.hpp) on exact geometry: noise-free
// counters built by hand (tests/estimators/uwb_tdoa/exact_network.hpp) across the 2^40 wrap,
// with missed syncs, a blink at an anchor that has no clock yet, epochs one anchor short, a
// disabled anchor, outliers, bad input and bad parameters.
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "estimators/uwb_tdoa/tdoa_least_squares.hpp"
#include "tests/estimators/uwb_tdoa/exact_network.hpp"

namespace ips::uwb_tdoa {
namespace {

using test::ExactNetwork;
using test::kHz;
using test::kStart;

struct Rig {
  std::vector<pose_t> poses;
  std::vector<clock_t> clocks;
  TdoaEstimator est{[this](const pose_t& p) { poses.push_back(p); },
                    [this](const clock_t& c) { clocks.push_back(c); }, "uwb_tdoa"};
  ExactNetwork::Sink sink() {
    return [this](const uwb_rx_t& m) { est.on_rx(m); };
  }
};

Eigen::Vector3d static_point(double) { return {3.0, 5.0, 1.2}; }

// A circle of radius 2 m round (5, 4) at 1 m/s, at 1.2 m.
Eigen::Vector3d circle(double t) {
  return {5.0 + 2.0 * std::cos(t / 2.0), 4.0 + 2.0 * std::sin(t / 2.0), 1.2};
}

double horizontal_error(const pose_t& p, const Eigen::Vector3d& truth) {
  return std::hypot(p.position[0] - truth.x(), p.position[1] - truth.y());
}

// Truth at a pose's time: blinks are reported kLatencyS after they are sent.
Eigen::Vector3d truth_at(const pose_t& p, const std::function<Eigen::Vector3d(double)>& path) {
  return path(utime_to_s(p.utime - kStart) - test::kLatencyS);
}

TEST(TdoaEstimator, ExactCountersGiveTheExactPosition) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 30, static_point);
  ASSERT_GT(r.poses.size(), 200u);
  const pose_t& last = r.poses.back();
  EXPECT_EQ(last.source, "uwb_tdoa");
  EXPECT_EQ(last.tag_id, "T1");
  EXPECT_NEAR(last.position[0], 3.0, 0.003);
  EXPECT_NEAR(last.position[1], 5.0, 0.003);
  EXPECT_DOUBLE_EQ(last.position[2], 1.2);
  EXPECT_TRUE(last.status & pose_t::STATUS_OK);
  EXPECT_TRUE(last.status & pose_t::STATUS_2D);
  EXPECT_FALSE(last.status & pose_t::STATUS_COASTING);
  EXPECT_EQ(last.num_used, 4);  // 5 anchors: 4 differences to the reference
  EXPECT_LT(last.residual_m, 0.01);
  EXPECT_GT(last.position_cov[0], 0.0);
  // The filter assumes 0.17 ns (5 cm) per timestamp: its covariance says so, whatever the data.
  EXPECT_LT(last.position_cov[0], 0.05 * 0.05);
  EXPECT_LT(last.position_cov[4], 0.05 * 0.05);
  EXPECT_LT(std::hypot(last.velocity[0], last.velocity[1]), 0.01);
  // Every non-master anchor's clock, and the master's, are published at each sync.
  std::set<std::string> ids;
  for (const auto& c : r.clocks) ids.insert(c.anchor_id);
  EXPECT_EQ(ids.size(), 5u);
  EXPECT_EQ(r.est.stats().rejected_gate, 0);
  EXPECT_EQ(r.est.stats().initialisations, 1);
  EXPECT_EQ(r.est.master_id(), "A1");
}

TEST(TdoaEstimator, WalkingTagAcrossCounterWrapsIsTrackedClosely) {
  // 60 s: every anchor's counter wraps three or four times, some between a sync and a blink.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 60, circle);
  ASSERT_GT(r.poses.size(), 500u);
  double max_err = 0;
  for (const auto& p : r.poses)
    max_err = std::max(max_err, horizontal_error(p, truth_at(p, circle)));
  std::printf("exact counters, circle 1 m/s, 60 s: %zu poses, max horizontal error %.4f m\n",
              r.poses.size(), max_err);
  // Constant-velocity lag on a 2 m circle (0.5 m/s^2) with mm-level measurements: a few mm.
  EXPECT_LT(max_err, 0.02);
  EXPECT_EQ(r.est.stats().rejected_gate, 0);
  EXPECT_EQ(r.est.stats().rejected_geometry, 0);
}

TEST(TdoaEstimator, ReferenceAndUpdateChoicesAgreeOnExactGeometry) {
  const ExactNetwork net = test::room_network();
  for (const char* params : {"{reference: master}", "{reference: A3}", "{reference: nearest}",
                             "{update: sequential}", "{update: sequential, reference: A4}"}) {
    Rig r;
    r.est.set_site(net.site(1.2, params));
    net.run(r.sink(), 20, circle);
    ASSERT_GT(r.poses.size(), 100u) << params;
    double max_err = 0;
    for (size_t k = 20; k < r.poses.size(); ++k)
      max_err = std::max(max_err, horizontal_error(r.poses[k], truth_at(r.poses[k], circle)));
    EXPECT_LT(max_err, 0.02) << params;
  }
}

TEST(TdoaEstimator, ThreeDimensionalWhenTheTagHeightIsUnknown) {
  // Anchors at different heights make the height observable; T1 is not in the site's tags.
  const ExactNetwork net({{"A1", {0, 0, 2.8}, 1.0, 10},
                          {"A2", {10, 0, 0.4}, 5.0, -20},
                          {"A3", {10, 8, 2.8}, 9.0, 30},
                          {"A4", {0, 8, 0.4}, 13.0, -40},
                          {"A5", {5, 4, 3.0}, 17.0, 5},
                          {"A6", {5, 0, 1.6}, 2.0, 0}},
                         0);
  Rig r;
  r.est.set_site(net.site(NAN));
  const Eigen::Vector3d truth(6.0, 2.5, 0.9);
  net.run(r.sink(), 20, [&](double) { return truth; });
  ASSERT_FALSE(r.poses.empty());
  const pose_t& last = r.poses.back();
  EXPECT_FALSE(last.status & pose_t::STATUS_2D);
  EXPECT_NEAR(last.position[0], 6.0, 0.005);
  EXPECT_NEAR(last.position[1], 2.5, 0.005);
  EXPECT_NEAR(last.position[2], 0.9, 0.01);
  EXPECT_EQ(last.num_used, 5);
  EXPECT_GT(last.position_cov[8], 0.0);
}

TEST(TdoaEstimator, BlinkAtAnAnchorWithoutSyncIsNotUsed) {
  // A5 never hears a sync: its blink receptions cannot be put in master time. The other four
  // anchors still give the exact position.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 20, static_point, [](int i, int32_t) { return i != 4; });
  ASSERT_FALSE(r.poses.empty());
  EXPECT_NEAR(r.poses.back().position[0], 3.0, 0.005);
  EXPECT_NEAR(r.poses.back().position[1], 5.0, 0.005);
  EXPECT_EQ(r.poses.back().num_used, 3);
  // Every A5 report, and those of A2..A4 before their clocks track (the second sync, t = 2 s:
  // two syncs give offset and rate): 200 + 3 x 20. Until then only the master's reception
  // converts: too few for a difference.
  EXPECT_EQ(r.est.stats().rx_no_clock, 200 + 3 * 20);
  EXPECT_EQ(r.est.stats().epochs_too_few, 20);
  EXPECT_GT(utime_to_s(r.poses.front().utime - kStart), 2.0);
}

TEST(TdoaEstimator, EpochsOneAnchorShortOfAFixDoNotInitialise) {
  // 2D needs 4 anchors to start (3 differences for 2 unknowns and a check): with 3, nothing.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 10, static_point, nullptr, [](int i, int32_t) { return i < 3; });
  EXPECT_TRUE(r.poses.empty());
  EXPECT_EQ(r.est.stats().initialisations, 0);
  EXPECT_GT(r.est.stats().epochs, 90);
  // 3D needs 5: with 4, nothing either.
  Rig r3;
  r3.est.set_site(net.site(NAN));
  net.run(r3.sink(), 10, static_point, nullptr, [](int i, int32_t) { return i < 4; });
  EXPECT_TRUE(r3.poses.empty());
  EXPECT_EQ(r3.est.stats().initialisations, 0);
}

TEST(TdoaEstimator, OnceTrackingTwoAnchorsStillUpdate) {
  // Started with all five, then from blink 100 on only A2 and A3 hear the tag: one difference a
  // blink keeps the (static) track updated, never coasting.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 20, static_point, nullptr,
          [](int i, int32_t seq) { return seq < 100 || i == 1 || i == 2; });
  ASSERT_GT(r.poses.size(), 150u);
  const pose_t& last = r.poses.back();
  EXPECT_EQ(last.num_used, 1);
  EXPECT_FALSE(last.status & pose_t::STATUS_COASTING);
  // On the hyperbola |p - A2| - |p - A3| of the truth within a cm (the filter weighs each
  // difference as 7 cm of noise, so it closes in gradually); along it nothing holds the estimate
  // but its velocity, so it may wander a few cm in 10 s.
  const Eigen::Vector3d p(last.position[0], last.position[1], last.position[2]);
  const Eigen::Vector3d a2 = net.anchors()[1].position, a3 = net.anchors()[2].position;
  const Eigen::Vector3d truth = static_point(0);
  EXPECT_NEAR((p - a2).norm() - (p - a3).norm(), (truth - a2).norm() - (truth - a3).norm(), 0.01);
  EXPECT_NEAR(last.position[0], 3.0, 0.05);
  EXPECT_NEAR(last.position[1], 5.0, 0.05);
  EXPECT_EQ(r.est.stats().initialisations, 1);
  EXPECT_EQ(r.est.stats().epochs_too_few, 20);  // only the blinks before the clocks track
}

TEST(TdoaEstimator, DisabledAnchorIsIgnored) {
  // A6 is in the site but disabled, with a wildly wrong clock: its reports are dropped.
  const ExactNetwork net({{"A1", {0.0, 0.0, 2.5}, 3.982187, 12.0},
                          {"A2", {10.0, 0.0, 2.5}, 6.525657, -31.0},
                          {"A3", {10.0, 8.0, 2.5}, 16.9, 44.0},
                          {"A4", {0.0, 8.0, 2.5}, 0.25, -7.5},
                          {"A6", {5.0, 0.0, 2.5}, 4.0, 5000.0}},
                         0);
  std::string y =
      "anchors:\n"
      "  - {id: A1, kind: uwb_tdoa, position: [0, 0, 2.5]}\n"
      "  - {id: A2, kind: uwb_tdoa, position: [10, 0, 2.5]}\n"
      "  - {id: A3, kind: uwb_tdoa, position: [10, 8, 2.5]}\n"
      "  - {id: A4, kind: uwb_tdoa, position: [0, 8, 2.5]}\n"
      "  - {id: A6, kind: uwb_tdoa, position: [5, 0, 2.5], enabled: false}\n"
      "  - {id: U1, kind: uwb, position: [5, 8, 2.5]}\n"
      "tags:\n  - {id: T1, height_m: 1.2}\n";
  Rig r;
  r.est.set_site(parse_site_text(y, "site.yaml"));
  net.run(r.sink(), 20, static_point);
  // A TWR anchor is not a TDoA anchor either.
  r.est.on_rx(ExactNetwork::report(kStart + 20'500'000, "U1", "T1", false, 500, 5));
  ASSERT_FALSE(r.poses.empty());
  EXPECT_NEAR(r.poses.back().position[0], 3.0, 0.005);
  EXPECT_NEAR(r.poses.back().position[1], 5.0, 0.005);
  EXPECT_EQ(r.poses.back().num_used, 3);
  EXPECT_EQ(r.est.stats().dropped_unknown_anchor, 200 + 10 + 1);  // blinks, syncs, U1
  for (const auto& c : r.clocks) EXPECT_NE(c.anchor_id, "A6");
}

TEST(TdoaEstimator, OutlierReceptionIsGated) {
  // A2 reports blink 150 6 ns late (1.8 m, a reflection): gated, the track unharmed.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 14.9, static_point);
  std::vector<uwb_rx_t> blink;
  net.blink([&](const uwb_rx_t& m) { blink.push_back(m); }, "T1", 149, 14.901, static_point(0));
  blink[1].rx_counter = counter_mod(blink[1].rx_counter + 383);
  for (const auto& m : blink) r.est.on_rx(m);
  r.est.flush();
  EXPECT_EQ(r.est.stats().rejected_gate + r.est.stats().rejected_geometry, 1);
  EXPECT_NEAR(r.poses.back().position[0], 3.0, 0.005);
  EXPECT_NEAR(r.poses.back().position[1], 5.0, 0.005);
  EXPECT_EQ(r.poses.back().num_used, 3);
}

TEST(TdoaEstimator, TrackRestartsAfterCoastingTooLong) {
  // The tag is not heard for 5 s (max_coast_s 3) and reappears 4 m away: a fresh fix, flagged.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  auto path = [](double t) {
    return t < 12 ? Eigen::Vector3d(3, 5, 1.2) : Eigen::Vector3d(7, 5, 1.2);
  };
  net.run(r.sink(), 25, path, nullptr, [](int, int32_t seq) { return seq < 70 || seq >= 120; });
  EXPECT_EQ(r.est.stats().initialisations, 2);
  bool flagged = false;
  for (const auto& p : r.poses) flagged |= (p.status & pose_t::STATUS_REINITIALISED) != 0;
  EXPECT_TRUE(flagged);
  EXPECT_NEAR(r.poses.back().position[0], 7.0, 0.005);
}

TEST(TdoaEstimator, TrackRestartsAfterRepeatedRejections) {
  // The tag is heard without a gap but jumps 4 m at 12 s (a track locked onto a wrong solution
  // looks the same): every difference is gated, and after reinit_after_rejections (5) such blinks
  // a fresh fix takes over.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  auto path = [](double t) {
    return t < 12 ? Eigen::Vector3d(3, 5, 1.2) : Eigen::Vector3d(7, 5, 1.2);
  };
  net.run(r.sink(), 20, path);
  EXPECT_EQ(r.est.stats().initialisations, 2);
  EXPECT_EQ(r.est.stats().rejected_gate, 5 * 4);  // 5 blinks of 4 differences
  bool flagged = false;
  for (const auto& p : r.poses) flagged |= (p.status & pose_t::STATUS_REINITIALISED) != 0;
  EXPECT_TRUE(flagged);
  EXPECT_NEAR(r.poses.back().position[0], 7.0, 0.005);
  EXPECT_NEAR(r.poses.back().position[1], 5.0, 0.005);
}

TEST(TdoaEstimator, LateAndDuplicateReportsAreCounted) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  net.run(r.sink(), 10, static_point);
  const size_t before = r.poses.size();
  std::vector<uwb_rx_t> blink;
  net.blink([&](const uwb_rx_t& m) { blink.push_back(m); }, "T1", 100, 10.001, static_point(0));
  r.est.on_rx(blink[0]);
  r.est.on_rx(blink[0]);  // the same anchor twice
  EXPECT_EQ(r.est.stats().dropped_duplicate, 1);
  for (size_t k = 1; k < blink.size(); ++k) r.est.on_rx(blink[k]);
  EXPECT_EQ(r.poses.size(), before + 1);  // every anchor reported: processed at once
  // An anchor's report of the processed blink again: a copy (a LAN duplicates datagrams), routine.
  // It was counted as late, a fault, and kept ips-fuse degraded in the soak.
  r.est.on_rx(blink[2]);
  EXPECT_EQ(r.est.stats().dropped_duplicate, 2);
  EXPECT_EQ(r.est.stats().dropped_late, 0);
  // A blink the last anchor has not reported yet, closed when its window has passed (another
  // tag's report): that anchor's report after it is a straggler, late.
  std::vector<uwb_rx_t> next;
  net.blink([&](const uwb_rx_t& m) { next.push_back(m); }, "T1", 101, 10.101, static_point(0));
  for (size_t k = 0; k + 1 < next.size(); ++k) r.est.on_rx(next[k]);
  uwb_rx_t other = next[0];
  other.sender_id = "T2";
  other.utime += 60'000;  // beyond epoch_window_s
  r.est.on_rx(other);
  EXPECT_EQ(r.poses.size(), before + 2);
  r.est.on_rx(next.back());
  EXPECT_EQ(r.est.stats().dropped_late, 1);
  EXPECT_EQ(r.est.stats().dropped_duplicate, 2);
  uwb_rx_t old = blink[0];
  old.utime -= 500'000;  // 0.5 s behind the newest: beyond reorder_tolerance_s
  old.seq = 95;
  r.est.on_rx(old);
  EXPECT_EQ(r.est.stats().dropped_late, 2);
}

TEST(TdoaEstimator, BadReportsAreCountedNotUsed) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  auto rx = [](auto&& change) {
    uwb_rx_t m = ExactNetwork::report(kStart + 1'000'000, "A2", "T1", false, 1, 1000);
    change(m);
    return m;
  };
  r.est.on_rx(rx([](uwb_rx_t& m) { m.rx_counter = kCounterModulus; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.rx_counter = -1; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.counter_hz = NAN; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.counter_hz = 0; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.utime = 0; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.utime = INT64_MAX; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.sender_id = ""; }));
  r.est.on_rx(rx([](uwb_rx_t& m) { m.sender_id = "A3"; }));      // an anchor is not a tag
  r.est.on_rx(rx([](uwb_rx_t&) {}));                             // fixes the counter frequency
  r.est.on_rx(rx([](uwb_rx_t& m) { m.counter_hz = 499.2e6; }));  // another frequency
  r.est.on_rx(rx([](uwb_rx_t& m) { m.anchor_id = "NOPE"; }));
  EXPECT_EQ(r.est.stats().dropped_invalid, 9);
  EXPECT_EQ(r.est.stats().dropped_unknown_anchor, 1);
  EXPECT_TRUE(r.poses.empty());
}

TEST(TdoaEstimator, NoSiteNoOutput) {
  const ExactNetwork net = test::room_network();
  Rig r;
  net.run(r.sink(), 5, static_point);
  EXPECT_TRUE(r.poses.empty());
  EXPECT_TRUE(r.clocks.empty());
  EXPECT_EQ(r.est.stats().rx_in, 50 * 5 + 3 * 5);
}

TEST(TdoaEstimator, TagIdsOffTheBusCannotExhaustMemory) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site(1.2, "{max_tags: 3}"));
  for (int i = 0; i < 10; ++i)
    r.est.on_rx(
        ExactNetwork::report(kStart + 1'000'000 + i, "A2", "tag" + std::to_string(i), false, 1, 5));
  EXPECT_EQ(r.est.stats().dropped_too_many_tags, 7);
  // Much later the silent tracks make room.
  r.est.on_rx(ExactNetwork::report(kStart + 60'000'000, "A2", "new", false, 1, 5));
  EXPECT_EQ(r.est.stats().dropped_too_many_tags, 7);
}

TEST(TdoaEstimator, SeveralTagsAreTrackedApart) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  const Eigen::Vector3d t2(8.0, 2.0, 1.5);
  for (int32_t k = 0; k < 150; ++k) {
    if (k % 20 == 0) net.sync(r.sink(), k / 20);
    net.blink(r.sink(), "T1", k, 0.1 * k + 0.001, static_point(0));
    net.blink(r.sink(), "T2", k, 0.1 * k + 0.051, t2);
  }
  r.est.flush();
  const pose_t* last1 = nullptr;
  const pose_t* last2 = nullptr;
  for (const auto& p : r.poses) (p.tag_id == "T1" ? last1 : last2) = &p;
  ASSERT_TRUE(last1 && last2);
  EXPECT_NEAR(last1->position[0], 3.0, 0.005);
  EXPECT_NEAR(last2->position[0], 8.0, 0.005);
  EXPECT_NEAR(last2->position[1], 2.0, 0.005);
  EXPECT_FALSE(last2->status & pose_t::STATUS_2D);  // T2 is not in the site: 3D
  EXPECT_NEAR(last2->position[2], 1.5, 0.3);        // coplanar but for A5: height weak
}

TEST(TdoaEstimator, PublishesAtMostOncePerPeriod) {
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site(1.2, "{publish_period_s: 0.25}"));
  net.run(r.sink(), 20, static_point);
  for (size_t k = 1; k < r.poses.size(); ++k)
    EXPECT_GE(r.poses[k].utime - r.poses[k - 1].utime, 250'000);
  EXPECT_GT(r.poses.size(), 50u);
  EXPECT_EQ(r.poses.back().num_used, 3 * 4);  // 3 blinks of 4 differences since the last pose
}

TEST(TdoaEstimator, SameInputSameOutput) {
  const ExactNetwork net = test::room_network();
  auto once = [&] {
    Rig r;
    r.est.set_site(net.site());
    net.run(r.sink(), 20, circle);
    std::vector<uint8_t> bytes;
    for (const auto& p : r.poses) {
      std::vector<uint8_t> b(static_cast<size_t>(p.getEncodedSize()));
      p.encode(b.data(), 0, static_cast<int>(b.size()));
      bytes.insert(bytes.end(), b.begin(), b.end());
    }
    return bytes;
  };
  const auto a = once();
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, once());
}

TEST(TdoaFix, LeastSquaresOnRangeDifferences) {
  const std::vector<Eigen::Vector3d> anchors = {
      {0, 0, 2.5}, {10, 0, 2.5}, {10, 8, 2.5}, {0, 8, 2.5}, {5, 4.2, 2.9}};
  for (const Eigen::Vector3d& truth :
       {Eigen::Vector3d(3, 5, 1.2), Eigen::Vector3d(0.5, 0.5, 1.2), Eigen::Vector3d(9.7, 7.6, 1.2),
        Eigen::Vector3d(5, 4.1, 1.2)}) {
    std::vector<double> z;
    for (size_t k = 1; k < anchors.size(); ++k)
      z.push_back((truth - anchors[k]).norm() - (truth - anchors[0]).norm());
    TdoaFixOptions o;
    o.height_m = 1.2;
    const TdoaFix fix = solve_tdoa_fix(anchors, z, o);
    ASSERT_TRUE(fix.ok);
    EXPECT_NEAR((fix.position - truth).norm(), 0.0, 1e-4) << truth.transpose();
    EXPECT_LT(fix.residual_rms_m, 1e-4);
    EXPECT_GT(fix.covariance_unit(0, 0), 0.0);
  }
  // One difference fewer than unknowns plus one: refused.
  TdoaFixOptions o;
  o.height_m = 1.2;
  EXPECT_FALSE(solve_tdoa_fix(std::span(anchors.data(), 3), std::vector<double>{0.1, 0.2}, o).ok);
}

std::string config_error(const std::string& params) {
  const ExactNetwork net = test::room_network();
  Rig r;
  try {
    r.est.set_site(net.site(1.2, params));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(TdoaParams, BadValuesNameTheField) {
  // The site text puts estimators.uwb_tdoa on line 11.
  EXPECT_EQ(config_error("{rx_sigma_ns: -1}"),
            "site.yaml:11: estimators.uwb_tdoa.rx_sigma_ns: must be in (0, 1e6]");
  EXPECT_EQ(config_error("{sync_match_window_s: 9}"),
            "site.yaml:11: estimators.uwb_tdoa.sync_match_window_s: must be in (0, 8]");
  EXPECT_EQ(config_error("{max_tags: 0}"),
            "site.yaml:11: estimators.uwb_tdoa.max_tags: must be in [1, 100000]");
  EXPECT_EQ(config_error("{master: A9}"),
            "site.yaml:11: estimators.uwb_tdoa.master: 'A9' is not an enabled uwb_tdoa anchor of "
            "the site");
  EXPECT_EQ(config_error("{reference: farthest}"),
            "site.yaml:11: estimators.uwb_tdoa.reference: expected nearest, master or an enabled "
            "uwb_tdoa anchor of the site, got 'farthest'");
  EXPECT_EQ(config_error("{update: batch}"),
            "site.yaml:11: estimators.uwb_tdoa.update: expected vector or sequential");
  EXPECT_EQ(config_error("{mode: 4d}"),
            "site.yaml:11: estimators.uwb_tdoa.mode: expected auto (2D when the tag height is "
            "known) or 3d");
  EXPECT_NE(config_error("{accel: 1}").find("accel"), std::string::npos);  // misspelt key
  EXPECT_EQ(config_error("{gate_sigma: .nan}").substr(0, 40),
            "site.yaml:11: estimators.uwb_tdoa.gate_s");
  EXPECT_EQ(config_error("{master: A2, reference: A5, update: sequential, mode: 3d}"), "no error");
  // A bad site leaves the previous one in place.
  const ExactNetwork net = test::room_network();
  Rig r;
  r.est.set_site(net.site());
  EXPECT_THROW(r.est.set_site(net.site(1.2, "{gate_sigma: 0}")), ConfigError);
  EXPECT_TRUE(r.est.has_site());
  EXPECT_EQ(r.est.params().gate_sigma, 4.0);
}

}  // namespace
}  // namespace ips::uwb_tdoa
