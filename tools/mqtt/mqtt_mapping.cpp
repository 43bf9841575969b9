#include "tools/mqtt/mqtt_mapping.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <nlohmann/json.hpp>

#include "core/health_state.hpp"
#include "core/message_names.hpp"
#include "core/track_limit.hpp"

namespace ips::mqtt {

namespace {

using nlohmann::json;

// Length of the valid UTF-8 sequence starting at s[i] (RFC 3629: no overlong forms, no
// surrogates, at most U+10FFFF), 0 when the bytes there are not one.
size_t utf8_sequence(std::string_view s, size_t i) {
  const auto b = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char c = b(i);
  size_t n = 0;
  unsigned lo = 0x80, hi = 0xbf;
  if (c < 0x80) return 1;
  if (c >= 0xc2 && c <= 0xdf) {
    n = 2;
  } else if (c >= 0xe0 && c <= 0xef) {
    n = 3;
    if (c == 0xe0) lo = 0xa0;
    if (c == 0xed) hi = 0x9f;
  } else if (c >= 0xf0 && c <= 0xf4) {
    n = 4;
    if (c == 0xf0) lo = 0x90;
    if (c == 0xf4) hi = 0x8f;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (b(i + 1) < lo || b(i + 1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if (b(i + k) < 0x80 || b(i + k) > 0xbf) return 0;
  return n;
}

json number_or_null(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

// "2026-12-02T21:34:41.123456Z" for the message's utime; null when it is not a plausible time.
json iso_time(int64_t utime) {
  if (!plausible_utime(utime)) return nullptr;
  const time_t secs = static_cast<time_t>(utime / 1000000);
  std::tm tm{};
  if (!gmtime_r(&secs, &tm)) return nullptr;
  char buf[96];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%06lldZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<long long>(utime % 1000000));
  return buf;
}

std::string dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

std::string unknown(int v) { return "unknown(" + std::to_string(v) + ")"; }

json position(const double (&p)[3]) {
  return json::array({number_or_null(p[0]), number_or_null(p[1]), number_or_null(p[2])});
}

}  // namespace

std::string topic_level(std::string_view id) {
  if (id.empty()) return "_";
  std::string out;
  out.reserve(id.size());
  for (size_t i = 0; i < id.size();) {
    const size_t n = utf8_sequence(id, i);
    const unsigned char c = static_cast<unsigned char>(id[i]);
    if (n == 0 || c == '+' || c == '#' || c == '/' || c < 0x20 || c == 0x7f) {
      out += '_';
      ++i;
    } else {
      out.append(id.substr(i, n));
      i += n;
    }
  }
  if (out.size() <= kMaxTopicLevel) return out;
  // An id off the bus may be any length: a long one is cut (at a character's start, so the level
  // stays UTF-8) and marked with a hash of the whole id, so that two long ids keep two topics.
  uint32_t hash = 2166136261u;  // FNV-1a
  for (const char c : id) hash = (hash ^ static_cast<unsigned char>(c)) * 16777619u;
  size_t cut = kMaxTopicLevel - 9;
  while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xc0) == 0x80) --cut;
  char mark[10];
  std::snprintf(mark, sizeof mark, "~%08x", hash);
  out.resize(cut);
  return out + mark;
}

std::string check_topic_prefix(std::string_view prefix) {
  if (prefix.empty()) return "empty";
  if (prefix.front() == '$') return "starts with '$' (the broker's own topics)";
  if (prefix.size() > 1000) return "longer than 1000 bytes";
  size_t level_start = 0;
  for (size_t i = 0; i <= prefix.size(); ++i) {
    if (i == prefix.size() || prefix[i] == '/') {
      if (i == level_start) return "has an empty level ('//', or '/' at an end)";
      level_start = i + 1;
      continue;
    }
    const unsigned char c = static_cast<unsigned char>(prefix[i]);
    if (c == '+' || c == '#') return "holds the wildcard '" + std::string(1, prefix[i]) + "'";
    if (c < 0x20 || c == 0x7f) return "holds a control character";
    const size_t n = utf8_sequence(prefix, i);
    if (n == 0) return "is not valid UTF-8";
    i += n - 1;
  }
  return "";
}

std::string pose_topic(const std::string& prefix, std::string_view site, std::string_view tag) {
  return prefix + "/" + topic_level(site) + "/tag/" + topic_level(tag) + "/pose";
}
std::string zone_topic(const std::string& prefix, std::string_view site, std::string_view tag) {
  return prefix + "/" + topic_level(site) + "/tag/" + topic_level(tag) + "/zone";
}
std::string alert_topic(const std::string& prefix, std::string_view site) {
  return prefix + "/" + topic_level(site) + "/alert";
}
std::string health_topic(const std::string& prefix, std::string_view site,
                         std::string_view process) {
  return prefix + "/" + topic_level(site) + "/health/" + topic_level(process);
}

std::optional<Ellipse> two_sigma_ellipse(const double (&cov)[9]) {
  const double a = cov[0], b = 0.5 * (cov[1] + cov[3]), d = cov[4];
  if (!std::isfinite(a) || !std::isfinite(b) || !std::isfinite(d)) return std::nullopt;
  // Eigenvalues of [[a, b], [b, d]]: mean +- sqrt(((a - d) / 2)^2 + b^2).
  const double mean = 0.5 * (a + d);
  const double r = std::hypot(0.5 * (a - d), b);
  const double l1 = mean + r, l2 = mean - r;
  if (l2 < -1e-12 * std::max(1.0, std::abs(l1))) return std::nullopt;
  Ellipse e;
  e.semi_major_m = 2 * std::sqrt(std::max(0.0, l1));
  e.semi_minor_m = 2 * std::sqrt(std::max(0.0, l2));
  double angle = 0.5 * std::atan2(2 * b, a - d) * 180.0 / M_PI;  // in (-90, 90]
  if (angle <= -90) angle += 180;
  e.angle_deg = angle;
  return e;
}

// The names of core/message_names.hpp (and core/health_state.hpp), with the number of a value
// the message definition does not have: "unknown(7)".
namespace {
std::string named(const char* name, int value) { return name ? name : unknown(value); }
}  // namespace
std::string zone_event_name(int8_t event) { return named(ips::zone_event_name(event), event); }
std::string alert_kind_name(int8_t kind) { return named(ips::alert_kind_name(kind), kind); }
std::string alert_severity_name(int8_t severity) {
  return named(ips::alert_severity_name(severity), severity);
}
std::string alert_state_name(int8_t state) { return named(ips::alert_state_name(state), state); }
std::string health_state_name(int8_t state) {
  const std::string name = ips::health_state_name(state);
  return name == "unknown" ? unknown(state) : name;
}

std::string pose_json(const pose_t& p, const std::string& channel) {
  json j;
  j["utime"] = p.utime;
  j["time"] = iso_time(p.utime);
  j["channel"] = channel;
  j["source"] = p.source;
  j["tag"] = p.tag_id;
  j["x"] = number_or_null(p.position[0]);
  j["y"] = number_or_null(p.position[1]);
  j["z"] = number_or_null(p.position[2]);
  bool cov_known = true;
  for (double v : p.position_cov) cov_known = cov_known && std::isfinite(v);
  if (cov_known) {
    json cov = json::array();
    for (double v : p.position_cov) cov.push_back(v);
    j["cov"] = cov;
  } else {
    j["cov"] = nullptr;
  }
  if (const auto e = two_sigma_ellipse(p.position_cov)) {
    j["ellipse_2sigma"] = {{"semi_major_m", e->semi_major_m},
                           {"semi_minor_m", e->semi_minor_m},
                           {"angle_deg", e->angle_deg}};
  } else {
    j["ellipse_2sigma"] = nullptr;
  }
  j["z_2sigma_m"] = std::isfinite(p.position_cov[8]) && p.position_cov[8] >= 0
                        ? json(2 * std::sqrt(p.position_cov[8]))
                        : json(nullptr);
  j["velocity"] = position(p.velocity);
  j["heading_deg"] = number_or_null(p.heading_rad * 180.0 / M_PI);
  j["num_used"] = p.num_used;
  j["residual_m"] = number_or_null(p.residual_m);
  j["status"] = p.status;
  json flags = json::array();
  const std::pair<int32_t, const char*> names[] = {{pose_t::STATUS_OK, "ok"},
                                                   {pose_t::STATUS_INITIALISING, "initialising"},
                                                   {pose_t::STATUS_COASTING, "coasting"},
                                                   {pose_t::STATUS_2D, "2d"},
                                                   {pose_t::STATUS_REINITIALISED, "reinitialised"}};
  for (const auto& [bit, name] : names)
    if (p.status & bit) flags.push_back(name);
  j["flags"] = flags;
  return dump(j);
}

std::string zone_json(const zone_event_t& e) {
  json j;
  j["utime"] = e.utime;
  j["time"] = iso_time(e.utime);
  j["source"] = e.source;
  j["seq"] = e.seq;
  j["tag"] = e.tag_id;
  j["zone_id"] = e.zone_id;
  j["zone_name"] = e.zone_name;
  j["floor"] = e.floor == zone_event_t::FLOOR_ANY ? json(nullptr) : json(e.floor);
  j["event"] = zone_event_name(e.event);
  j["dwell_s"] = number_or_null(e.dwell_s);
  j["x"] = number_or_null(e.position[0]);
  j["y"] = number_or_null(e.position[1]);
  j["z"] = number_or_null(e.position[2]);
  j["pose_channel"] = e.pose_channel;
  j["alert"] = e.alert != 0;
  return dump(j);
}

std::string alert_json(const alert_t& a) {
  json j;
  j["utime"] = a.utime;
  j["time"] = iso_time(a.utime);
  j["source"] = a.source;
  j["seq"] = a.seq;
  j["id"] = a.id;
  j["kind"] = alert_kind_name(a.kind);
  j["severity"] = alert_severity_name(a.severity);
  j["state"] = alert_state_name(a.state);
  j["subject"] = a.subject;
  j["text"] = a.text;
  return dump(j);
}

std::string health_json(const health_t& h) {
  json j;
  j["utime"] = h.utime;
  j["time"] = iso_time(h.utime);
  j["source"] = h.source;
  j["host"] = h.host;
  j["pid"] = h.pid;
  j["state"] = health_state_name(h.state);
  j["msgs_in"] = h.msgs_in;
  j["msgs_out"] = h.msgs_out;
  j["parse_errors"] = h.parse_errors;
  j["drops"] = h.drops;
  j["last_error"] = h.last_error;
  j["uptime_s"] = utime_to_s(h.uptime_us);
  j["kernel_drops"] = h.kernel_drops;
  j["queue_drops"] = h.queue_drops;
  j["seq_lost"] = h.seq_lost;
  j["consistency"] = h.consistency;
  j["version"] = h.version;
  j["note"] = h.note;
  return dump(j);
}

PoseRateLimiter::PoseRateLimiter(double max_hz, int max_tags)
    : interval_(max_hz > 0 ? s_to_utime(1.0 / max_hz) : 0), max_tags_(max_tags) {}

bool PoseRateLimiter::admit(const pose_t& pose, const std::string& channel, utime_t now) {
  if (interval_ == 0) return true;
  auto key = std::make_pair(pose.tag_id, channel);
  auto it = tracks_.find(key);
  if (it == tracks_.end()) {
    if (!room_for_track(tracks_, now, max_tags_, s_to_utime(60.0))) {
      ++untracked_;
      return true;
    }
    Track& t = tracks_[std::move(key)];
    t.last_sent = t.newest_utime = now;
    return true;
  }
  Track& t = it->second;
  t.newest_utime = now;
  if (!t.held && now - t.last_sent >= interval_) {
    t.last_sent = now;
    return true;
  }
  if (t.held) ++rate_limited_;
  t.held = pose;
  return false;
}

size_t PoseRateLimiter::held() const {
  size_t n = 0;
  for (const auto& [key, t] : tracks_) n += t.held ? 1 : 0;
  return n;
}

}  // namespace ips::mqtt
