// ips-mqtt's mapping of LCM messages to MQTT topics and JSON (tools/mqtt/mqtt_mapping.hpp), and
// its per-tag pose rate limit. The payloads are parsed back and checked field by field against
// docs/mqtt.md.
#include "tools/mqtt/mqtt_mapping.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ips::mqtt {
namespace {

using nlohmann::json;

pose_t test_pose(const std::string& tag = "T1") {
  pose_t p{};
  p.utime = 1764700000000003;  // 2025-12-02T18:26:40.000003Z
  p.source = "fuse";
  p.tag_id = tag;
  p.position[0] = 1.5;
  p.position[1] = 2.5;
  p.position[2] = 1.2;
  const double cov[9] = {0.04, 0, 0, 0, 0.01, 0, 0, 0, 0.09};
  for (int k = 0; k < 9; ++k) p.position_cov[k] = cov[k];
  p.velocity[0] = 0.5;
  p.velocity[1] = 0;
  p.velocity[2] = NAN;
  p.heading_rad = M_PI / 2;
  p.num_used = 6;
  p.residual_m = NAN;
  p.status = int32_t{pose_t::STATUS_OK} | pose_t::STATUS_2D;
  return p;
}

TEST(MqttTopicLevel, WildcardsSeparatorsControlAndBadUtf8BecomeUnderscores) {
  EXPECT_EQ(topic_level("T1"), "T1");
  EXPECT_EQ(topic_level("a/b+c#d"), "a_b_c_d");
  EXPECT_EQ(topic_level(""), "_");
  EXPECT_EQ(topic_level(std::string("x\x01y\x7f", 4)), "x_y_");
  EXPECT_EQ(topic_level("Zo\xc3\xa9"), "Zo\xc3\xa9");  // é, valid UTF-8, kept
  EXPECT_EQ(topic_level("\xff"
                        "a"),
            "_a");                                                 // not UTF-8
  EXPECT_EQ(topic_level("\xc0\xaf"), "__");                        // overlong '/'
  EXPECT_EQ(topic_level("\xed\xa0\x80"), "___");                   // a surrogate
  EXPECT_EQ(topic_level("\xf0\x9f\x93\x8d"), "\xf0\x9f\x93\x8d");  // U+1F4CD, 4 bytes
  EXPECT_EQ(topic_level("\xe2\x82"), "__");                        // truncated sequence
  EXPECT_EQ(topic_level("a b$c"), "a b$c");                        // legal in a level
}

// Found by fuzz_mqtt_mapping (seed tests/fuzz/seeds/mqtt_mapping/long-id): an id of 997 bytes made
// a topic check_topic_prefix refused (longer than 1000 bytes); an id off the bus may be any length.
TEST(MqttTopicLevel, LongIdsAreCutToFitAndKeptApartByAHash) {
  const std::string fits(kMaxTopicLevel, 'a');
  EXPECT_EQ(topic_level(fits), fits);
  const std::string level = topic_level(std::string(997, 'a'));
  ASSERT_EQ(level.size(), kMaxTopicLevel);
  EXPECT_EQ(level.substr(0, kMaxTopicLevel - 9), std::string(kMaxTopicLevel - 9, 'a'));
  EXPECT_EQ(level[kMaxTopicLevel - 9], '~');
  EXPECT_EQ(level.find_first_not_of("0123456789abcdef", kMaxTopicLevel - 8), std::string::npos);
  EXPECT_EQ(check_topic_prefix("ips/" + level), "");
  EXPECT_NE(topic_level(std::string(997, 'a') + "b"), topic_level(std::string(997, 'a') + "c"));
  std::string accents;  // é is 2 bytes: the cut must not split one
  for (int i = 0; i < 150; ++i) accents += "\xc3\xa9";
  const std::string cut = topic_level(accents);
  EXPECT_LE(cut.size(), kMaxTopicLevel);
  EXPECT_EQ(check_topic_prefix(cut), "");
  const std::string huge(70000, '/');
  EXPECT_EQ(check_topic_prefix(pose_topic("ips", huge, huge)), "");
  EXPECT_EQ(check_topic_prefix(health_topic("ips", huge, huge)), "");
}

TEST(MqttTopicPrefix, LevelsWithoutWildcardsOrEmptyOnes) {
  EXPECT_EQ(check_topic_prefix("ips"), "");
  EXPECT_EQ(check_topic_prefix("acme/site-3/ips"), "");
  EXPECT_NE(check_topic_prefix(""), "");
  EXPECT_NE(check_topic_prefix("a//b"), "");
  EXPECT_NE(check_topic_prefix("/ips"), "");
  EXPECT_NE(check_topic_prefix("ips/"), "");
  EXPECT_NE(check_topic_prefix("$SYS"), "");
  EXPECT_NE(check_topic_prefix("ips/+"), "");
  EXPECT_NE(check_topic_prefix("ips#"), "");
  EXPECT_NE(check_topic_prefix("ip\ts"), "");
  EXPECT_NE(check_topic_prefix("ips\xff"), "");
}

TEST(MqttTopics, AreThePrefixTheSiteAndTheSanitisedIds) {
  EXPECT_EQ(pose_topic("ips", "lab", "T1"), "ips/lab/tag/T1/pose");
  EXPECT_EQ(pose_topic("acme/ips", "lab/2", "T/1"), "acme/ips/lab_2/tag/T_1/pose");
  EXPECT_EQ(zone_topic("ips", "lab", "T#1"), "ips/lab/tag/T_1/zone");
  EXPECT_EQ(alert_topic("ips", ""), "ips/_/alert");
  EXPECT_EQ(health_topic("ips", "lab", "ips-uwb-twr"), "ips/lab/health/ips-uwb-twr");
  EXPECT_EQ(health_topic("ips", "lab", "+"), "ips/lab/health/_");
}

TEST(MqttEllipse, TwoSigmaSemiAxesAndOrientationOfTheHorizontalCovariance) {
  // Diagonal: sigma_x 0.2 m, sigma_y 0.1 m -> 0.4 and 0.2 m along x.
  auto e = two_sigma_ellipse({0.04, 0, 0, 0, 0.01, 0, 0, 0, 1});
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->semi_major_m, 0.4, 1e-12);
  EXPECT_NEAR(e->semi_minor_m, 0.2, 1e-12);
  EXPECT_NEAR(e->angle_deg, 0, 1e-9);
  // Along y: the major axis at 90 degrees.
  e = two_sigma_ellipse({0.01, 0, 0, 0, 0.04, 0, 0, 0, 1});
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->angle_deg, 90, 1e-9);
  // [[0.02, 0.01], [0.01, 0.02]]: eigenvalues 0.03 along (1, 1) and 0.01 along (1, -1).
  e = two_sigma_ellipse({0.02, 0.01, 0, 0.01, 0.02, 0, 0, 0, 1});
  ASSERT_TRUE(e);
  EXPECT_NEAR(e->semi_major_m, 2 * std::sqrt(0.03), 1e-12);
  EXPECT_NEAR(e->semi_minor_m, 0.2, 1e-12);
  EXPECT_NEAR(e->angle_deg, 45, 1e-9);
  EXPECT_FALSE(two_sigma_ellipse({NAN, 0, 0, 0, 0.01, 0, 0, 0, 1}));
  EXPECT_FALSE(two_sigma_ellipse({0.01, 0.1, 0, 0.1, 0.01, 0, 0, 0, 1}));  // not PSD
}

TEST(MqttPoseJson, CarriesThePoseItsCovarianceEllipseAndFlags) {
  const json j = json::parse(pose_json(test_pose(), "POSE_FUSED"));
  EXPECT_EQ(j["utime"], 1764700000000003);
  EXPECT_EQ(j["time"], "2025-12-02T18:26:40.000003Z");
  EXPECT_EQ(j["channel"], "POSE_FUSED");
  EXPECT_EQ(j["source"], "fuse");
  EXPECT_EQ(j["tag"], "T1");
  EXPECT_EQ(j["x"], 1.5);
  EXPECT_EQ(j["y"], 2.5);
  EXPECT_EQ(j["z"], 1.2);
  EXPECT_EQ(j["cov"], json({0.04, 0, 0, 0, 0.01, 0, 0, 0, 0.09}));
  EXPECT_NEAR(j["ellipse_2sigma"]["semi_major_m"].get<double>(), 0.4, 1e-12);
  EXPECT_NEAR(j["ellipse_2sigma"]["semi_minor_m"].get<double>(), 0.2, 1e-12);
  EXPECT_NEAR(j["z_2sigma_m"].get<double>(), 0.6, 1e-12);
  EXPECT_EQ(j["velocity"], json({0.5, 0, nullptr}));  // NaN: unknown
  EXPECT_NEAR(j["heading_deg"].get<double>(), 90, 1e-12);
  EXPECT_EQ(j["num_used"], 6);
  EXPECT_TRUE(j["residual_m"].is_null());
  EXPECT_EQ(j["status"], 9);
  EXPECT_EQ(j["flags"], json({"ok", "2d"}));
}

TEST(MqttPoseJson, UnknownCovarianceIsNullAndBadUtf8IsReplacedNotThrown) {
  pose_t p = test_pose(std::string("T\xff", 2));
  p.position_cov[0] = NAN;
  p.utime = 0;  // not a time
  const json j = json::parse(pose_json(p, "POSE_UWB"));
  EXPECT_TRUE(j["cov"].is_null());
  EXPECT_TRUE(j["ellipse_2sigma"].is_null());
  EXPECT_TRUE(j["time"].is_null());
  EXPECT_EQ(j["tag"], "T\xef\xbf\xbd");  // U+FFFD
}

TEST(MqttZoneJson, NamesTheEventAndFloorAnyIsNull) {
  zone_event_t e{};
  e.utime = 1764700000000000;
  e.source = "ips-zones";
  e.seq = 3;
  e.tag_id = "T1";
  e.zone_id = "Z1";
  e.zone_name = "Store room";
  e.floor = zone_event_t::FLOOR_ANY;
  e.event = zone_event_t::EVENT_LEAVE;
  e.dwell_s = 12.5;
  e.position[0] = 3;
  e.position[1] = 4;
  e.position[2] = 1.2;
  e.pose_channel = "POSE_FUSED";
  e.alert = true;
  json j = json::parse(zone_json(e));
  EXPECT_EQ(j["event"], "leave");
  EXPECT_TRUE(j["floor"].is_null());
  EXPECT_EQ(j["zone_name"], "Store room");
  EXPECT_EQ(j["dwell_s"], 12.5);
  EXPECT_EQ(j["x"], 3);
  EXPECT_EQ(j["alert"], true);
  EXPECT_EQ(j["seq"], 3);
  e.floor = 2;
  e.event = 9;
  j = json::parse(zone_json(e));
  EXPECT_EQ(j["floor"], 2);
  EXPECT_EQ(j["event"], "unknown(9)");
}

TEST(MqttAlertJson, NamesKindSeverityAndState) {
  alert_t a{};
  a.utime = 1764700000000000;
  a.source = "ips-zones";
  a.seq = 5;
  a.id = 7;
  a.kind = alert_t::KIND_TAG_SILENT;
  a.severity = alert_t::SEVERITY_WARNING;
  a.state = alert_t::STATE_CLEARED;
  a.subject = "T3";
  a.text = "T3: no pose on POSE_FUSED for 12.0 s";
  const json j = json::parse(alert_json(a));
  EXPECT_EQ(j["kind"], "tag_silent");
  EXPECT_EQ(j["severity"], "warning");
  EXPECT_EQ(j["state"], "cleared");
  EXPECT_EQ(j["id"], 7);
  EXPECT_EQ(j["subject"], "T3");
  EXPECT_EQ(j["text"], "T3: no pose on POSE_FUSED for 12.0 s");
}

TEST(MqttHealthJson, CarriesEveryFieldWithTheStateInWords) {
  health_t h{};
  h.utime = 1764700000000000;
  h.source = "ips-uwb-twr";
  h.host = "sensors";
  h.pid = 42;
  h.state = health_t::STATE_DEGRADED;
  h.msgs_in = 100;
  h.drops = 2;
  h.last_error = "UWB_RANGE: 2 ranges dropped";
  h.uptime_us = 3500000;
  h.version = "0.1.0 (git x, Release)";
  h.note = "a note";
  const json j = json::parse(health_json(h));
  EXPECT_EQ(j["state"], "degraded");
  EXPECT_EQ(j["uptime_s"], 3.5);
  EXPECT_EQ(j["msgs_in"], 100);
  EXPECT_EQ(j["drops"], 2);
  EXPECT_EQ(j["host"], "sensors");
  EXPECT_EQ(j["version"], "0.1.0 (git x, Release)");
  EXPECT_EQ(j["note"], "a note");
  EXPECT_EQ(j["last_error"], "UWB_RANGE: 2 ranges dropped");
}

// At 5 Hz (0.2 s) and poses every 50 ms: the first goes at once, the next ones are held (each
// replacing the one before: rate-limited), and the newest held goes when 0.2 s have passed.
TEST(MqttPoseRateLimiter, SendsAtMostMaxHzAndAlwaysTheNewestPose) {
  PoseRateLimiter limiter(5.0);
  std::vector<int> sent;
  auto release = [&](utime_t now) {
    limiter.release(now, [&](const pose_t& p, const std::string&) { sent.push_back(p.num_used); });
  };
  for (int i = 0; i <= 8; ++i) {
    pose_t p = test_pose();
    p.num_used = i;
    const utime_t now = i * 50000;
    release(now);
    if (limiter.admit(p, "POSE_FUSED", now)) sent.push_back(i);
  }
  release(400000);
  // 0 at 0 s; 1..3 held in turn, 3 released at 0.2 s; 4..7 held, 7 released at 0.4 s; 8 held.
  EXPECT_EQ(sent, (std::vector<int>{0, 3, 7}));
  EXPECT_EQ(limiter.held(), 1u);
  EXPECT_EQ(limiter.rate_limited(), 5);  // 1, 2, 4, 5, 6 replaced
  release(600000);
  EXPECT_EQ(sent, (std::vector<int>{0, 3, 7, 8}));  // a tag's last pose is not lost
  EXPECT_EQ(limiter.held(), 0u);
}

TEST(MqttPoseRateLimiter, TagsAndChannelsAreLimitedApartAndZeroHzLimitsNothing) {
  PoseRateLimiter limiter(5.0);
  EXPECT_TRUE(limiter.admit(test_pose("T1"), "POSE_FUSED", 0));
  EXPECT_TRUE(limiter.admit(test_pose("T2"), "POSE_FUSED", 1000));
  EXPECT_TRUE(limiter.admit(test_pose("T1"), "POSE_UWB", 2000));
  EXPECT_FALSE(limiter.admit(test_pose("T1"), "POSE_FUSED", 3000));
  PoseRateLimiter all(0.0);
  for (int i = 0; i < 100; ++i) EXPECT_TRUE(all.admit(test_pose(), "POSE_FUSED", i));
  EXPECT_EQ(all.rate_limited(), 0);
}

TEST(MqttPoseRateLimiter, TagsBeyondTheLimitAreSentUnlimitedAndCounted) {
  PoseRateLimiter limiter(5.0, 2);
  EXPECT_TRUE(limiter.admit(test_pose("T1"), "POSE_FUSED", 0));
  EXPECT_TRUE(limiter.admit(test_pose("T2"), "POSE_FUSED", 0));
  EXPECT_TRUE(limiter.admit(test_pose("T3"), "POSE_FUSED", 0));
  EXPECT_TRUE(limiter.admit(test_pose("T3"), "POSE_FUSED", 1));
  EXPECT_EQ(limiter.untracked(), 2);
  // A minute of silence from T1 and T2 makes room for T3.
  EXPECT_TRUE(limiter.admit(test_pose("T3"), "POSE_FUSED", 61000000));
  EXPECT_FALSE(limiter.admit(test_pose("T3"), "POSE_FUSED", 61000001));
}

}  // namespace
}  // namespace ips::mqtt
