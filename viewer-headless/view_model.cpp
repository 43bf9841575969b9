#include "viewer-headless/view_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <numbers>
#include <set>

#include "core/channels.hpp"
#include "core/message_names.hpp"

namespace ips::view {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

std::string cut(std::string_view s, size_t max_bytes) {
  return std::string(s.substr(0, max_bytes));
}

// Makes room for a new key in a table bounded to `max` entries: the entry silent longest gives
// way when it has been silent for expire_s of host time. False: no room, the new key is dropped.
template <class Map, class LastSeen>
bool make_room(Map& map, size_t max, utime_t now, double expire_s, LastSeen last_seen,
               int64_t& expired) {
  if (map.size() < max) return true;
  if (map.empty()) return false;  // max == 0
  auto oldest = map.begin();
  for (auto it = map.begin(); it != map.end(); ++it)
    if (last_seen(it->second) < last_seen(oldest->second)) oldest = it;
  if (!(seconds_between(now, last_seen(oldest->second)) >= expire_s)) return false;
  map.erase(oldest);
  ++expired;
  return true;
}

// The length of the valid UTF-8 sequence starting at s[i] (RFC 3629, Unicode table 3-7: no
// overlong forms, no surrogates, nothing above U+10FFFF); 0 when it is not one.
size_t utf8_sequence_length(std::string_view s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[i + k]); };
  const unsigned char c = byte(0);
  size_t n = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
  if (c >= 0xC2 && c <= 0xDF) {
    n = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    n = 3;
    if (c == 0xE0) lo = 0xA0;
    if (c == 0xED) hi = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    n = 4;
    if (c == 0xF0) lo = 0x90;
    if (c == 0xF4) hi = 0x8F;
  } else {
    return 0;
  }
  if (i + n > s.size()) return 0;
  if (byte(1) < lo || byte(1) > hi) return 0;
  for (size_t k = 2; k < n; ++k)
    if (byte(k) < 0x80 || byte(k) > 0xBF) return 0;
  return n;
}

// Appends `"key":` (key is ours, plain ASCII).
void key(std::string& out, const char* name) {
  out += '"';
  out += name;
  out += "\":";
}

// The anchors as a JSON array.
void append_anchors(std::string& s, const std::vector<Anchor>& anchors) {
  s += '[';
  for (size_t i = 0; i < anchors.size(); ++i) {
    const Anchor& a = anchors[i];
    if (i) s += ',';
    s += '{';
    key(s, "id");
    s += json_string(a.id) + ',';
    key(s, "kind");
    s += json_string(a.kind) + ',';
    key(s, "enabled");
    s += a.enabled ? "true," : "false,";
    key(s, "position");
    s += '[' + json_number(a.position.x()) + ',' + json_number(a.position.y()) + ',' +
         json_number(a.position.z()) + ']';
    if (a.kind == "ble_aoa") {
      s += ',';
      key(s, "yaw_deg");
      s += json_number(a.orientation_rad.z() * kRadToDeg);
    }
    s += '}';
  }
  s += ']';
}

const char* name_or_unknown(const char* name) { return name ? name : "unknown"; }

std::string xy_json(const Eigen::Vector2d& p) {
  return '[' + json_number(p.x()) + ',' + json_number(p.y()) + ']';
}

}  // namespace

void Trail::push(utime_t t, const Eigen::Vector2d& p) {
  if (ring_.empty()) return;
  ring_[next_] = {t, p};
  next_ = (next_ + 1) % ring_.size();
  size_ = std::min(size_ + 1, ring_.size());
}

std::vector<Eigen::Vector2d> Trail::points() const {
  std::vector<Eigen::Vector2d> out;
  if (size_ == 0) return out;
  const size_t cap = ring_.size();
  const utime_t newest = ring_[(next_ + cap - 1) % cap].t;
  size_t first = 0;  // the oldest point within the window
  while (first < size_ && seconds_between(newest, ring_[(next_ + cap - size_ + first) % cap].t) >
                              window_s_)
    ++first;
  out.reserve(size_ - first);
  for (size_t i = first; i < size_; ++i) out.push_back(ring_[(next_ + cap - size_ + i) % cap].p);
  return out;
}

std::vector<std::string> status_names(int32_t status) {
  std::vector<std::string> names;
  if (status & pose_t::STATUS_OK) names.emplace_back("ok");
  if (status & pose_t::STATUS_INITIALISING) names.emplace_back("initialising");
  if (status & pose_t::STATUS_COASTING) names.emplace_back("coasting");
  if (status & pose_t::STATUS_2D) names.emplace_back("2d");
  if (status & pose_t::STATUS_REINITIALISED) names.emplace_back("reinitialised");
  return names;
}

std::optional<Ellipse> covariance_ellipse(const Eigen::Matrix2d& cov, double n_sigma) {
  if (!(n_sigma > 0) || !cov.allFinite()) return std::nullopt;
  const double a = cov(0, 0), c = cov(1, 1), b = 0.5 * (cov(0, 1) + cov(1, 0));
  // Eigenvalues of [[a, b], [b, c]]: (a + c) / 2 +- hypot((a - c) / 2, b); the smaller one as
  // det / larger, which keeps its precision when the matrix is nearly singular.
  const double large = 0.5 * (a + c) + std::hypot(0.5 * (a - c), b);
  if (!(large > 0)) return std::nullopt;
  const double small = (a * c - b * b) / large;
  if (!(small > 0) || !std::isfinite(large)) return std::nullopt;
  Ellipse e;
  e.semi_major_m = n_sigma * std::sqrt(large);
  e.semi_minor_m = n_sigma * std::sqrt(small);
  e.angle_rad = 0.5 * std::atan2(2 * b, a - c);
  if (e.angle_rad <= -std::numbers::pi / 2) e.angle_rad += std::numbers::pi;
  return e;
}

std::string json_string(std::string_view s) {
  std::string out;
  out.reserve(s.size() + 2);
  out += '"';
  size_t i = 0;
  while (i < s.size()) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c < 0x80) {
      if (c == '"' || c == '\\') {
        out += '\\';
        out += static_cast<char>(c);
      } else if (c < 0x20 || c == 0x7f || c == '<' || c == '>' || c == '&') {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        out += buf;
      } else {
        out += static_cast<char>(c);
      }
      ++i;
      continue;
    }
    const size_t n = utf8_sequence_length(s, i);
    if (n == 0) {
      out += "\\ufffd";
      ++i;
      continue;
    }
    // U+2028 and U+2029 end a line in JavaScript source (before ES2019).
    if (n == 3 && c == 0xE2 && static_cast<unsigned char>(s[i + 1]) == 0x80 &&
        (static_cast<unsigned char>(s[i + 2]) & 0xFE) == 0xA8)
      out += static_cast<unsigned char>(s[i + 2]) == 0xA8 ? "\\u2028" : "\\u2029";
    else
      out.append(s.substr(i, n));
    i += n;
  }
  out += '"';
  return out;
}

std::string json_number(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

ViewModel::ViewModel(ViewOptions options) : options_(options) {}

void ViewModel::on_site(const site_t& msg, utime_t host_utime) {
  ++stats_.sites_in;
  try {
    Site site = site_from_msg(msg);
    if (site.anchors.size() > options_.max_anchors)
      throw SiteError("SITE message from " + msg.source + ": " +
                      std::to_string(site.anchors.size()) + " anchors, more than " +
                      std::to_string(options_.max_anchors));
    anchors_ = std::move(site.anchors);
    if (msg.site_yaml != site_yaml_) {
      site_yaml_ = msg.site_yaml;
      layout_ = std::move(site.layout);
      ++site_version_;
    }
    site_name_ = cut(site.name, options_.max_id_bytes);
    site_source_ = cut(msg.source, options_.max_id_bytes);
    site_host_utime_ = host_utime;
    has_site_ = true;
  } catch (const std::exception& e) {
    ++stats_.bad_sites;
    last_site_error_ = cut(e.what(), options_.max_error_bytes);
  }
}

void ViewModel::on_pose(const std::string& channel, const pose_t& msg, utime_t host_utime) {
  ++stats_.poses_in;
  if (channel.size() > options_.max_id_bytes || msg.tag_id.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  TrackKey k{channel, msg.tag_id};
  auto it = tracks_.find(k);
  if (!std::isfinite(msg.position[0]) || !std::isfinite(msg.position[1])) {
    ++stats_.non_finite_positions;
    if (it != tracks_.end()) ++it->second.non_finite;
    return;
  }
  if (it == tracks_.end()) {
    if (!make_room(
            tracks_, options_.max_tracks, host_utime, options_.expire_s,
            [](const Track& t) { return t.host_utime; }, stats_.expired)) {
      ++stats_.dropped_too_many_tracks;
      return;
    }
    it = tracks_.emplace(std::move(k), Track{}).first;
    it->second.channel = channel;
    it->second.tag = msg.tag_id;
    it->second.trail = Trail(options_.trail_length, options_.trail_s);
  }
  Track& t = it->second;
  t.source.assign(msg.source, 0, std::min(msg.source.size(), options_.max_id_bytes));
  t.utime = msg.utime;
  t.host_utime = host_utime;
  t.position = {msg.position[0], msg.position[1], msg.position[2]};
  // position_cov is the row-major 3x3; its top-left 2x2 is the horizontal block.
  t.cov_xy << msg.position_cov[0], msg.position_cov[1], msg.position_cov[3], msg.position_cov[4];
  t.heading_rad = msg.heading_rad;
  t.status = msg.status;
  ++t.count;
  t.trail.push(host_utime, t.position.head<2>());
}

void ViewModel::on_health(const health_t& msg, utime_t host_utime) {
  ++stats_.health_in;
  if (msg.source.size() > options_.max_id_bytes || msg.host.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  ProcessKey k{msg.source, msg.host, msg.pid};
  auto it = processes_.find(k);
  if (it == processes_.end()) {
    if (!make_room(
            processes_, options_.max_processes, host_utime, options_.expire_s,
            [](const Process& p) { return p.host_utime; }, stats_.expired)) {
      ++stats_.dropped_too_many_processes;
      return;
    }
    it = processes_.emplace(std::move(k), Process{}).first;
  }
  Process& p = it->second;
  p.health = msg;
  if (p.health.last_error.size() > options_.max_error_bytes)
    p.health.last_error.resize(options_.max_error_bytes);
  if (p.health.consistency.size() > options_.max_error_bytes)
    p.health.consistency.resize(options_.max_error_bytes);
  if (p.health.version.size() > options_.max_error_bytes)
    p.health.version.resize(options_.max_error_bytes);
  p.host_utime = host_utime;
}

void ViewModel::on_altitude(const altitude_t& msg, utime_t host_utime) {
  ++stats_.altitudes_in;
  if (msg.tag_id.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  auto it = heights_.find(msg.tag_id);
  if (it == heights_.end()) {
    if (!make_room(
            heights_, options_.max_tags, host_utime, options_.expire_s,
            [](const TagHeight& h) { return h.host_utime; }, stats_.expired)) {
      ++stats_.dropped_too_many_tags;
      return;
    }
    it = heights_.emplace(msg.tag_id, TagHeight{}).first;
  }
  TagHeight& h = it->second;
  h.height_m = msg.height_m;
  h.floor = msg.floor_valid && !msg.relative ? msg.floor : kNoFloor;
  h.relative = msg.relative;
  h.host_utime = host_utime;
}

void ViewModel::on_zone_event(const zone_event_t& msg, utime_t host_utime) {
  (void)host_utime;
  ++stats_.zone_events_in;
  if (msg.tag_id.size() > options_.max_id_bytes || msg.zone_id.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  if (options_.max_zone_events == 0) return;
  zone_event_t e = msg;
  e.zone_name = cut(e.zone_name, options_.max_id_bytes);
  e.source = cut(e.source, options_.max_id_bytes);
  e.pose_channel = cut(e.pose_channel, options_.max_id_bytes);
  if (zone_events_.size() < options_.max_zone_events) {
    zone_events_.push_back(std::move(e));
  } else {
    zone_events_[zone_next_] = std::move(e);
    zone_next_ = (zone_next_ + 1) % zone_events_.size();
  }
}

void ViewModel::on_alert(const alert_t& msg, utime_t host_utime) {
  ++stats_.alerts_in;
  if (msg.source.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  const std::pair<std::string, int64_t> k{msg.source, msg.id};
  auto it = alerts_.find(k);
  if (it == alerts_.end()) {
    if (alerts_.size() >= options_.max_alerts) {
      // The oldest ended alert gives way; with every one still raised, the new one is dropped.
      auto oldest = alerts_.end();
      for (auto a = alerts_.begin(); a != alerts_.end(); ++a)
        if (a->second.cleared_utime != 0 &&
            (oldest == alerts_.end() || a->second.host_utime < oldest->second.host_utime))
          oldest = a;
      if (oldest == alerts_.end()) {
        ++stats_.dropped_too_many_alerts;
        return;
      }
      alerts_.erase(oldest);
      ++stats_.expired;
    }
    it = alerts_.emplace(k, AlertRow{}).first;
    it->second.raised_utime = msg.utime;
  }
  AlertRow& a = it->second;
  a.last = msg;
  a.last.subject = cut(a.last.subject, options_.max_id_bytes);
  a.last.text = cut(a.last.text, options_.max_error_bytes);
  a.host_utime = host_utime;
  if (msg.state == alert_t::STATE_CLEARED) {
    a.cleared_utime = msg.utime != 0 ? msg.utime : 1;
  } else {
    if (a.cleared_utime != 0) a.acked = false;  // raised again
    a.cleared_utime = 0;
    if (a.raised_utime == 0) a.raised_utime = msg.utime;
  }
}

bool ViewModel::ack_alert(const std::string& source, int64_t id) {
  auto it = alerts_.find({source, id});
  if (it == alerts_.end()) return false;
  it->second.acked = true;
  return true;
}

int ViewModel::track_floor(const Track& t) const {
  if (auto it = heights_.find(t.tag); it != heights_.end() && it->second.floor != kNoFloor)
    return it->second.floor;
  if (layout_.floors.empty() || !std::isfinite(t.position.z())) return kNoFloor;
  return layout_.floor_of_height(t.position.z());
}

void ViewModel::on_bytes(const std::string& channel, size_t bytes, utime_t host_utime) {
  ++stats_.bytes_messages_in;
  if (channel.size() > options_.max_id_bytes) {
    ++stats_.dropped_long_ids;
    return;
  }
  auto it = channels_.find(channel);
  if (it == channels_.end()) {
    if (!make_room(
            channels_, options_.max_channels, host_utime, options_.expire_s,
            [](const ChannelMeter& m) { return m.last_host_utime; }, stats_.expired)) {
      ++stats_.dropped_too_many_channels;
      return;
    }
    it = channels_.emplace(channel, ChannelMeter{}).first;
    it->second.ring.resize(std::max<size_t>(1, options_.rate_samples));
  }
  ChannelMeter& m = it->second;
  m.ring[m.next] = {host_utime, bytes};
  m.next = (m.next + 1) % m.ring.size();
  m.size = std::min(m.size + 1, m.ring.size());
  ++m.count;
  m.bytes += static_cast<int64_t>(bytes);
  m.last_host_utime = host_utime;
}

ChannelRow ViewModel::row(const std::string& channel, const ChannelMeter& m, utime_t now) const {
  ChannelRow r;
  r.channel = channel;
  r.count = m.count;
  r.bytes = m.bytes;
  r.age_s = seconds_between(now, m.last_host_utime);
  utime_t since = 0;
  if (__builtin_sub_overflow(now, s_to_utime(options_.rate_window_s), &since))
    since = std::numeric_limits<utime_t>::min();
  utime_t first = std::numeric_limits<utime_t>::max(), last = std::numeric_limits<utime_t>::min();
  size_t k = 0;
  double bytes = 0;
  // The ring's first `size` slots are the remembered arrivals (in ring order, which does not
  // matter here).
  for (size_t i = 0; i < m.size; ++i) {
    const Arrival& a = m.ring[i];
    if (a.host_utime <= since) continue;
    ++k;
    bytes += static_cast<double>(a.bytes);
    first = std::min(first, a.host_utime);
    last = std::max(last, a.host_utime);
  }
  const double window_s = options_.rate_window_s;
  if (k == 0) return r;
  const double span_s = seconds_between(last, first);
  // k arrivals are k - 1 intervals; a burst within one microsecond falls back to k per window.
  r.rate_hz = k >= 2 && span_s > 0 ? static_cast<double>(k - 1) / span_s
                                   : static_cast<double>(k) / window_s;
  r.bytes_per_s = r.rate_hz * bytes / static_cast<double>(k);
  return r;
}

std::vector<ChannelRow> ViewModel::channel_table(utime_t now) const {
  std::vector<ChannelRow> rows;
  rows.reserve(channels_.size());
  for (const auto& [name, m] : channels_) rows.push_back(row(name, m, now));
  return rows;
}

std::vector<std::string> ViewModel::pose_channels() const {
  std::vector<std::string> out;
  for (const auto& [k, t] : tracks_)
    if (out.empty() || out.back() != k.first) out.push_back(k.first);
  return out;
}

std::string ViewModel::json(utime_t now, bool with_trails, bool brief) const {
  const auto age = [&](utime_t t) { return json_number(seconds_between(now, t)); };
  std::string s;
  s.reserve(4096 + tracks_.size() * (256 + (with_trails ? 40 * options_.trail_length : 0)));
  s += '{';
  key(s, "now_utime");
  s += std::to_string(now);

  s += ',';
  key(s, "site");
  if (has_site_) {
    s += '{';
    key(s, "name");
    s += json_string(site_name_) + ',';
    key(s, "source");
    s += json_string(site_source_) + ',';
    key(s, "age_s");
    s += age(site_host_utime_) + ',';
    key(s, "version");
    s += std::to_string(site_version_) + '}';
  } else {
    s += "null";
  }
  s += ',';
  key(s, "site_error");
  s += json_string(last_site_error_);

  s += ',';
  key(s, "anchors");
  append_anchors(s, anchors_);

  const auto colours = channel_colours(pose_channels());
  s += ',';
  key(s, "tracks");
  s += '[';
  bool first = true;
  for (const auto& [k, t] : tracks_) {
    if (!first) s += ',';
    first = false;
    s += '{';
    key(s, "channel");
    s += json_string(t.channel) + ',';
    key(s, "tag");
    s += json_string(t.tag) + ',';
    key(s, "source");
    s += json_string(t.source) + ',';
    key(s, "colour");
    s += json_string(colours.at(t.channel)) + ',';
    if (!brief) {
      key(s, "utime");
      s += std::to_string(t.utime) + ',';
    }
    key(s, "age_s");
    s += age(t.host_utime) + ',';
    key(s, "position");
    s += '[' + json_number(t.position.x()) + ',' + json_number(t.position.y()) + ',' +
         json_number(t.position.z()) + "],";
    if (!brief) {
      key(s, "cov_xy");
      s += "[[" + json_number(t.cov_xy(0, 0)) + ',' + json_number(t.cov_xy(0, 1)) + "],[" +
           json_number(t.cov_xy(1, 0)) + ',' + json_number(t.cov_xy(1, 1)) + "]],";
    }
    key(s, "ellipse_2sigma");
    if (const auto e = covariance_ellipse(t.cov_xy, 2.0))
      s += "{\"semi_major_m\":" + json_number(e->semi_major_m) +
           ",\"semi_minor_m\":" + json_number(e->semi_minor_m) +
           ",\"angle_deg\":" + json_number(e->angle_rad * kRadToDeg) + "},";
    else
      s += "null,";
    if (!brief) {
      key(s, "heading_rad");
      s += json_number(t.heading_rad) + ',';
      key(s, "status");
      s += std::to_string(t.status) + ',';
    }
    key(s, "floor");
    const int floor = track_floor(t);
    s += (floor == kNoFloor ? std::string("null") : std::to_string(floor)) + ',';
    key(s, "flags");
    s += '[';
    const auto names = status_names(t.status);
    for (size_t i = 0; i < names.size(); ++i) s += (i ? ",\"" : "\"") + names[i] + '"';
    s += "],";
    key(s, "count");
    s += std::to_string(t.count);
    if (!brief) {
      s += ',';
      key(s, "non_finite");
      s += std::to_string(t.non_finite);
    }
    if (with_trails) {
      s += ',';
      key(s, "trail");
      s += '[';
      const auto pts = t.trail.points();
      for (size_t i = 0; i < pts.size(); ++i)
        s += (i ? ",[" : "[") + json_number(pts[i].x()) + ',' + json_number(pts[i].y()) + ']';
      s += ']';
    }
    s += '}';
  }
  s += ']';

  s += ',';
  key(s, "channels");
  s += '[';
  first = true;
  for (const auto& [name, m] : channels_) {
    const ChannelRow r = row(name, m, now);
    if (!first) s += ',';
    first = false;
    s += '{';
    key(s, "channel");
    s += json_string(r.channel) + ',';
    key(s, "count");
    s += std::to_string(r.count) + ',';
    key(s, "rate_hz");
    s += json_number(r.rate_hz) + ',';
    key(s, "age_s");
    s += json_number(r.age_s) + ',';
    key(s, "bytes_per_s");
    s += json_number(r.bytes_per_s) + ',';
    key(s, "bytes");
    s += std::to_string(r.bytes) + '}';
  }
  s += ']';

  s += ',';
  key(s, "processes");
  s += '[';
  first = true;
  for (const auto& [k, p] : processes_) {
    const health_t& h = p.health;
    if (!first) s += ',';
    first = false;
    s += '{';
    key(s, "source");
    s += json_string(h.source) + ',';
    key(s, "host");
    s += json_string(h.host) + ',';
    key(s, "pid");
    s += std::to_string(h.pid) + ',';
    key(s, "state");
    s += json_string(health_state_name(h.state)) + ',';
    key(s, "state_code");
    s += std::to_string(h.state) + ',';
    key(s, "msgs_in");
    s += std::to_string(h.msgs_in) + ',';
    key(s, "msgs_out");
    s += std::to_string(h.msgs_out) + ',';
    key(s, "parse_errors");
    s += std::to_string(h.parse_errors) + ',';
    key(s, "drops");
    s += std::to_string(h.drops) + ',';
    key(s, "kernel_drops");
    s += std::to_string(h.kernel_drops) + ',';
    key(s, "queue_drops");
    s += std::to_string(h.queue_drops) + ',';
    key(s, "seq_lost");
    s += std::to_string(h.seq_lost) + ',';
    key(s, "recv_buf_bytes");
    s += std::to_string(h.recv_buf_bytes) + ',';
    key(s, "last_error");
    s += json_string(h.last_error) + ',';
    key(s, "consistency");
    s += json_string(h.consistency) + ',';
    key(s, "version");
    s += json_string(h.version) + ',';
    key(s, "uptime_s");
    s += json_number(utime_to_s(h.uptime_us)) + ',';
    key(s, "age_s");
    s += age(p.host_utime) + '}';
  }
  s += ']';

  s += ',';
  key(s, "heights");
  s += '[';
  first = true;
  for (const auto& [tag, h] : heights_) {
    if (!first) s += ',';
    first = false;
    s += '{';
    key(s, "tag");
    s += json_string(tag) + ',';
    key(s, "height_m");
    s += json_number(h.height_m) + ',';
    key(s, "floor");
    s += (h.floor == kNoFloor ? std::string("null") : std::to_string(h.floor)) + ',';
    key(s, "relative");
    s += h.relative ? "true," : "false,";
    key(s, "age_s");
    s += age(h.host_utime) + '}';
  }
  s += ']';

  // Newest first.
  s += ',';
  key(s, "zone_events");
  s += '[';
  for (size_t i = 0; i < zone_events_.size(); ++i) {
    const size_t n = zone_events_.size();
    const zone_event_t& e = zone_events_[(zone_next_ + n - 1 - i) % n];
    if (i) s += ',';
    s += '{';
    key(s, "utime");
    s += std::to_string(e.utime) + ',';
    key(s, "source");
    s += json_string(e.source) + ',';
    key(s, "tag");
    s += json_string(e.tag_id) + ',';
    key(s, "zone");
    s += json_string(e.zone_id) + ',';
    key(s, "zone_name");
    s += json_string(e.zone_name) + ',';
    key(s, "floor");
    s += (e.floor == zone_event_t::FLOOR_ANY ? std::string("null") : std::to_string(e.floor)) +
         ',';
    key(s, "event");
    s += std::string("\"") + name_or_unknown(zone_event_name(e.event)) + "\",";
    key(s, "dwell_s");
    s += json_number(e.dwell_s) + ',';
    key(s, "position");
    s += '[' + json_number(e.position[0]) + ',' + json_number(e.position[1]) + ',' +
         json_number(e.position[2]) + "],";
    key(s, "alert");
    s += e.alert ? "true}" : "false}";
  }
  s += ']';

  // Raised ones first, newest first within each.
  std::vector<const AlertRow*> alerts;
  for (const auto& [k, a] : alerts_) alerts.push_back(&a);
  std::stable_sort(alerts.begin(), alerts.end(), [](const AlertRow* a, const AlertRow* b) {
    const bool ra = a->cleared_utime == 0, rb = b->cleared_utime == 0;
    if (ra != rb) return ra;
    return a->raised_utime > b->raised_utime;
  });
  s += ',';
  key(s, "alerts");
  s += '[';
  for (size_t i = 0; i < alerts.size(); ++i) {
    const AlertRow& a = *alerts[i];
    if (i) s += ',';
    s += '{';
    key(s, "source");
    s += json_string(a.last.source) + ',';
    key(s, "id");
    s += std::to_string(a.last.id) + ',';
    key(s, "kind");
    s += std::string("\"") + name_or_unknown(alert_kind_name(a.last.kind)) + "\",";
    key(s, "severity");
    s += std::string("\"") + name_or_unknown(alert_severity_name(a.last.severity)) + "\",";
    key(s, "raised");
    s += a.cleared_utime == 0 ? "true," : "false,";
    key(s, "raised_utime");
    s += std::to_string(a.raised_utime) + ',';
    key(s, "cleared_utime");
    s += (a.cleared_utime == 0 ? std::string("null") : std::to_string(a.cleared_utime)) + ',';
    key(s, "acked");
    s += a.acked ? "true," : "false,";
    key(s, "subject");
    s += json_string(a.last.subject) + ',';
    key(s, "text");
    s += json_string(a.last.text) + '}';
  }
  s += ']';

  s += ',';
  key(s, "stats");
  s += '{';
  const std::pair<const char*, int64_t> counters[] = {
      {"sites_in", stats_.sites_in},
      {"bad_sites", stats_.bad_sites},
      {"poses_in", stats_.poses_in},
      {"non_finite_positions", stats_.non_finite_positions},
      {"health_in", stats_.health_in},
      {"altitudes_in", stats_.altitudes_in},
      {"zone_events_in", stats_.zone_events_in},
      {"alerts_in", stats_.alerts_in},
      {"bytes_messages_in", stats_.bytes_messages_in},
      {"dropped_long_ids", stats_.dropped_long_ids},
      {"dropped_too_many_tracks", stats_.dropped_too_many_tracks},
      {"dropped_too_many_channels", stats_.dropped_too_many_channels},
      {"dropped_too_many_processes", stats_.dropped_too_many_processes},
      {"dropped_too_many_alerts", stats_.dropped_too_many_alerts},
      {"dropped_too_many_tags", stats_.dropped_too_many_tags},
      {"expired", stats_.expired},
  };
  first = true;
  for (const auto& [name, value] : counters) {
    if (!first) s += ',';
    first = false;
    key(s, name);
    s += std::to_string(value);
  }
  s += "}}";
  return s;
}

std::string ViewModel::site_json() const {
  std::string s = "{";
  key(s, "version");
  s += std::to_string(site_version_) + ',';
  key(s, "name");
  s += (has_site_ ? json_string(site_name_) : std::string("null")) + ',';
  key(s, "anchors");
  append_anchors(s, anchors_);
  s += ',';
  key(s, "floors");
  s += '[';
  for (size_t i = 0; i < layout_.floors.size(); ++i) {
    const Floor& f = layout_.floors[i];
    if (i) s += ',';
    s += '{';
    key(s, "index");
    s += std::to_string(f.index) + ',';
    key(s, "name");
    s += json_string(f.name) + ',';
    key(s, "height_m");
    s += json_number(f.height_m) + ',';
    key(s, "plan");
    if (f.plan && !f.plan->data_uri.empty()) {
      s += '{';
      key(s, "image");
      s += json_string(f.plan->image) + ',';
      key(s, "uri");
      s += json_string(f.plan->data_uri) + ',';
      key(s, "origin");
      s += xy_json(f.plan->origin) + ',';
      key(s, "size_m");
      s += xy_json(f.plan->size_m) + ',';
      key(s, "rotation_deg");
      s += json_number(f.plan->rotation_rad * kRadToDeg) + '}';
    } else {
      s += "null";
    }
    s += '}';
  }
  s += "],";
  key(s, "zones");
  s += '[';
  for (size_t i = 0; i < layout_.zones.size(); ++i) {
    const Zone& z = layout_.zones[i];
    if (i) s += ',';
    s += '{';
    key(s, "id");
    s += json_string(z.id) + ',';
    key(s, "name");
    s += json_string(z.name) + ',';
    key(s, "floor");
    s += (z.floor ? std::to_string(*z.floor) : std::string("null")) + ',';
    key(s, "alert");
    s += std::string("{\"enter\":") + (z.alert.enter ? "true" : "false") +
         ",\"leave\":" + (z.alert.leave ? "true" : "false") +
         ",\"dwell\":" + (z.alert.dwell ? "true" : "false") + "},";
    key(s, "polygon");
    s += '[';
    for (size_t k = 0; k < z.polygon.size(); ++k) s += (k ? "," : "") + xy_json(z.polygon[k]);
    s += "]}";
  }
  s += "]}";
  return s;
}

}  // namespace ips::view
