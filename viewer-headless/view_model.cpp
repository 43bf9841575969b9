#include "viewer-headless/view_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <numbers>
#include <set>

#include "core/channels.hpp"

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

}  // namespace

void Trail::push(const Eigen::Vector2d& p) {
  if (ring_.empty()) return;
  ring_[next_] = p;
  next_ = (next_ + 1) % ring_.size();
  size_ = std::min(size_ + 1, ring_.size());
}

std::vector<Eigen::Vector2d> Trail::points() const {
  std::vector<Eigen::Vector2d> out;
  out.reserve(size_);
  const size_t cap = ring_.size();
  for (size_t i = 0; i < size_; ++i) out.push_back(ring_[(next_ + cap - size_ + i) % cap]);
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

std::map<std::string, std::string> channel_colours(const std::vector<std::string>& channels) {
  // Tableau 10 for the default channel names, so a channel keeps its colour as others come and
  // go; the lighter Tableau 20 half for any other name.
  static const std::map<std::string, std::string> kFixed = {
      {channel::kTruth, "#000000"},         {channel::kPoseUwb, "#1f77b4"},
      {channel::kPoseTdoa, "#ff7f0e"},      {channel::kPoseAoa, "#2ca02c"},
      {channel::kPoseFused, "#d62728"},     {channel::kPoseIns, "#9467bd"},
      {channel::kPosePdr, "#8c564b"},       {channel::kInsModule, "#17becf"},
      {channel::kPoseUwbModule, "#bcbd22"},
  };
  static constexpr const char* kOthers[] = {"#7f7f7f", "#e377c2", "#aec7e8", "#ffbb78",
                                            "#98df8a", "#ff9896", "#c5b0d5", "#c49c94",
                                            "#f7b6d2", "#dbdb8d", "#9edae5"};
  constexpr size_t kOthersSize = sizeof kOthers / sizeof kOthers[0];
  std::map<std::string, std::string> colours;
  const std::set<std::string> sorted(channels.begin(), channels.end());
  size_t other = 0;
  for (const auto& c : sorted) {
    const auto it = kFixed.find(c);
    colours[c] = it != kFixed.end() ? it->second : kOthers[other++ % kOthersSize];
  }
  return colours;
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
    it->second.trail = Trail(options_.trail_length);
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
  t.trail.push(t.position.head<2>());
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

std::string ViewModel::json(utime_t now, bool with_trails) const {
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
    s += age(site_host_utime_) + '}';
  } else {
    s += "null";
  }
  s += ',';
  key(s, "site_error");
  s += json_string(last_site_error_);

  s += ',';
  key(s, "anchors");
  s += '[';
  for (size_t i = 0; i < anchors_.size(); ++i) {
    const Anchor& a = anchors_[i];
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
    key(s, "utime");
    s += std::to_string(t.utime) + ',';
    key(s, "age_s");
    s += age(t.host_utime) + ',';
    key(s, "position");
    s += '[' + json_number(t.position.x()) + ',' + json_number(t.position.y()) + ',' +
         json_number(t.position.z()) + "],";
    key(s, "cov_xy");
    s += "[[" + json_number(t.cov_xy(0, 0)) + ',' + json_number(t.cov_xy(0, 1)) + "],[" +
         json_number(t.cov_xy(1, 0)) + ',' + json_number(t.cov_xy(1, 1)) + "]],";
    key(s, "ellipse_2sigma");
    if (const auto e = covariance_ellipse(t.cov_xy, 2.0))
      s += "{\"semi_major_m\":" + json_number(e->semi_major_m) +
           ",\"semi_minor_m\":" + json_number(e->semi_minor_m) +
           ",\"angle_deg\":" + json_number(e->angle_rad * kRadToDeg) + "},";
    else
      s += "null,";
    key(s, "heading_rad");
    s += json_number(t.heading_rad) + ',';
    key(s, "status");
    s += std::to_string(t.status) + ',';
    key(s, "flags");
    s += '[';
    const auto names = status_names(t.status);
    for (size_t i = 0; i < names.size(); ++i) s += (i ? ",\"" : "\"") + names[i] + '"';
    s += "],";
    key(s, "count");
    s += std::to_string(t.count) + ',';
    key(s, "non_finite");
    s += std::to_string(t.non_finite);
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
  key(s, "stats");
  s += '{';
  const std::pair<const char*, int64_t> counters[] = {
      {"sites_in", stats_.sites_in},
      {"bad_sites", stats_.bad_sites},
      {"poses_in", stats_.poses_in},
      {"non_finite_positions", stats_.non_finite_positions},
      {"health_in", stats_.health_in},
      {"bytes_messages_in", stats_.bytes_messages_in},
      {"dropped_long_ids", stats_.dropped_long_ids},
      {"dropped_too_many_tracks", stats_.dropped_too_many_tracks},
      {"dropped_too_many_channels", stats_.dropped_too_many_channels},
      {"dropped_too_many_processes", stats_.dropped_too_many_processes},
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

}  // namespace ips::view
