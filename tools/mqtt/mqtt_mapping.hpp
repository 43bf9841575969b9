#pragma once
// ips-mqtt's pure core: what an LCM message becomes on MQTT (topic and JSON payload, docs/mqtt.md),
// and the per-tag pose rate limit. Values in, values out: no socket, clock or LCM here.
#include <cstdint>
#include <ips/alert_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/zone_event_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "core/time.hpp"

namespace ips::mqtt {

// One MQTT topic level from an id off the bus (tag, process, site name): '+', '#' and '/' (MQTT
// wildcards and the level separator), control characters, DEL and bytes that are not valid UTF-8
// (a topic must be UTF-8, MQTT 3.1.1 section 1.5.3) each become '_'; an empty id becomes "_".
// A level longer than kMaxTopicLevel bytes is cut to fit, ending in '~' and 8 hex digits of a
// hash of the whole id (topics stay within check_topic_prefix's 1000 bytes, long ids apart).
// The payload always carries the id as published.
inline constexpr size_t kMaxTopicLevel = 200;
std::string topic_level(std::string_view id);

// Checks --topic-prefix: one or more levels separated by '/', none empty, no '+' or '#', not
// starting with '$' (the broker's own topics), valid UTF-8 without control characters.
// Returns "" when valid, else the reason.
std::string check_topic_prefix(std::string_view prefix);

// The topics (docs/mqtt.md#topics).
std::string pose_topic(const std::string& prefix, std::string_view site, std::string_view tag);
std::string zone_topic(const std::string& prefix, std::string_view site, std::string_view tag);
std::string alert_topic(const std::string& prefix, std::string_view site);
std::string health_topic(const std::string& prefix, std::string_view site,
                         std::string_view process);

// The horizontal 2-sigma ellipse of a position covariance (x, y block): semi-axes in m and the
// major axis's angle from +x, counter-clockwise, in degrees (-90, 90]; the eigen-decomposition of
// the 2x2 symmetric block. nullopt when the block is unknown (NaN) or not positive semi-definite.
struct Ellipse {
  double semi_major_m = 0;
  double semi_minor_m = 0;
  double angle_deg = 0;
};
std::optional<Ellipse> two_sigma_ellipse(const double (&cov)[9]);

// The JSON payloads (one line each; NaN becomes null; strings that are not UTF-8 are kept with
// their bad bytes replaced by U+FFFD).
std::string pose_json(const pose_t& pose, const std::string& channel);
std::string zone_json(const zone_event_t& event);
std::string alert_json(const alert_t& alert);
std::string health_json(const health_t& health);

// Names of the enumerations as the payloads write them ("enter", "critical", ...); an unknown
// value is "unknown(N)".
std::string zone_event_name(int8_t event);
std::string alert_kind_name(int8_t kind);
std::string alert_severity_name(int8_t severity);
std::string alert_state_name(int8_t state);
std::string health_state_name(int8_t state);

// Per tag and pose channel, at most max_hz poses a second (host time of arrival): a pose that
// comes sooner than 1/max_hz after the last one sent is held, replacing one held before (that
// one is rate-limited: never sent), and released by release() once its time has come, so that a
// tag's last pose is always sent. max_hz 0: every pose goes at once. At most max_tags (tag,
// channel) pairs are tracked; a new pair beyond them, while none is silent for a minute, is
// sent at once (and counted in untracked()).
class PoseRateLimiter {
 public:
  struct Held {
    pose_t pose;
    std::string channel;
  };
  PoseRateLimiter(double max_hz, int max_tags = 10000);

  // True: send this pose now. False: it is held (released later, or replaced).
  bool admit(const pose_t& pose, const std::string& channel, utime_t now);
  // Hands over the held poses whose time has come at `now`.
  template <class Fn>
  void release(utime_t now, Fn&& send) {
    for (auto& [key, t] : tracks_)
      if (t.held && now - t.last_sent >= interval_) {
        t.last_sent = now;
        t.newest_utime = now;
        Held h{std::move(*t.held), key.second};
        t.held.reset();
        send(h.pose, h.channel);
      }
  }
  // Poses replaced while held: never sent (not an error).
  int64_t rate_limited() const { return rate_limited_; }
  int64_t untracked() const { return untracked_; }
  size_t held() const;

 private:
  struct Track {
    utime_t last_sent = 0;
    utime_t newest_utime = 0;  // arrival of the newest pose (room_for_track's staleness)
    std::optional<pose_t> held;
  };
  utime_t interval_;
  int max_tags_;
  std::map<std::pair<std::string, std::string>, Track> tracks_;
  int64_t rate_limited_ = 0;
  int64_t untracked_ = 0;
};

}  // namespace ips::mqtt
