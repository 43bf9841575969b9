// The view model of ips-view: covariance ellipses, bounded trails and tables, non-finite
// positions, the lcm-spy-like channel table, HEALTH per process, bad sites, and the JSON
// snapshot's escaping of names from the air.
#include "viewer-headless/view_model.hpp"

#include <ips/uwb_range_t.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>
#include <limits>
#include <numbers>
#include <set>
#include <string>
#include <vector>

#include "viewer-headless/bus_feed.hpp"

namespace ips::view {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr utime_t kT0 = 1'700'000'000'000'000;  // host receive time, us
constexpr double kDeg = std::numbers::pi / 180.0;

pose_t pose(const std::string& tag, double x, double y, double z = 1.2) {
  pose_t p{};
  p.utime = kT0;
  p.source = "uwb_twr";
  p.tag_id = tag;
  p.position[0] = x, p.position[1] = y, p.position[2] = z;
  for (double& c : p.position_cov) c = kNaN;
  for (double& v : p.velocity) v = kNaN;
  p.heading_rad = kNaN;
  p.residual_m = kNaN;
  p.status = pose_t::STATUS_OK;
  return p;
}

site_t site_msg(const std::string& yaml) {
  site_t m{};
  m.utime = kT0;
  m.source = "ips-sim";
  m.site_yaml = yaml;
  return m;
}

// config/sites/lab.yaml's anchors, and a BLE AoA anchor looking along +y (yaw 90 deg).
const char* kLabSite = R"(name: lab
anchors:
  - {id: A1, kind: uwb, position: [0.0, 0.0, 2.4]}
  - {id: A2, kind: uwb, position: [10.0, 0.0, 2.4]}
  - {id: A3, kind: uwb, position: [10.0, 8.0, 2.4]}
  - {id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}
  - {id: B1, kind: ble_aoa, position: [5.0, 0.0, 2.8], orientation_deg: [0, 0, 90]}
tags:
  - {id: T1, height_m: 1.2}
)";

Eigen::Matrix2d diag(double xx, double yy) {
  Eigen::Matrix2d m;
  m << xx, 0, 0, yy;
  return m;
}

// R(angle) diag(major2, minor2) R^T: a covariance whose major axis is at `angle` from +x.
Eigen::Matrix2d rotated_cov(double major2, double minor2, double angle_rad) {
  Eigen::Matrix2d r;
  r << std::cos(angle_rad), -std::sin(angle_rad), std::sin(angle_rad), std::cos(angle_rad);
  return r * diag(major2, minor2) * r.transpose();
}

// A strict JSON checker (RFC 8259 grammar; strings must be printable ASCII or escapes, which is
// what json_string() promises for ASCII input): enough to know the page's JSON.parse succeeds.
class JsonChecker {
 public:
  explicit JsonChecker(const std::string& s) : s_(s) {}
  bool valid() {
    ws();
    if (!value()) return false;
    ws();
    return i_ == s_.size();
  }

 private:
  bool value() {
    if (i_ >= s_.size()) return false;
    const char c = s_[i_];
    if (c == '{') return object();
    if (c == '[') return array();
    if (c == '"') return string();
    if (literal("true") || literal("false") || literal("null")) return true;
    return number();
  }
  bool object() {
    ++i_;
    ws();
    if (peek('}')) return ++i_, true;
    while (true) {
      ws();
      if (!string()) return false;
      ws();
      if (!peek(':')) return false;
      ++i_;
      ws();
      if (!value()) return false;
      ws();
      if (peek('}')) return ++i_, true;
      if (!peek(',')) return false;
      ++i_;
    }
  }
  bool array() {
    ++i_;
    ws();
    if (peek(']')) return ++i_, true;
    while (true) {
      ws();
      if (!value()) return false;
      ws();
      if (peek(']')) return ++i_, true;
      if (!peek(',')) return false;
      ++i_;
    }
  }
  bool string() {
    if (!peek('"')) return false;
    for (++i_; i_ < s_.size(); ++i_) {
      const unsigned char c = static_cast<unsigned char>(s_[i_]);
      if (c == '"') return ++i_, true;
      if (c < 0x20) return false;
      if (c == '\\') {
        if (++i_ >= s_.size()) return false;
        const char e = s_[i_];
        if (e == 'u') {
          for (int k = 0; k < 4; ++k)
            if (++i_ >= s_.size() || !std::isxdigit(static_cast<unsigned char>(s_[i_])))
              return false;
        } else if (std::string("\"\\/bfnrt").find(e) == std::string::npos) {
          return false;
        }
      }
    }
    return false;
  }
  bool number() {
    if (peek('-')) ++i_;
    const size_t int_start = i_;
    if (!digits()) return false;
    if (s_[int_start] == '0' && i_ - int_start > 1) return false;  // no leading zeros
    if (peek('.')) {
      ++i_;
      if (!digits()) return false;
    }
    if (peek('e') || peek('E')) {
      ++i_;
      if (peek('+') || peek('-')) ++i_;
      if (!digits()) return false;
    }
    return true;
  }
  bool digits() {
    const size_t start = i_;
    while (i_ < s_.size() && std::isdigit(static_cast<unsigned char>(s_[i_]))) ++i_;
    return i_ > start;
  }
  bool literal(const char* word) {
    const std::string w = word;
    if (s_.compare(i_, w.size(), w) != 0) return false;
    i_ += w.size();
    return true;
  }
  bool peek(char c) const { return i_ < s_.size() && s_[i_] == c; }
  void ws() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  const std::string& s_;
  size_t i_ = 0;
};

bool valid_json(const std::string& s) { return JsonChecker(s).valid(); }

TEST(CovarianceEllipse, DiagonalFourOneGivesTwoSigmaSemiAxesFourAndTwo) {
  // diag(4, 1) m^2: sigmas 2 m and 1 m; at 2 sigma, 4 m along x and 2 m along y.
  const auto e = covariance_ellipse(diag(4, 1), 2.0);
  ASSERT_TRUE(e);
  EXPECT_DOUBLE_EQ(e->semi_major_m, 4.0);
  EXPECT_DOUBLE_EQ(e->semi_minor_m, 2.0);
  EXPECT_DOUBLE_EQ(e->angle_rad, 0.0);
}

TEST(CovarianceEllipse, LargerVarianceInYPutsTheMajorAxisAlongY) {
  const auto e = covariance_ellipse(diag(1, 4), 2.0);
  ASSERT_TRUE(e);
  EXPECT_DOUBLE_EQ(e->semi_major_m, 4.0);
  EXPECT_DOUBLE_EQ(e->semi_minor_m, 2.0);
  EXPECT_NEAR(e->angle_rad, 90 * kDeg, 1e-12);
}

TEST(CovarianceEllipse, RotatedCovarianceGivesItsAngle) {
  // diag(4, 1) rotated by 30 deg: [[3.25, 1.299], [1.299, 1.75]].
  const Eigen::Matrix2d cov = rotated_cov(4, 1, 30 * kDeg);
  EXPECT_NEAR(cov(0, 0), 3.25, 1e-12);
  EXPECT_NEAR(cov(0, 1), 0.75 * std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(cov(1, 1), 1.75, 1e-12);
  const auto e = covariance_ellipse(cov, 2.0);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->semi_major_m, 4.0, 1e-12);
  EXPECT_NEAR(e->semi_minor_m, 2.0, 1e-12);
  EXPECT_NEAR(e->angle_rad, 30 * kDeg, 1e-12);

  // An axis is an axis: -60 deg and 120 deg are the same ellipse, reported in (-90, 90].
  const auto f = covariance_ellipse(rotated_cov(9, 0.25, 120 * kDeg), 1.0);
  ASSERT_TRUE(f);
  EXPECT_NEAR(f->semi_major_m, 3.0, 1e-12);
  EXPECT_NEAR(f->semi_minor_m, 0.5, 1e-12);
  EXPECT_NEAR(f->angle_rad, -60 * kDeg, 1e-12);
}

TEST(CovarianceEllipse, NotPositiveDefiniteOrNotFiniteIsSkipped) {
  Eigen::Matrix2d indefinite;
  indefinite << 1, 2, 2, 1;  // eigenvalues 3 and -1
  EXPECT_FALSE(covariance_ellipse(indefinite, 2.0));
  EXPECT_FALSE(covariance_ellipse(diag(1, 0), 2.0));  // singular
  EXPECT_FALSE(covariance_ellipse(Eigen::Matrix2d::Zero(), 2.0));
  EXPECT_FALSE(covariance_ellipse(diag(-1, -4), 2.0));
  EXPECT_FALSE(covariance_ellipse(Eigen::Matrix2d::Constant(kNaN), 2.0));
  EXPECT_FALSE(covariance_ellipse(diag(1, 1), 0.0));
  // Nearly singular but positive definite: the minor axis keeps its precision (det / major).
  Eigen::Matrix2d thin;
  thin << 1e4, 0, 0, 1e-8;
  const auto e = covariance_ellipse(thin, 1.0);
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->semi_minor_m, 1e-4, 1e-16);
}

TEST(ViewModel, PoseIsKeptPerChannelAndTagWithHorizontalCovariance) {
  ViewModel m;
  pose_t p = pose("T1", 3.0, 4.0);
  const double cov[9] = {0.04, 0.01, 0.0, 0.01, 0.09, 0.0, 0.0, 0.0, 0.25};
  std::copy(std::begin(cov), std::end(cov), std::begin(p.position_cov));
  p.status = int32_t{pose_t::STATUS_OK} | pose_t::STATUS_2D;
  m.on_pose("POSE_UWB", p, kT0 + 10);
  m.on_pose("TRUTH", pose("T1", 3.1, 4.1), kT0 + 20);

  ASSERT_EQ(m.tracks().size(), 2u);
  const Track& t = m.tracks().at({"POSE_UWB", "T1"});
  EXPECT_EQ(t.source, "uwb_twr");
  EXPECT_EQ(t.position, Eigen::Vector3d(3.0, 4.0, 1.2));
  EXPECT_DOUBLE_EQ(t.cov_xy(0, 0), 0.04);
  EXPECT_DOUBLE_EQ(t.cov_xy(0, 1), 0.01);
  EXPECT_DOUBLE_EQ(t.cov_xy(1, 0), 0.01);
  EXPECT_DOUBLE_EQ(t.cov_xy(1, 1), 0.09);
  EXPECT_EQ(t.status, int32_t{pose_t::STATUS_OK} | pose_t::STATUS_2D);
  EXPECT_EQ(t.host_utime, kT0 + 10);
  EXPECT_EQ(status_names(t.status), (std::vector<std::string>{"ok", "2d"}));
  EXPECT_EQ(m.pose_channels(), (std::vector<std::string>{"POSE_UWB", "TRUTH"}));
}

TEST(ViewModel, TrailKeepsTheLastSecondsOldestFirst) {
  ViewOptions o;
  o.trail_length = 5;
  ViewModel m(o);
  for (int i = 0; i < 12; ++i) m.on_pose("POSE_FUSED", pose("T1", i, -i), kT0 + i);
  const Track& t = m.tracks().at({"POSE_FUSED", "T1"});
  EXPECT_EQ(t.count, 12);
  ASSERT_EQ(t.trail.size(), 5u);
  const auto pts = t.trail.points();
  for (int k = 0; k < 5; ++k) EXPECT_EQ(pts[k], Eigen::Vector2d(7.0 + k, -(7.0 + k))) << k;
  EXPECT_EQ(Eigen::Vector2d(t.position.head<2>()), Eigen::Vector2d(11.0, -11.0));

  // By time: the last 20 s (default) of a 10 Hz track are 201 positions; a 50 Hz one keeps
  // 20 s too (1001), not the same count.
  ViewModel d;
  for (int i = 0; i < 300; ++i) d.on_pose("POSE_FUSED", pose("T1", i, 0), kT0 + i * 100000);
  for (int i = 0; i < 1500; ++i) d.on_pose("TRUTH", pose("T1", i, 0), kT0 + i * 20000);
  EXPECT_EQ(d.tracks().at({"POSE_FUSED", "T1"}).trail.points().size(), 201u);
  EXPECT_EQ(d.tracks().at({"POSE_FUSED", "T1"}).trail.points().front().x(), 99.0);
  EXPECT_EQ(d.tracks().at({"TRUTH", "T1"}).trail.points().size(), 1001u);
  EXPECT_EQ(d.tracks().at({"TRUTH", "T1"}).trail.points().back().x(), 1499.0);
  // ... at most trail_length of them.
  ViewOptions few;
  few.trail_length = 100;
  ViewModel f(few);
  for (int i = 0; i < 300; ++i) f.on_pose("POSE_FUSED", pose("T1", i, 0), kT0 + i * 100000);
  EXPECT_EQ(f.tracks().at({"POSE_FUSED", "T1"}).trail.points().size(), 100u);

  ViewOptions none;
  none.trail_length = 0;
  ViewModel n(none);
  n.on_pose("POSE_FUSED", pose("T1", 1, 2), kT0);
  EXPECT_EQ(n.tracks().at({"POSE_FUSED", "T1"}).trail.size(), 0u);
}

TEST(ViewModel, NonFinitePositionsAreCountedNotStored) {
  ViewModel m;
  m.on_pose("POSE_UWB", pose("T1", kNaN, 1.0), kT0);  // no track yet: none is made
  EXPECT_TRUE(m.tracks().empty());
  m.on_pose("POSE_UWB", pose("T1", 1.0, 2.0), kT0 + 1);
  m.on_pose("POSE_UWB", pose("T1", std::numeric_limits<double>::infinity(), 2.0), kT0 + 2);
  m.on_pose("POSE_UWB", pose("T1", 1.0, -std::numeric_limits<double>::infinity()), kT0 + 3);
  m.on_pose("POSE_UWB", pose("T1", 5.0, 6.0, kNaN), kT0 + 4);  // 2-D estimate: z unknown is fine

  EXPECT_EQ(m.stats().poses_in, 5);
  EXPECT_EQ(m.stats().non_finite_positions, 3);
  const Track& t = m.tracks().at({"POSE_UWB", "T1"});
  EXPECT_EQ(t.count, 2);
  EXPECT_EQ(t.non_finite, 2);
  EXPECT_EQ(t.trail.size(), 2u);
  EXPECT_EQ(Eigen::Vector2d(t.position.head<2>()), Eigen::Vector2d(5.0, 6.0));
  EXPECT_TRUE(std::isnan(t.position.z()));
  // ... and the JSON says null, not nan.
  const std::string j = m.json(kT0 + 10);
  EXPECT_NE(j.find("\"position\":[5,6,null]"), std::string::npos) << j;
  EXPECT_EQ(j.find("nan"), std::string::npos);
  EXPECT_EQ(j.find("inf"), std::string::npos);
  EXPECT_TRUE(valid_json(j)) << j;
}

TEST(ViewModel, TagsAreBoundedAndTheSilentLongestGivesWayAfterExpiry) {
  ViewOptions o;
  o.max_tracks = 3;
  o.expire_s = 60;
  ViewModel m(o);
  for (int i = 0; i < 5; ++i) m.on_pose("POSE_UWB", pose("T" + std::to_string(i), i, 0), kT0 + i);
  EXPECT_EQ(m.tracks().size(), 3u);
  EXPECT_EQ(m.stats().dropped_too_many_tracks, 2);
  // T1 and T2 keep talking; 61 s later T0 has been silent longest and long enough.
  m.on_pose("POSE_UWB", pose("T1", 1, 1), kT0 + 30'000'000);
  m.on_pose("POSE_UWB", pose("T2", 2, 2), kT0 + 30'000'000);
  m.on_pose("POSE_UWB", pose("T9", 9, 9), kT0 + 61'000'000);
  EXPECT_EQ(m.stats().expired, 1);
  EXPECT_EQ(m.tracks().count({"POSE_UWB", "T0"}), 0u);
  EXPECT_EQ(m.tracks().count({"POSE_UWB", "T9"}), 1u);
  // A flood of new ids while everyone is fresh is dropped, not let in.
  for (int i = 0; i < 100; ++i)
    m.on_pose("POSE_UWB", pose("X" + std::to_string(i), 0, 0), kT0 + 62'000'000);
  EXPECT_EQ(m.tracks().size(), 3u);
  EXPECT_EQ(m.stats().dropped_too_many_tracks, 102);
}

TEST(ViewModel, OverlongIdsAreDroppedAndCounted) {
  ViewModel m;
  m.on_pose("POSE_UWB", pose(std::string(129, 'x'), 1, 1), kT0);
  m.on_pose(std::string(129, 'C'), pose("T1", 1, 1), kT0);
  m.on_bytes(std::string(129, 'C'), 10, kT0);
  health_t h{};
  h.source = std::string(200, 's');
  m.on_health(h, kT0);
  EXPECT_TRUE(m.tracks().empty());
  EXPECT_TRUE(m.channel_table(kT0).empty());
  EXPECT_TRUE(m.processes().empty());
  EXPECT_EQ(m.stats().dropped_long_ids, 4);
  // 128 is allowed.
  m.on_pose("POSE_UWB", pose(std::string(128, 'x'), 1, 1), kT0);
  EXPECT_EQ(m.tracks().size(), 1u);
}

TEST(ViewModel, ChannelRateOfTenMessagesATenthOfASecondApartIsTenHertz) {
  ViewModel m;  // rate window 5 s
  for (int i = 0; i < 10; ++i) m.on_bytes("POSE_UWB", 120, kT0 + i * 100'000);
  const utime_t last = kT0 + 900'000;

  auto rows = m.channel_table(last);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].channel, "POSE_UWB");
  EXPECT_EQ(rows[0].count, 10);
  EXPECT_EQ(rows[0].bytes, 1200);
  EXPECT_NEAR(rows[0].rate_hz, 10.0, 1e-9);
  EXPECT_NEAR(rows[0].bytes_per_s, 1200.0, 1e-6);
  EXPECT_DOUBLE_EQ(rows[0].age_s, 0.0);

  // 2.5 s later: the same ten in the window, 2.5 s since the last.
  rows = m.channel_table(last + 2'500'000);
  EXPECT_NEAR(rows[0].rate_hz, 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(rows[0].age_s, 2.5);

  // 4.15 s after the last, the first (5.05 s old) has left the window: 9 in 0.8 s, still 10 Hz.
  rows = m.channel_table(last + 4'150'000);
  EXPECT_NEAR(rows[0].rate_hz, 10.0, 1e-9);

  // One left in the window: one per window, 0.2 Hz. None: 0 Hz; the count stays.
  rows = m.channel_table(last + 4'950'000);
  EXPECT_NEAR(rows[0].rate_hz, 0.2, 1e-12);
  EXPECT_NEAR(rows[0].bytes_per_s, 24.0, 1e-9);
  rows = m.channel_table(last + 6'000'000);
  EXPECT_EQ(rows[0].rate_hz, 0.0);
  EXPECT_EQ(rows[0].bytes_per_s, 0.0);
  EXPECT_EQ(rows[0].count, 10);
  EXPECT_DOUBLE_EQ(rows[0].age_s, 6.0);
}

TEST(ViewModel, ChannelRateIsRightWhenTheRateOutrunsTheRememberedArrivals) {
  ViewOptions o;
  o.rate_samples = 16;
  ViewModel m(o);
  // IMU at 200 Hz for 3 s, mixed sizes.
  for (int i = 0; i < 600; ++i) m.on_bytes("IMU", i % 2 ? 100 : 60, kT0 + i * 5'000);
  const auto rows = m.channel_table(kT0 + 599 * 5'000);
  EXPECT_NEAR(rows[0].rate_hz, 200.0, 1e-6);
  EXPECT_NEAR(rows[0].bytes_per_s, 200.0 * 80, 1e-3);
  EXPECT_EQ(rows[0].count, 600);
}

TEST(ViewModel, ChannelTableIsSortedAndBounded) {
  ViewOptions o;
  o.max_channels = 2;
  ViewModel m(o);
  m.on_bytes("TRUTH", 10, kT0);
  m.on_bytes("HEALTH", 10, kT0);
  m.on_bytes("SITE", 10, kT0);
  const auto rows = m.channel_table(kT0);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].channel, "HEALTH");
  EXPECT_EQ(rows[1].channel, "TRUTH");
  EXPECT_EQ(m.stats().dropped_too_many_channels, 1);
  EXPECT_EQ(m.stats().bytes_messages_in, 3);
}

TEST(ViewModel, HealthIsKeptPerSourceHostAndPid) {
  ViewModel m;
  health_t h{};
  h.utime = kT0;
  h.source = "ips-uwb-twr";
  h.host = "lab-pc";
  h.pid = 100;
  h.state = health_t::STATE_OK;
  h.msgs_in = 10;
  m.on_health(h, kT0);
  h.msgs_in = 20;
  h.state = health_t::STATE_DEGRADED;
  h.last_error = std::string(600, 'e');
  h.version = "0.1.0 (git 98887a18c402-dirty, Release)";
  m.on_health(h, kT0 + 1'000'000);
  h.pid = 101;  // restarted: another process
  h.state = health_t::STATE_STARTING;
  h.last_error.clear();
  m.on_health(h, kT0 + 2'000'000);

  ASSERT_EQ(m.processes().size(), 2u);
  const Process& p = m.processes().at({"ips-uwb-twr", "lab-pc", 100});
  EXPECT_EQ(p.health.msgs_in, 20);
  EXPECT_EQ(p.health.state, health_t::STATE_DEGRADED);
  EXPECT_EQ(p.health.last_error.size(), 512u);
  EXPECT_EQ(p.host_utime, kT0 + 1'000'000);

  const std::string j = m.json(kT0 + 3'000'000);
  EXPECT_TRUE(valid_json(j)) << j;
  EXPECT_NE(j.find("\"pid\":100,\"state\":\"degraded\",\"state_code\":1,\"msgs_in\":20"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"pid\":101,\"state\":\"starting\""), std::string::npos);
  EXPECT_NE(j.find("\"version\":\"0.1.0 (git 98887a18c402-dirty, Release)\""), std::string::npos)
      << j;
  EXPECT_NE(j.find("\"age_s\":2}"), std::string::npos) << j;  // pid 100, last seen at +1 s
  EXPECT_STREQ(health_state_name(9), "unknown");
}

TEST(ViewModel, BadSiteIsCountedAndThePreviousSiteStays) {
  ViewModel m;
  m.on_site(site_msg(kLabSite), kT0);
  ASSERT_TRUE(m.has_site());
  EXPECT_EQ(m.site_name(), "lab");
  ASSERT_EQ(m.anchors().size(), 5u);
  EXPECT_NEAR(m.anchors()[4].orientation_rad.z(), 90 * kDeg, 1e-12);

  m.on_site(site_msg("anchors: [ {id: A1, position: [0, 0"), kT0 + 1);  // not YAML
  m.on_site(site_msg("name: x\nanchors:\n  - {id: A1, kind: laser, position: [0, 0, 0]}\n"),
            kT0 + 2);
  EXPECT_EQ(m.stats().sites_in, 3);
  EXPECT_EQ(m.stats().bad_sites, 2);
  EXPECT_NE(m.last_site_error().find("laser"), std::string::npos) << m.last_site_error();
  EXPECT_EQ(m.site_name(), "lab");
  EXPECT_EQ(m.anchors().size(), 5u);

  ViewOptions o;
  o.max_anchors = 4;
  ViewModel small(o);
  small.on_site(site_msg(kLabSite), kT0);
  EXPECT_FALSE(small.has_site());
  EXPECT_EQ(small.stats().bad_sites, 1);
  EXPECT_NE(small.last_site_error().find("5 anchors"), std::string::npos);
}

TEST(JsonString, EscapesQuotesBackslashesControlsAndMarkup) {
  EXPECT_EQ(json_string("T1"), "\"T1\"");
  EXPECT_EQ(json_string("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(json_string(std::string("\n\t\x01\x1f\x7f", 5)),
            "\"\\u000a\\u0009\\u0001\\u001f\\u007f\"");
  EXPECT_EQ(json_string(std::string("a\0b", 3)), "\"a\\u0000b\"");
  EXPECT_EQ(json_string("<script>alert(1)</script>"),
            "\"\\u003cscript\\u003ealert(1)\\u003c/script\\u003e\"");
  EXPECT_EQ(json_string("a&b"), "\"a\\u0026b\"");
}

TEST(JsonString, KeepsValidUtf8AndReplacesInvalidBytes) {
  EXPECT_EQ(json_string("caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x93\x8d"),
            "\"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x93\x8d\"");
  EXPECT_EQ(json_string("\xff"), "\"\\ufffd\"");
  EXPECT_EQ(json_string("\xc3"), "\"\\ufffd\"");                        // cut sequence
  EXPECT_EQ(json_string("\xc0\xaf"), "\"\\ufffd\\ufffd\"");             // overlong '/'
  EXPECT_EQ(json_string("\xed\xa0\x80"), "\"\\ufffd\\ufffd\\ufffd\"");  // a surrogate
  EXPECT_EQ(json_string("\xe2\x80\xa8\xe2\x80\xa9"), "\"\\u2028\\u2029\"");
}

TEST(JsonNumber, NonFiniteIsNull) {
  EXPECT_EQ(json_number(kNaN), "null");
  EXPECT_EQ(json_number(std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(json_number(-std::numeric_limits<double>::infinity()), "null");
  EXPECT_EQ(json_number(2.5), "2.5");
  EXPECT_EQ(json_number(-1234567.125), "-1234567.125");
}

TEST(ViewModel, JsonEscapesEveryStringFromTheAir) {
  ViewModel m;
  pose_t p = pose("<script>alert(1)</script>", 1, 2);
  p.source = "evil\"src\\\n";
  m.on_pose("POSE_UWB", p, kT0);
  health_t h{};
  h.source = "ips-x";
  h.host = "h\"ost";
  h.last_error = "line1\nline2\x1b[2J";
  m.on_health(h, kT0);
  m.on_bytes("POSE_UWB", 200, kT0);

  const std::string j = m.json(kT0);
  EXPECT_TRUE(valid_json(j)) << j;
  EXPECT_EQ(j.find("<script"), std::string::npos);
  EXPECT_EQ(j.find('<'), std::string::npos);
  EXPECT_NE(j.find("\"tag\":\"\\u003cscript\\u003ealert(1)\\u003c/script\\u003e\""),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"source\":\"evil\\\"src\\\\\\u000a\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"host\":\"h\\\"ost\""), std::string::npos);
  EXPECT_NE(j.find("\"last_error\":\"line1\\u000aline2\\u001b[2J\""), std::string::npos) << j;
  for (unsigned char c : j) EXPECT_GE(c, 0x20) << "raw control byte in the JSON";
}

TEST(ViewModel, JsonSnapshotHoldsAnchorsTracksChannelsAndStats) {
  ViewModel m;
  m.on_site(site_msg(kLabSite), kT0);
  pose_t p = pose("T1", 3, 4);
  const Eigen::Matrix2d cov = rotated_cov(4, 1, 30 * kDeg);
  p.position_cov[0] = cov(0, 0), p.position_cov[1] = cov(0, 1);
  p.position_cov[3] = cov(1, 0), p.position_cov[4] = cov(1, 1);
  p.status = int32_t{pose_t::STATUS_OK} | pose_t::STATUS_COASTING;
  m.on_pose("POSE_FUSED", p, kT0 + 500'000);
  m.on_pose("TRUTH", pose("T1", 3.2, 4.1), kT0 + 500'000);
  m.on_pose("POSE_UWB", pose("T1", kNaN, 4.1), kT0 + 500'000);
  for (int i = 0; i < 10; ++i) m.on_bytes("POSE_FUSED", 150, kT0 + i * 100'000);

  const std::string j = m.json(kT0 + 1'500'000);
  ASSERT_TRUE(valid_json(j)) << j;
  EXPECT_EQ(j.rfind("{\"now_utime\":1700000001500000,", 0), 0u) << j;
  EXPECT_NE(j.find("\"site\":{\"name\":\"lab\",\"source\":\"ips-sim\",\"age_s\":1.5,\"version\":1}"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("{\"id\":\"A1\",\"kind\":\"uwb\",\"enabled\":true,\"position\":[0,0,2.4]}"),
            std::string::npos)
      << j;
  // Only the ble_aoa anchor carries its yaw.
  EXPECT_NE(j.find("\"id\":\"B1\",\"kind\":\"ble_aoa\",\"enabled\":true,\"position\":[5,0,2.8],"
                   "\"yaw_deg\":90}"),
            std::string::npos)
      << j;
  EXPECT_EQ(j.find("yaw_deg"), j.rfind("yaw_deg"));
  // Tracks sorted by channel then tag, with colour, ellipse (2 sigma) and flags.
  const size_t fused = j.find("\"channel\":\"POSE_FUSED\",\"tag\":\"T1\"");
  const size_t truth = j.find("\"channel\":\"TRUTH\",\"tag\":\"T1\"");
  ASSERT_NE(fused, std::string::npos);
  ASSERT_NE(truth, std::string::npos);
  EXPECT_LT(fused, truth);
  EXPECT_EQ(j.find("\"channel\":\"POSE_UWB\",\"tag\""), std::string::npos);  // nothing finite
  EXPECT_NE(j.find("\"colour\":\"#d62728\""), std::string::npos);
  EXPECT_NE(j.find("\"colour\":\"#000000\""), std::string::npos);
  EXPECT_NE(j.find("\"ellipse_2sigma\":{\"semi_major_m\":4,\"semi_minor_m\":2,\"angle_deg\":30}"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"ellipse_2sigma\":null"), std::string::npos);  // TRUTH: no covariance
  EXPECT_NE(j.find("\"flags\":[\"ok\",\"coasting\"]"), std::string::npos);
  EXPECT_NE(j.find("\"age_s\":1,\"position\":[3,4,1.2]"), std::string::npos) << j;
  EXPECT_NE(j.find("\"trail\":[[3,4]]"), std::string::npos);
  EXPECT_NE(j.find("{\"channel\":\"POSE_FUSED\",\"count\":10,\"rate_hz\":10,\"age_s\":0.6,"
                   "\"bytes_per_s\":1500,\"bytes\":1500}"),
            std::string::npos)
      << j;
  EXPECT_NE(j.find("\"non_finite_positions\":1"), std::string::npos);
  EXPECT_NE(j.find("\"site_error\":\"\""), std::string::npos);
}

const char* kTwoFloors = R"(name: house
anchors:
  - {id: A1, position: [0, 0, 2.4]}
floors:
  - {index: 0, name: Ground, height_m: 0}
  - {index: 1, name: First, height_m: 3.5}
zones:
  - {id: hall, name: Hall <b>, floor: 1, polygon: [[0, 0], [2, 0], [2, 2]], alert: [enter]}
plan_images:
  g.png: "data:image/png;base64,iVBORw0KGgo="
)";

TEST(ViewModel, FloorsFromAltitudeElseFromTheTracksHeight) {
  ViewModel m;
  m.on_site(site_msg(kTwoFloors), kT0);
  m.on_pose("POSE_FUSED", pose("T1", 1, 1, 4.7), kT0);
  m.on_pose("POSE_FUSED", pose("T2", 1, 1, 1.2), kT0);
  const auto& tracks = m.tracks();
  EXPECT_EQ(m.track_floor(tracks.at({"POSE_FUSED", "T1"})), 1);  // 4.7 m: above floor 1's 3.5
  EXPECT_EQ(m.track_floor(tracks.at({"POSE_FUSED", "T2"})), 0);
  // ALTITUDE's floor wins over the height (a 2D estimate's z is the site's tag height).
  altitude_t a{};
  a.tag_id = "T2";
  a.height_m = 4.6;
  a.floor = 1;
  a.floor_valid = true;
  m.on_altitude(a, kT0);
  EXPECT_EQ(m.track_floor(tracks.at({"POSE_FUSED", "T2"})), 1);
  // A relative height has no floor.
  a.tag_id = "T1";
  a.floor = 0;
  a.relative = true;
  m.on_altitude(a, kT0);
  EXPECT_EQ(m.track_floor(tracks.at({"POSE_FUSED", "T1"})), 1);
  const std::string j = m.json(kT0);
  ASSERT_TRUE(valid_json(j)) << j;
  EXPECT_NE(j.find("\"tag\":\"T2\",\"height_m\":4.6,\"floor\":1,\"relative\":false"),
            std::string::npos)
      << j;
  // Without floors in the site: none.
  ViewModel flat;
  flat.on_pose("POSE_FUSED", pose("T1", 1, 1, 4.7), kT0);
  EXPECT_EQ(flat.track_floor(flat.tracks().at({"POSE_FUSED", "T1"})), kNoFloor);
}

TEST(ViewModel, SiteJsonHoldsFloorsPlansAndZonesAndChangesVersionOnlyWithTheSite) {
  ViewModel m;
  m.on_site(site_msg(kTwoFloors), kT0);
  EXPECT_EQ(m.site_version(), 1);
  m.on_site(site_msg(kTwoFloors), kT0 + 5'000'000);  // repeated: the same site
  EXPECT_EQ(m.site_version(), 1);
  const std::string j = m.site_json();
  ASSERT_TRUE(valid_json(j)) << j;
  EXPECT_NE(j.find("\"floors\":[{\"index\":0,\"name\":\"Ground\",\"height_m\":0,\"plan\":null},"
                   "{\"index\":1,\"name\":\"First\",\"height_m\":3.5,\"plan\":null}]"),
            std::string::npos)
      << j;
  // Markup from the site is escaped.
  EXPECT_NE(j.find("\"name\":\"Hall \\u003cb\\u003e\",\"floor\":1,\"alert\":{\"enter\":true,"
                   "\"leave\":false,\"dwell\":false},\"polygon\":[[0,0],[2,0],[2,2]]"),
            std::string::npos)
      << j;
  std::string with_plan = kTwoFloors;
  with_plan.replace(with_plan.find("height_m: 0}"), 12,
                    "height_m: 0, plan: {image: g.png, origin: [1, 2], size_m: [10, 5], "
                    "rotation_deg: 90}}");
  m.on_site(site_msg(with_plan), kT0 + 6'000'000);
  EXPECT_EQ(m.site_version(), 2);
  EXPECT_NE(m.site_json().find("\"plan\":{\"image\":\"g.png\",\"uri\":\"data:image/png;base64,"
                               "iVBORw0KGgo=\",\"origin\":[1,2],\"size_m\":[10,5],"
                               "\"rotation_deg\":90}"),
            std::string::npos)
      << m.site_json();
}

zone_event_t zone_event(int8_t event, int64_t seq) {
  zone_event_t e{};
  e.utime = kT0 + seq;
  e.source = "ips-zones";
  e.seq = seq;
  e.tag_id = "T1";
  e.zone_id = "hall";
  e.zone_name = "Hall";
  e.floor = zone_event_t::FLOOR_ANY;
  e.event = event;
  e.pose_channel = "POSE_FUSED";
  return e;
}

TEST(ViewModel, ZoneEventsNewestFirstAndBounded) {
  ViewOptions o;
  o.max_zone_events = 3;
  ViewModel m(o);
  for (int i = 0; i < 5; ++i)
    m.on_zone_event(zone_event(i % 2 ? zone_event_t::EVENT_LEAVE : zone_event_t::EVENT_ENTER, i),
                    kT0);
  const std::string j = m.json(kT0);
  ASSERT_TRUE(valid_json(j)) << j;
  const auto at = [&](int seq) {
    return j.find("\"utime\":" + std::to_string(kT0 + seq) + ",\"source\":\"ips-zones\"");
  };
  EXPECT_EQ(at(0), std::string::npos);
  EXPECT_EQ(at(1), std::string::npos);
  ASSERT_NE(at(4), std::string::npos) << j;
  EXPECT_LT(at(4), at(3));
  EXPECT_LT(at(3), at(2));
  EXPECT_NE(j.find("\"floor\":null,\"event\":\"enter\""), std::string::npos) << j;
  EXPECT_EQ(m.stats().zone_events_in, 5);
}

alert_t alert(int64_t id, int8_t state, int64_t utime) {
  alert_t a{};
  a.utime = utime;
  a.source = "ips-zones";
  a.id = id;
  a.kind = alert_t::KIND_TAG_SILENT;
  a.severity = alert_t::SEVERITY_WARNING;
  a.state = state;
  a.subject = "T" + std::to_string(id);
  a.text = "silent";
  return a;
}

TEST(ViewModel, AlertsRaisedClearedAckedAndBounded) {
  ViewOptions o;
  o.max_alerts = 2;
  ViewModel m(o);
  m.on_alert(alert(1, alert_t::STATE_RAISED, 100), kT0);
  m.on_alert(alert(2, alert_t::STATE_RAISED, 200), kT0);
  EXPECT_TRUE(m.ack_alert("ips-zones", 1));
  EXPECT_FALSE(m.ack_alert("ips-zones", 9));
  EXPECT_FALSE(m.ack_alert("other", 1));
  // Both raised: a third has no room, and is counted.
  m.on_alert(alert(3, alert_t::STATE_RAISED, 300), kT0);
  EXPECT_EQ(m.stats().dropped_too_many_alerts, 1);
  // Once one has ended, it gives way.
  m.on_alert(alert(1, alert_t::STATE_CLEARED, 400), kT0);
  m.on_alert(alert(3, alert_t::STATE_RAISED, 500), kT0);
  std::string j = m.json(kT0);
  ASSERT_TRUE(valid_json(j)) << j;
  EXPECT_EQ(j.find("\"subject\":\"T1\""), std::string::npos) << j;
  // Raised ones first, newest first.
  const auto t3 = j.find("\"id\":3,\"kind\":\"tag_silent\",\"severity\":\"warning\",\"raised\":true,"
                         "\"raised_utime\":500,\"cleared_utime\":null,\"acked\":false");
  const auto t2 = j.find("\"id\":2,");
  ASSERT_NE(t3, std::string::npos) << j;
  EXPECT_LT(t3, t2);
  // Cleared: its time kept; raised again: no longer acknowledged.
  EXPECT_TRUE(m.ack_alert("ips-zones", 2));
  m.on_alert(alert(2, alert_t::STATE_CLEARED, 600), kT0);
  j = m.json(kT0);
  EXPECT_NE(j.find("\"id\":2,\"kind\":\"tag_silent\",\"severity\":\"warning\",\"raised\":false,"
                   "\"raised_utime\":200,\"cleared_utime\":600,\"acked\":true"),
            std::string::npos)
      << j;
  m.on_alert(alert(2, alert_t::STATE_RAISED, 700), kT0);
  j = m.json(kT0);
  EXPECT_NE(j.find("\"id\":2,\"kind\":\"tag_silent\",\"severity\":\"warning\",\"raised\":true,"
                   "\"raised_utime\":200,\"cleared_utime\":null,\"acked\":false"),
            std::string::npos)
      << j;
}

TEST(ViewModel, EmptyModelGivesValidJson) {
  const ViewModel m;
  const std::string j = m.json(kT0);
  EXPECT_TRUE(valid_json(j)) << j;
  EXPECT_NE(j.find("\"site\":null"), std::string::npos);
  EXPECT_NE(j.find("\"tracks\":[]"), std::string::npos);
}

TEST(ChannelColours, DefaultChannelsKeepFixedColoursOthersShareThePalette) {
  const auto c = channel_colours({"POSE_UWB", "TRUTH", "ZZZ", "AAA", "POSE_FUSED"});
  EXPECT_EQ(c.at("TRUTH"), "#000000");
  EXPECT_EQ(c.at("POSE_UWB"), "#1f77b4");
  EXPECT_EQ(c.at("POSE_FUSED"), "#d62728");
  // Other names: a colour of their own (core/channel_colours.hpp, by the name), the same
  // whichever other channels are on the bus.
  EXPECT_EQ(c.at("AAA"), channel_colours({"AAA", "TRUTH"}).at("AAA"));
  EXPECT_EQ(c.at("ZZZ"), ips::channel_colour("ZZZ"));
  std::set<std::string> distinct;
  for (const auto& [ch, colour] : c) distinct.insert(colour);
  EXPECT_EQ(distinct.size(), c.size());
  // The same channel has the same colour whatever else is on the bus.
  EXPECT_EQ(channel_colours({"POSE_UWB"}).at("POSE_UWB"), "#1f77b4");
}

template <class Msg>
std::vector<uint8_t> encoded(const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

TEST(BusFeed, DecodesSitesHealthAndPosesOnAnyChannelAndCountsTheRest) {
  ViewModel m;
  BusFeed feed(m, {});
  const auto site = encoded(site_msg(kLabSite));
  feed.feed("SITE", site.data(), site.size(), kT0);
  const auto p = encoded(pose("T1", 3, 4));
  feed.feed("POSE_UWB", p.data(), p.size(), kT0 + 1);
  feed.feed("MY_OWN_ESTIMATOR", p.data(), p.size(), kT0 + 2);
  health_t h{};
  h.source = "ips-uwb-twr";
  h.host = "lab-pc";
  h.pid = 42;
  h.state = health_t::STATE_OK;
  const auto hb = encoded(h);
  feed.feed("HEALTH", hb.data(), hb.size(), kT0 + 3);
  uwb_range_t r{};
  r.tag_id = "T1";
  r.anchor_id = "A1";
  const auto rb = encoded(r);
  feed.feed("UWB_RANGE", rb.data(), rb.size(), kT0 + 4);
  // A pose on HEALTH and a range on SITE are refused by the fingerprint, counted, and named.
  EXPECT_STREQ(feed.feed("HEALTH", p.data(), p.size(), kT0 + 5), "health_t");
  EXPECT_STREQ(feed.feed("SITE", rb.data(), rb.size(), kT0 + 6), "site_t");
  const uint8_t junk[3] = {1, 2, 3};
  EXPECT_EQ(feed.feed("POSE_UWB", junk, sizeof junk, kT0 + 7), nullptr);  // not a pose: other

  EXPECT_EQ(feed.stats().messages, 8);
  EXPECT_EQ(feed.stats().poses, 2);
  EXPECT_EQ(feed.stats().undecodable, 2);
  EXPECT_EQ(feed.stats().other, 2);  // the range, and the junk on POSE_UWB
  EXPECT_TRUE(m.has_site());
  EXPECT_EQ(m.anchors().size(), 5u);
  ASSERT_EQ(m.tracks().size(), 2u);
  EXPECT_EQ(m.tracks().at({"MY_OWN_ESTIMATOR", "T1"}).position.x(), 3.0);
  EXPECT_EQ(m.processes().size(), 1u);
  // Every message counts in the channel table, decoded or not.
  const auto rows = m.channel_table(kT0 + 10);
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[0].channel, "HEALTH");
  EXPECT_EQ(rows[0].count, 2);
  EXPECT_EQ(rows[2].channel, "POSE_UWB");
  EXPECT_EQ(rows[2].count, 2);
  EXPECT_EQ(rows[2].bytes, static_cast<int64_t>(p.size() + sizeof junk));
}

TEST(BusFeed, DecodesAltitudesZoneEventsAndAlertsOnTheirChannels) {
  ViewModel m;
  BusFeed feed(m, {});
  altitude_t a{};
  a.tag_id = "T1";
  a.height_m = 4.0;
  a.floor = 1;
  a.floor_valid = true;
  const auto ab = encoded(a);
  EXPECT_EQ(feed.feed("ALTITUDE", ab.data(), ab.size(), kT0), nullptr);
  const auto zb = encoded(zone_event(zone_event_t::EVENT_ENTER, 0));
  EXPECT_EQ(feed.feed("ZONE_EVENT", zb.data(), zb.size(), kT0), nullptr);
  const auto lb = encoded(alert(7, alert_t::STATE_RAISED, 1));
  EXPECT_EQ(feed.feed("ALERT", lb.data(), lb.size(), kT0), nullptr);
  // Another type on each: refused by the fingerprint, counted, named.
  EXPECT_STREQ(feed.feed("ALTITUDE", zb.data(), zb.size(), kT0), "altitude_t");
  EXPECT_STREQ(feed.feed("ZONE_EVENT", lb.data(), lb.size(), kT0), "zone_event_t");
  EXPECT_STREQ(feed.feed("ALERT", ab.data(), ab.size(), kT0), "alert_t");
  EXPECT_EQ(feed.stats().undecodable, 3);
  EXPECT_EQ(m.stats().altitudes_in, 1);
  EXPECT_EQ(m.stats().zone_events_in, 1);
  EXPECT_EQ(m.stats().alerts_in, 1);
  EXPECT_TRUE(m.ack_alert("ips-zones", 7));
}

TEST(BusFeed, AnEmptySiteChannelTakesNoSite) {
  // ips-view --site FILE: SITE messages are not taken (nor decoded as poses).
  ViewModel m;
  BusFeed feed(m, {.site = "", .health = "HEALTH"});
  const auto site = encoded(site_msg(kLabSite));
  feed.feed("SITE", site.data(), site.size(), kT0);
  EXPECT_FALSE(m.has_site());
  EXPECT_EQ(feed.stats().other, 1);
  EXPECT_EQ(m.channel_table(kT0).size(), 1u);
}

TEST(ViewModel, JsonWithoutTrailsLeavesThemOut) {
  ViewModel m;
  for (int i = 0; i < 5; ++i) m.on_pose("POSE_UWB", pose("T1", i, 0), kT0 + i);
  const std::string with = m.json(kT0 + 10);
  const std::string without = m.json(kT0 + 10, false);
  EXPECT_TRUE(valid_json(without)) << without;
  EXPECT_NE(with.find("\"trail\":[[0,0],[1,0],[2,0],[3,0],[4,0]]"), std::string::npos) << with;
  EXPECT_EQ(without.find("\"trail\""), std::string::npos) << without;
  EXPECT_NE(without.find("\"position\":[4,0,1.2]"), std::string::npos) << without;
}

TEST(ViewModel, HostTimesFarApartDoNotOverflow) {
  // Log times are whatever the file says: ages and rates over the whole int64 range are plain
  // doubles (UBSan in the sanitizer build checks the arithmetic; fuzz_view_log found this).
  ViewModel m;
  const utime_t lo = std::numeric_limits<utime_t>::min() + 1;
  const utime_t hi = std::numeric_limits<utime_t>::max();
  m.on_bytes("A", 10, lo);
  m.on_bytes("A", 10, hi);
  m.on_pose("POSE_UWB", pose("T1", 1, 2), lo);
  const auto rows = m.channel_table(hi);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].age_s, 0.0);
  EXPECT_GT(rows[0].rate_hz, 0.0);
  EXPECT_TRUE(valid_json(m.json(hi)));
  EXPECT_TRUE(valid_json(m.json(lo)));
  EXPECT_NEAR(seconds_between(hi, lo), 1.8446744e13, 1e7);
}

}  // namespace
}  // namespace ips::view
