// The BLE angle-of-arrival model (drivers/sim/models/ble_aoa.cpp): the XPLR-AOA angle
// conventions of ../shared/reference/000_ble_aoa.md checked against hand-computed geometry, and the
// generated data checked against the model's own parameters with sample statistics.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <ips/ble_aoa_t.hpp>
#include <map>
#include <set>
#include <sstream>

#include "drivers/sim/simulator.hpp"
#include "tests/drivers/sim/sim_test_support.hpp"

namespace ips::sim {
namespace {

constexpr utime_t kStart = 1767225600000000;
constexpr double kDeg = M_PI / 180.0;

// The hall of the reference (Table 7.2, mounting yaws of (7.2)).
const char* kHallAnchors =
    "    - {id: A1, kind: ble_aoa, position: [0.000, 0.000, 1.683], orientation_deg: [0, 0, "
    "60.73]}\n"
    "    - {id: A2, kind: ble_aoa, position: [4.552, -0.119, 1.627], orientation_deg: [0, 0, "
    "119.27]}\n"
    "    - {id: A3, kind: ble_aoa, position: [-0.105, 8.126, 1.723], orientation_deg: [0, 0, "
    "-60.73]}\n"
    "    - {id: A4, kind: ble_aoa, position: [4.651, 8.103, 1.681], orientation_deg: [0, 0, "
    "-119.27]}\n";
const Eigen::Vector3d kHallT1(2.186, 3.369, 1.528);
const Eigen::Vector3d kHallT5(2.060, 0.831, -0.009);

// Error sources off: the angles are the geometric ones, unrounded.
const char* kClean =
    "noise_sigma_deg: 0, edge_quadratic_per_deg: 0, edge_cubic_per_deg2: 0, "
    "angle_resolution_deg: 0, rssi_sigma_db: 0";

// A scenario with the given anchors (YAML list items), tags T1, T2, ... standing at `tags`
// (a 1 mm step onto the point in the first 10 us), and a ble_aoa section `{params}`.
std::string scenario(const std::string& anchors, const std::vector<Eigen::Vector3d>& tags,
                     const std::string& params, double duration_s) {
  std::ostringstream s;
  s.precision(12);
  s << "duration_s: " << duration_s << "\nsite:\n  anchors:\n" << anchors << "  tags:\n";
  for (size_t i = 0; i < tags.size(); ++i) s << "    - {id: T" << i + 1 << "}\n";
  s << "trajectories:\n";
  for (size_t i = 0; i < tags.size(); ++i) {
    const Eigen::Vector3d& p = tags[i];
    s << "  - {tag: T" << i + 1 << ", loop: false, speed_mps: 100, waypoints: [[" << p.x() - 0.001
      << ", " << p.y() << ", " << p.z() << "], [" << p.x() << ", " << p.y() << ", " << p.z()
      << "]]}\n";
  }
  s << "sensors:\n  ble_aoa: {" << params << "}\n";
  return s.str();
}

std::vector<ble_aoa_t> run_scenario(const Scenario& sc, uint64_t seed) {
  return simulated_messages<ble_aoa_t>(sc, seed, "BLE_AOA");
}

std::vector<ble_aoa_t> run(const std::string& text, uint64_t seed = 1) {
  return run_scenario(parse_scenario_text(text, "test.yaml"), seed);
}

// Geometric azimuth and elevation (deg) of `tag` seen from `a`, in the XPLR-AOA convention the
// model documents: anchor frame x = normal, y = left, z = up (R = Rz(yaw) Ry(pitch) Rx(roll));
// azimuth positive to the anchor's right, elevation positive towards its up.
Eigen::Vector2d geometric(const Anchor& a, const Eigen::Vector3d& tag) {
  const Eigen::Vector3d& o = a.orientation_rad;
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(o.z(), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(o.y(), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(o.x(), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  const Eigen::Vector3d b = r.transpose() * (tag - a.position);
  return {std::atan2(-b.y(), b.x()) / kDeg, std::atan2(b.z(), std::hypot(b.x(), b.y())) / kDeg};
}

struct Stats {
  double n = 0, sum = 0, sum_sq = 0;
  void add(double v) {
    n += 1;
    sum += v;
    sum_sq += v * v;
  }
  double mean() const { return sum / n; }
  double sd() const { return std::sqrt((sum_sq - sum * sum / n) / (n - 1)); }
};

// Events of one anchor grouped by advertisement: with report latency and multipath delay of at
// most 25 ms each, one advertisement's events span <= 25 ms after the direct one, and the next
// advertisement (>= 90 ms later) reports >= 40 ms after the last of them. A gap > 32 ms splits.
std::vector<std::vector<ble_aoa_t>> groups_of(const std::vector<ble_aoa_t>& ev,
                                              const std::string& anchor) {
  std::vector<std::vector<ble_aoa_t>> g;
  for (const auto& m : ev) {
    if (m.anchor_id != anchor) continue;
    if (g.empty() || m.utime - g.back().back().utime > 32'000) g.emplace_back();
    g.back().push_back(m);
  }
  return g;
}

TEST(BleAoaModel, ZeroNoiseGivesTheGeometricAnglesOfTheReference) {
  // Reference section 6, target 1 (noise-free theta at A1..A4, from alpha = beta - theta (7.2)):
  // hall T1: 3.71, -4.88, 3.55, -1.76; hall T5: 38.76, -39.86, 12.74, -9.66. By hand, A1 and T1:
  // bearing atan2(3.369, 2.186) = 57.02 deg, theta = 60.73 - 57.02 = 3.71 deg (tag to the right
  // of the normal); elevation atan2(1.528 - 1.683, hypot(2.186, 3.369) = 4.0161) = -2.210 deg.
  // A1 and T5: atan2(-0.009 - 1.683, hypot(2.060, 0.831) = 2.2213) = -37.297 deg.
  const std::vector<Eigen::Vector3d> tags = {kHallT1, kHallT5};
  const auto ev = run(scenario(kHallAnchors, tags, kClean, 1.0));
  const std::map<std::string, std::array<double, 2>> az = {{"A1", {3.71, 38.76}},
                                                           {"A2", {-4.88, -39.86}},
                                                           {"A3", {3.55, 12.74}},
                                                           {"A4", {-1.76, -9.66}}};
  std::map<std::string, int> count;
  for (const auto& m : ev) {
    const int k = m.tag_id == "T1" ? 0 : 1;
    EXPECT_NEAR(m.azimuth_deg, az.at(m.anchor_id)[k], 0.006) << m.anchor_id << " " << m.tag_id;
    if (m.anchor_id == "A1") {
      EXPECT_NEAR(m.elevation_deg, k == 0 ? -2.210 : -37.297, 0.001);
    }
    ++count[m.anchor_id + m.tag_id];
  }
  EXPECT_EQ(count.size(), 8u);  // every anchor sees both tags, ~10 times in 1 s
  for (const auto& [key, n] : count) EXPECT_GE(n, 9) << key;
}

TEST(BleAoaModel, TiltedAndRolledAnchorsMeasureInTheirMountingFrame) {
  // P: ceiling-mounted, pitch 90 (normal straight down, its "up" along site +x).
  // R: roll 90 about a normal along +x (its left is site up). Y: yaw 90 (facing north).
  const std::string anchors =
      "    - {id: P, kind: ble_aoa, position: [0, 0, 3], orientation_deg: [0, 90, 0]}\n"
      "    - {id: R, kind: ble_aoa, position: [-2, 0, 0], orientation_deg: [90, 0, 0]}\n"
      "    - {id: Y, kind: ble_aoa, position: [0, -3, 1], orientation_deg: [0, 0, 90]}\n";
  const std::vector<Eigen::Vector3d> tags = {{1, 0, 1}, {0, 1, 1}};
  // By hand, anchor frame (normal, left, up) coordinates b of the direction d to the tag:
  //   P, T1: d = (1, 0, -2), b = (2, 0, 1): azimuth 0, elevation atan(1/2) = 26.565.
  //   P, T2: d = (0, 1, -2), b = (2, 1, 0): azimuth -26.565 (tag on the left), elevation 0.
  //   R, T1: d = (3, 0, 1),  b = (3, 1, 0): azimuth -atan(1/3) = -18.435, elevation 0.
  //   R, T2: d = (2, 1, 1),  b = (2, 1, -1): azimuth -26.565, elevation -atan(1/sqrt 5) = -24.095.
  //   Y, T1: d = (1, 3, 0),  b = (3, -1, 0): azimuth +18.435 (east is right of north), elev. 0.
  //   Y, T2: d = (0, 4, 0),  b = (4, 0, 0): 0, 0.
  const std::map<std::string, std::array<double, 2>> want = {
      {"PT1", {0, 26.565}},        {"PT2", {-26.565, 0}}, {"RT1", {-18.435, 0}},
      {"RT2", {-26.565, -24.095}}, {"YT1", {18.435, 0}},  {"YT2", {0, 0}}};
  const auto ev = run(scenario(anchors, tags, kClean, 1.0));
  std::set<std::string> seen;
  for (const auto& m : ev) {
    const std::string key = m.anchor_id + m.tag_id;
    EXPECT_NEAR(m.azimuth_deg, want.at(key)[0], 0.001) << key;
    EXPECT_NEAR(m.elevation_deg, want.at(key)[1], 0.001) << key;
    seen.insert(key);
  }
  EXPECT_EQ(seen.size(), 6u);
}

TEST(BleAoaModel, NoiseSigmaAndGivenBiasesAreRecovered) {
  // 300 s at 10 Hz: n = 3000 per anchor and angle. Mean: SE = 5/sqrt(3000) = 0.09 deg, tolerance
  // 0.4 (> 4 SE); sd: SE = 5/sqrt(2n) = 0.065 deg, tolerance 0.3.
  Scenario sc = parse_scenario_text(
      scenario(kHallAnchors, {kHallT1},
               "noise_sigma_deg: 5, edge_noise_gain: 0, edge_quadratic_per_deg: 0, "
               "edge_cubic_per_deg2: 0, angle_resolution_deg: 0, "
               "anchor_bias_deg: {A1: [2.5, -1.5], A3: [-4, 3]}",
               300),
      "test.yaml");
  const std::map<std::string, Eigen::Vector2d> bias = {
      {"A1", {2.5, -1.5}}, {"A2", {0, 0}}, {"A3", {-4, 3}}, {"A4", {0, 0}}};
  std::map<std::string, std::array<Stats, 2>> err;
  for (const auto& m : run_scenario(sc, 5)) {
    const Eigen::Vector2d g = geometric(*sc.site.find_anchor(m.anchor_id), kHallT1);
    err[m.anchor_id][0].add(m.azimuth_deg - g.x());
    err[m.anchor_id][1].add(m.elevation_deg - g.y());
  }
  ASSERT_EQ(err.size(), 4u);
  for (const auto& [id, e] : err) {
    for (int k = 0; k < 2; ++k) {
      EXPECT_NEAR(e[k].n, 3000, 1) << id;
      EXPECT_NEAR(e[k].mean(), bias.at(id)[k], 0.4) << id << " angle " << k;
      EXPECT_NEAR(e[k].sd(), 5.0, 0.3) << id << " angle " << k;
    }
  }
}

TEST(BleAoaModel, DrawnBiasesHaveTheConfiguredSigmaAndBelongToTheAnchor) {
  // 40 anchors on a circle facing the tags; no noise, so every event's error is its anchor's
  // bias. 80 draws of N(0, 3): sd SE = 3/sqrt(160) = 0.24 (tolerance 0.8), mean SE = 0.34 (1.1).
  std::ostringstream anchors;
  for (int i = 0; i < 40; ++i) {
    const double a = 2 * M_PI * i / 40;
    anchors << "    - {id: B" << i << ", kind: ble_aoa, position: [" << 6 * std::cos(a) << ", "
            << 6 * std::sin(a) << ", 1.2], orientation_deg: [0, 0, " << a / kDeg + 180 << "]}\n";
  }
  const std::string params =
      "noise_sigma_deg: 0, bias_sigma_deg: 3, edge_quadratic_per_deg: 0, edge_cubic_per_deg2: 0, "
      "angle_resolution_deg: 0";
  const std::vector<Eigen::Vector3d> tags = {{0, 0, 1.2}, {0.5, 0.3, 1.0}};
  const std::string text = scenario(anchors.str(), tags, params, 0.5);
  Scenario sc = parse_scenario_text(text, "test.yaml");
  std::map<std::string, std::map<std::string, Eigen::Vector2d>> bias;  // anchor, tag
  for (const auto& m : run_scenario(sc, 9)) {
    const Eigen::Vector2d g =
        geometric(*sc.site.find_anchor(m.anchor_id), tags[m.tag_id == "T1" ? 0 : 1]);
    const Eigen::Vector2d b(m.azimuth_deg - g.x(), m.elevation_deg - g.y());
    auto& seen = bias[m.anchor_id];
    if (seen.count(m.tag_id)) {
      EXPECT_LT((seen[m.tag_id] - b).norm(), 1e-4) << "constant";
    }
    seen[m.tag_id] = b;
  }
  ASSERT_EQ(bias.size(), 40u);
  Stats s;
  for (auto& [id, per_tag] : bias) {
    ASSERT_EQ(per_tag.size(), 2u);
    EXPECT_LT((per_tag["T1"] - per_tag["T2"]).norm(), 1e-4) << id << ": same for every tag";
    s.add(per_tag["T1"].x());
    s.add(per_tag["T1"].y());
  }
  EXPECT_NEAR(s.mean(), 0.0, 1.1);
  EXPECT_NEAR(s.sd(), 3.0, 0.8);
  // Another seed draws other biases.
  const auto other = run(text, 10);
  ASSERT_FALSE(other.empty());
  const Eigen::Vector2d g =
      geometric(*sc.site.find_anchor(other[0].anchor_id), tags[other[0].tag_id == "T1" ? 0 : 1]);
  EXPECT_GT(std::abs(other[0].azimuth_deg - g.x() - bias[other[0].anchor_id][other[0].tag_id].x()),
            1e-3);
}

TEST(BleAoaModel, ErrorGrowsTowardsTheEdgeOfTheFieldOfView) {
  // An anchor facing +x at the tags' height; tags at azimuth 0, +60 (right) and -60 (left), 3 m.
  // Mean: the chamber cubic (6.10) theta + 0.0008 theta^2 - 0.000046 theta^3: +60 -> 52.944,
  // -60 -> -47.184. Sigma: 2 (1 + (60/90)^2) = 2.889 at 60 deg off the normal, 2 on it.
  // n = 2000 per tag: mean SE <= 0.065 (tolerance 0.3), sd SE <= 0.046 (tolerance 0.2).
  const std::string anchors =
      "    - {id: A, kind: ble_aoa, position: [0, 0, 1.2], orientation_deg: [0, 0, 0]}\n";
  const double c = 3 * std::cos(60 * kDeg), s = 3 * std::sin(60 * kDeg);
  const std::vector<Eigen::Vector3d> tags = {{3, 0, 1.2}, {c, -s, 1.2}, {c, s, 1.2}};
  const auto ev =
      run(scenario(anchors, tags, "noise_sigma_deg: 2, edge_noise_gain: 1, angle_resolution_deg: 0",
                   200),
          3);
  std::map<std::string, std::array<Stats, 2>> st;
  for (const auto& m : ev) {
    st[m.tag_id][0].add(m.azimuth_deg);
    st[m.tag_id][1].add(m.elevation_deg);
  }
  const double edge_sigma = 2 * (1 + 4.0 / 9.0);
  EXPECT_NEAR(st["T1"][0].n, 2000, 1);
  EXPECT_NEAR(st["T1"][0].mean(), 0.0, 0.3);
  EXPECT_NEAR(st["T1"][0].sd(), 2.0, 0.2);
  EXPECT_NEAR(st["T2"][0].mean(), 52.944, 0.3);
  EXPECT_NEAR(st["T2"][0].sd(), edge_sigma, 0.2);
  EXPECT_NEAR(st["T3"][0].mean(), -47.184, 0.3);
  EXPECT_NEAR(st["T3"][0].sd(), edge_sigma, 0.2);
  for (const char* t : {"T2", "T3"}) {
    EXPECT_NEAR(st[t][1].mean(), 0.0, 0.3) << t;
    EXPECT_NEAR(st[t][1].sd(), edge_sigma, 0.2) << t;
  }
}

TEST(BleAoaModel, FieldOfViewCutsEventsAndReportedAnglesStayWithin90) {
  // Tag at (0, 0, 1.2). F: straight ahead. B: the tag is behind it. S50 / S40: tag at azimuth
  // 50 / 40 (yaw - bearing, bearing 90). E: tag 59.5 deg above (atan2(1.7, 1)). C: azimuth 88.
  const std::string anchors =
      "    - {id: F, kind: ble_aoa, position: [-5, 0, 1.2]}\n"
      "    - {id: B, kind: ble_aoa, position: [5, 0, 1.2]}\n"
      "    - {id: S50, kind: ble_aoa, position: [0, -5, 1.2], orientation_deg: [0, 0, 140]}\n"
      "    - {id: S40, kind: ble_aoa, position: [0, -5, 1.2], orientation_deg: [0, 0, 130]}\n"
      "    - {id: E, kind: ble_aoa, position: [-1, 0, -0.5]}\n"
      "    - {id: C, kind: ble_aoa, position: [0, -5, 1.2], orientation_deg: [0, 0, 178]}\n";
  const std::vector<Eigen::Vector3d> tag = {{0, 0, 1.2}};
  const std::string common =
      "edge_quadratic_per_deg: 0, edge_cubic_per_deg2: 0, edge_noise_gain: 0";
  std::map<std::string, int> n45, n90;
  for (const auto& m : run(scenario(anchors, tag, common + ", fov_deg: 45", 10)))
    ++n45[m.anchor_id];
  EXPECT_NEAR(n45["F"], 100, 1);
  EXPECT_NEAR(n45["S40"], 100, 1);
  EXPECT_EQ(n45.count("B") + n45.count("S50") + n45.count("E") + n45.count("C"), 0u);

  double max_abs = 0;
  int at_90 = 0;
  for (const auto& m : run(scenario(anchors, tag, common, 10))) {
    ++n90[m.anchor_id];
    max_abs =
        std::max({max_abs, std::abs(double(m.azimuth_deg)), std::abs(double(m.elevation_deg))});
    if (m.anchor_id == "C" && m.azimuth_deg == 90.0f) ++at_90;
  }
  EXPECT_EQ(n90.count("B"), 0u);
  for (const char* id : {"F", "S50", "S40", "E", "C"}) EXPECT_NEAR(n90[id], 100, 1) << id;
  // C at 88 deg with sigma 5: P(88 + noise >= 89.5) = P(z >= 0.3) = 0.38 -> rounded to 90 and held
  // there; nothing beyond.
  EXPECT_EQ(max_abs, 90.0);
  EXPECT_GT(at_90, 20);
}

TEST(BleAoaModel, LossAndMultipathRatesAndTheDuplicatesWrongAngles) {
  // 600 s: 6000 advertisements per anchor, 24000 in all. Delivered fraction 0.8: SE 0.0026
  // (tolerance 0.011); duplicates among delivered 0.3: SE 0.0033 (tolerance 0.014).
  Scenario sc = parse_scenario_text(
      scenario(kHallAnchors, {kHallT1},
               std::string(kClean) + ", loss_probability: 0.2, multipath_probability: 0.3, "
                                     "multipath_offset_min_deg: 10, multipath_offset_max_deg: 60, "
                                     "multipath_delay_max_ms: 25, report_latency_max_ms: 25",
               600),
      "test.yaml");
  const auto ev = run_scenario(sc, 11);
  double advertisements = 0, delivered = 0, doubled = 0;
  Stats offset;
  int positive = 0;
  for (const char* id : {"A1", "A2", "A3", "A4"}) {
    const Eigen::Vector2d g = geometric(*sc.site.find_anchor(id), kHallT1);
    advertisements += 6000;
    for (const auto& grp : groups_of(ev, id)) {
      ++delivered;
      ASSERT_LE(grp.size(), 2u);
      EXPECT_NEAR(grp[0].azimuth_deg, g.x(), 1e-3);  // the direct path is exact without noise
      if (grp.size() < 2) continue;
      ++doubled;
      const ble_aoa_t& dup = grp[1];
      EXPECT_EQ(dup.channel, grp[0].channel);
      EXPECT_LE(dup.utime - grp[0].utime, 25'000);
      // Weaker by 3..10 dB, both rounded to whole dB.
      EXPECT_GE(grp[0].rssi_dbm - dup.rssi_dbm, 2.0f);
      EXPECT_LE(grp[0].rssi_dbm - dup.rssi_dbm, 11.0f);
      for (const double d : {dup.azimuth_deg - g.x(), dup.elevation_deg - g.y()}) {
        EXPECT_GE(std::abs(d), 10 - 1e-3);
        EXPECT_LE(std::abs(d), 60 + 1e-3);
        offset.add(std::abs(d));
        positive += d > 0;
      }
    }
  }
  EXPECT_NEAR(delivered / advertisements, 0.8, 0.011);
  EXPECT_NEAR(doubled / delivered, 0.3, 0.014);
  // |offset| ~ U(10, 60): mean 35, sd 14.4; n ~ 11500: SE 0.13 (tolerance 0.6). Signs: SE 0.005.
  EXPECT_NEAR(offset.mean(), 35.0, 0.6);
  EXPECT_NEAR(offset.sd(), 50 / std::sqrt(12.0), 0.5);
  EXPECT_NEAR(positive / offset.n, 0.5, 0.02);
}

TEST(BleAoaModel, UptimeInMsAndEventCounterPerAnchorAcrossTags) {
  const auto ev = run(
      scenario(kHallAnchors, {kHallT1, kHallT5},
               "loss_probability: 0.1, multipath_probability: 0.2, uptime_at_start_max_s: 600", 60),
      4);
  struct Last {
    const ble_aoa_t* m = nullptr;
    std::set<std::string> tags;
    int64_t boot_ms = 0;
  };
  std::map<std::string, Last> last;
  for (const auto& m : ev) {
    Last& l = last[m.anchor_id];
    l.tags.insert(m.tag_id);
    if (!l.m) {
      EXPECT_EQ(m.seq, 0);
      // Booted some time in the 600 s before the start.
      l.boot_ms = m.anchor_uptime_ms - (m.utime - kStart) / 1000;
      EXPECT_GE(l.boot_ms, 0);
      EXPECT_LE(l.boot_ms, 600'001);
    } else {
      // Events of all tags (duplicates included) counted one by one in the order they leave.
      EXPECT_EQ(m.seq, l.m->seq + 1) << m.anchor_id;
      EXPECT_GE(m.utime, l.m->utime);
      EXPECT_GE(m.anchor_uptime_ms, l.m->anchor_uptime_ms);
      // Milliseconds: the uptime advances with utime, to within the 1 ms truncation.
      const double d_uptime = double(m.anchor_uptime_ms - l.m->anchor_uptime_ms);
      EXPECT_LT(std::abs(d_uptime - double(m.utime - l.m->utime) / 1000.0), 1.0);
    }
    l.m = &m;
  }
  ASSERT_EQ(last.size(), 4u);
  std::set<int64_t> boots;
  for (const auto& [id, l] : last) {
    EXPECT_EQ(l.tags.size(), 2u) << id;
    boots.insert(l.boot_ms);
    // About 2 tags x 600 advertisements x 0.9 delivered x 1.2 with duplicates = 1296.
    EXPECT_NEAR(l.m->seq + 1, 1296, 150) << id;
  }
  EXPECT_EQ(boots.size(), 4u);  // each anchor booted at its own time
}

TEST(BleAoaModel, AdvertisingEvery100msWithAdvDelayOnRotatingChannels) {
  // No latency: every anchor reports an advertisement at the moment it is sent.
  const auto ev = run(scenario(kHallAnchors, {kHallT1}, "report_latency_max_ms: 0", 120), 6);
  std::vector<utime_t> adv;
  std::map<utime_t, std::set<int>> channels_at;
  std::map<std::string, int> last_channel;
  for (const auto& m : ev) {
    if (adv.empty() || adv.back() != m.utime) adv.push_back(m.utime);
    channels_at[m.utime].insert(m.channel);
    auto it = last_channel.find(m.anchor_id);
    if (it != last_channel.end()) {
      EXPECT_EQ(m.channel, it->second == 39 ? 37 : it->second + 1);
    }
    EXPECT_GE(m.channel, 37);
    EXPECT_LE(m.channel, 39);
    last_channel[m.anchor_id] = m.channel;
  }
  for (const auto& [t, ch] : channels_at)
    EXPECT_EQ(ch.size(), 1u) << "one channel per advertisement";
  // 1200 advertisements in 120 s (1199 when phase + advDelay push the last one past the end).
  ASSERT_NEAR(double(adv.size()), 1200, 1);
  EXPECT_EQ(ev.size(), 4 * adv.size());
  // t_k = phase + k 100 ms + U(0, 10 ms): successive gaps in [90, 110] ms, mean 100 ms, sd of a gap
  // sqrt(2 x 10^2 / 12) = 4.08 ms (1199 gaps: tolerance 0.4 ms); the delays spread over 0..10 ms.
  Stats gap;
  double lo = 1e18, hi = -1e18;
  for (size_t k = 0; k < adv.size(); ++k) {
    const double delay = double(adv[k] - adv[0]) - 100'000.0 * double(k);
    lo = std::min(lo, delay);
    hi = std::max(hi, delay);
    if (k) {
      const double g = double(adv[k] - adv[k - 1]);
      EXPECT_GE(g, 90'000);
      EXPECT_LE(g, 110'000);
      gap.add(g);
    }
  }
  EXPECT_NEAR(gap.mean(), 100'000, 10);
  EXPECT_NEAR(gap.sd(), 4083, 400);
  EXPECT_GT(hi - lo, 9'900);
  EXPECT_LE(hi - lo, 10'000);
}

TEST(BleAoaModel, RssiFollowsLogDistancePathLossAndValuesAreWholeNumbers) {
  // -59 dBm at 1 m, exponent 2: 2 m -> -65.02, 8 m -> -77.06 dBm. sigma 3 dB, rounded to 1 dB:
  // sd sqrt(9 + 1/12) = 3.014. n = 2000: mean SE 0.07 (tolerance 0.3), sd SE 0.05 (0.2).
  const std::string anchors =
      "    - {id: N, kind: ble_aoa, position: [-2, 0, 1.2]}\n"
      "    - {id: F, kind: ble_aoa, position: [-8, 0, 1.2]}\n";
  std::map<std::string, Stats> st;
  for (const auto& m :
       run(scenario(anchors, {{0, 0, 1.2}},
                    "rssi_1m_dbm: -59, path_loss_exponent: 2, rssi_sigma_db: 3", 200),
           8)) {
    st[m.anchor_id].add(m.rssi_dbm);
    // +UUDF carries integers: RSSI in dBm, angles in degrees (angle_resolution_deg 1).
    EXPECT_EQ(m.rssi_dbm, std::round(m.rssi_dbm));
    EXPECT_EQ(m.azimuth_deg, std::round(m.azimuth_deg));
    EXPECT_EQ(m.elevation_deg, std::round(m.elevation_deg));
    EXPECT_EQ(m.source, kSimSource);
    EXPECT_EQ(m.user_string, "");
  }
  EXPECT_NEAR(st["N"].mean(), -59 - 20 * std::log10(2.0), 0.3);
  EXPECT_NEAR(st["F"].mean(), -59 - 20 * std::log10(8.0), 0.3);
  EXPECT_NEAR(st["N"].sd(), std::sqrt(9 + 1 / 12.0), 0.2);
  EXPECT_NEAR(st["F"].sd(), std::sqrt(9 + 1 / 12.0), 0.2);
}

TEST(BleAoaModel, SameSeedSameBytes) {
  Scenario sc = load_scenario("aoa-hall");
  sc.duration_s = 20;
  auto events = [&](uint64_t seed) { return simulated_events(sc, seed, "BLE_AOA"); };
  const auto a = events(7), b = events(7), c = events(8);
  ASSERT_GT(a.size(), 700u);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].utime, b[i].utime);
    ASSERT_EQ(a[i].data, b[i].data) << "event " << i;
  }
  size_t same = 0;
  for (size_t i = 0; i < std::min(a.size(), c.size()); ++i) same += a[i].data == c[i].data;
  EXPECT_LT(same, 10u);
}

TEST(BleAoaModel, BadParametersNameFileLineAndField) {
  auto error = [](const std::string& params) -> std::string {
    try {
      parse_scenario_text(scenario(kHallAnchors, {kHallT1}, params, 1), "my.yaml");
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  // The ble_aoa section is on line 13 of the generated scenario.
  EXPECT_EQ(error("noise_sigma_deg: -1"),
            "my.yaml:13: sensors.ble_aoa.noise_sigma_deg: must be in [0, 90]");
  EXPECT_EQ(error("multipath_offset_min_deg: 20, multipath_offset_max_deg: 15"),
            "my.yaml:13: sensors.ble_aoa.multipath_offset_max_deg: must be in [20, 180]");
  EXPECT_EQ(error("anchor_bias_deg: {A9: [1, 2]}"),
            "my.yaml:13: sensors.ble_aoa.anchor_bias_deg.A9: no ble_aoa anchor 'A9' in the site");
  EXPECT_EQ(error("anchor_bias_deg: {A2: [100, 0]}"),
            "my.yaml:13: sensors.ble_aoa.anchor_bias_deg.A2: must be within [-90, 90] deg");
  EXPECT_EQ(
      error("noise_sigma: 3").rfind("my.yaml:13: sensors.ble_aoa.noise_sigma: unknown field", 0),
      0u);
}

// The aoa-hall reference scenarios against their own model: the parameters are read back from
// the scenario's ble_aoa section.
TEST(BleAoaScenario, AoaHallStaticPointsFollowTheirModel) {
  for (const char* name : {"aoa-hall-static-1", "aoa-hall-static-2"}) {
    const Scenario sc = load_scenario(name);
    ASSERT_NE(sc.sensor("ble_aoa"), nullptr);
    const YamlField& f = sc.sensor("ble_aoa")->section;
    const double sigma = f.get_double("noise_sigma_deg", 5);
    const double loss = f.get_double("loss_probability", 0);
    const double multipath = f.get_double("multipath_probability", 0);
    const double gain = f.get_double("edge_noise_gain", 1.0);
    const double c2 = f.get_double("edge_quadratic_per_deg", 0.0008);
    const double c3 = f.get_double("edge_cubic_per_deg2", -0.000046);
    EXPECT_EQ(sigma, 5.0);  // issue 3: angle noise about 5 deg
    const Eigen::Vector3d tag = sc.trajectories[0].path.at(10).position;
    EXPECT_LT((tag - (std::string(name) == "aoa-hall-static-1" ? kHallT1 : kHallT5)).norm(), 1e-9);
    const auto ev = run_scenario(sc, 2);
    double advertisements = 0, delivered = 0, doubled = 0;
    for (const auto& a : sc.site.anchors) {
      ASSERT_EQ(a.kind, "ble_aoa");
      const Eigen::Vector2d g = geometric(a, tag);
      const double off_normal_deg =
          std::acos(std::cos(g.x() * kDeg) * std::cos(g.y() * kDeg)) / kDeg;
      const double s = sigma * (1 + gain * std::pow(off_normal_deg / 90, 2));
      Stats err;
      advertisements += sc.duration_s * 10;
      for (const auto& grp : groups_of(ev, a.id)) {
        ++delivered;
        doubled += grp.size() > 1;
        err.add(grp[0].azimuth_deg - (g.x() + c2 * g.x() * g.x() + c3 * std::pow(g.x(), 3)));
      }
      // The mean error is the anchor's drawn bias, N(0, 3): within 4 sigma. The spread is the
      // model's sigma at this angle, plus 1/12 deg^2 of rounding; n ~ 1140: SE ~ 0.11 deg.
      EXPECT_LT(std::abs(err.mean()), 4 * f.get_double("bias_sigma_deg", 0) + 0.5) << name << a.id;
      EXPECT_NEAR(err.sd(), std::sqrt(s * s + 1 / 12.0), 0.45) << name << " " << a.id;
    }
    // 4800 advertisements: SE 0.003 (tolerance 0.015); duplicates SE 0.0045 (tolerance 0.02).
    EXPECT_NEAR(delivered / advertisements, 1 - loss, 0.015) << name;
    EXPECT_NEAR(doubled / delivered, multipath, 0.02) << name;
  }
}

TEST(BleAoaScenario, AoaHallWalkIsSeenByEveryAnchor) {
  const Scenario sc = load_scenario("aoa-hall");
  ASSERT_EQ(sc.site.anchors.size(), 4u);
  const auto ev = run_scenario(sc, 1);
  std::map<std::string, int> n;
  for (const auto& m : ev) {
    ++n[m.anchor_id];
    EXPECT_LE(std::abs(m.azimuth_deg), 90.0f);
    EXPECT_LE(std::abs(m.elevation_deg), 90.0f);
  }
  // The loop stays inside the rectangle the anchors face: 600 advertisements each, 5 % lost,
  // 10 % duplicated: 600 x 0.95 x 1.1 = 627 (binomial SE ~ 10).
  for (const char* id : {"A1", "A2", "A3", "A4"}) EXPECT_NEAR(n[id], 627, 45) << id;
}

}  // namespace
}  // namespace ips::sim
