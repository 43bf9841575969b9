// libFuzzer target: ips-mqtt's mapping (tools/mqtt/mqtt_mapping.hpp) of any message off the bus.
// The first byte picks the type (pose_t, zone_event_t, alert_t, health_t); the rest is decoded as
// it and mapped: every payload must be valid JSON (parsed back) and every topic a valid MQTT topic
// name (levels not empty, no wildcard, UTF-8: check_topic_prefix accepts it). The bytes are also
// taken as an id and as a prefix directly. Never a crash, hang or exception.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "core/node.hpp"
#include "tools/mqtt/mqtt_mapping.hpp"

namespace {

void expect_json(const std::string& payload) {
  if (!nlohmann::json::accept(payload)) __builtin_trap();
}
void expect_topic(const std::string& topic) {
  if (!ips::mqtt::check_topic_prefix(topic).empty()) __builtin_trap();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  namespace mq = ips::mqtt;
  const std::string raw(reinterpret_cast<const char*>(data), size);
  const std::string level = mq::topic_level(raw);
  if (level.find_first_of("+#/") != std::string::npos) __builtin_trap();
  expect_topic("ips/" + level);
  (void)mq::check_topic_prefix(raw);
  if (size < 1) return 0;
  const uint8_t* body = data + 1;
  const size_t n = size - 1;
  switch (data[0] % 4) {
    case 0: {
      ips::pose_t m;
      if (!ips::decode_message(m, body, n)) return 0;
      expect_json(mq::pose_json(m, "POSE_FUSED"));
      expect_topic(mq::pose_topic("ips", m.source, m.tag_id));
      (void)mq::two_sigma_ellipse(m.position_cov);
      mq::PoseRateLimiter limiter(5.0, 2);
      for (int64_t t = 0; t < 3; ++t) (void)limiter.admit(m, "POSE_FUSED", m.utime + t);
      break;
    }
    case 1: {
      ips::zone_event_t m;
      if (!ips::decode_message(m, body, n)) return 0;
      expect_json(mq::zone_json(m));
      expect_topic(mq::zone_topic("ips", m.zone_name, m.tag_id));
      break;
    }
    case 2: {
      ips::alert_t m;
      if (!ips::decode_message(m, body, n)) return 0;
      expect_json(mq::alert_json(m));
      expect_topic(mq::alert_topic("ips", m.subject));
      break;
    }
    default: {
      ips::health_t m;
      if (!ips::decode_message(m, body, n)) return 0;
      expect_json(mq::health_json(m));
      expect_topic(mq::health_topic("ips", m.host, m.source));
    }
  }
  return 0;
}
