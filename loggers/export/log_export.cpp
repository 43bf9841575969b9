#include "loggers/export/log_export.hpp"

#include "core/text_escape.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <ips/altitude_t.hpp>
#include <ips/anchor_t.hpp>
#include <ips/baro_station_t.hpp>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/clock_t.hpp>
#include <ips/health_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/step_t.hpp>
#include <ips/tag_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <ips/uwb_twr_timestamps_t.hpp>
#include <utility>

#include "core/node.hpp"

namespace ips::log_export {
namespace {

// A message's fields in CSV order: column name (with unit) and value.
using Fields = std::vector<std::pair<const char*, Cell>>;

void add3(Fields& f, const char* x, const char* y, const char* z, const double (&v)[3]) {
  f.emplace_back(x, v[0]);
  f.emplace_back(y, v[1]);
  f.emplace_back(z, v[2]);
}

// One function per type: the only place that lists its fields, so header and rows cannot drift.
void fields(const uwb_range_t& m, Fields& f) {
  f = {{"utime_us", m.utime},       {"source", m.source},
       {"tag_id", m.tag_id},        {"anchor_id", m.anchor_id},
       {"range_m", m.range_m},      {"rx_power_dbm", m.rx_power_dbm},
       {"fp_power_dbm", m.fp_power_dbm}, {"quality", m.quality},
       {"seq", int64_t{m.seq}}};
}

// The stamps under their names (0 past n_stamps), in ticks of tick_s.
void fields(const uwb_twr_timestamps_t& m, Fields& f) {
  f = {{"utime_us", m.utime},
       {"source", m.source},
       {"tag_id", m.tag_id},
       {"anchor_id", m.anchor_id},
       {"seq", int64_t{m.seq}},
       {"tick_s", m.tick_s},
       {"counter_bits", int64_t{m.counter_bits}},
       {"n_stamps", int64_t{m.n_stamps}},
       {"poll_tx", m.stamps[0]},
       {"poll_rx", m.stamps[1]},
       {"resp_tx", m.stamps[2]},
       {"resp_rx", m.stamps[3]},
       {"final_tx", m.stamps[4]},
       {"final_rx", m.stamps[5]},
       {"clock_offset_ppm", m.clock_offset_ppm},
       {"range_m", m.range_m},
       {"reported_range_m", m.reported_range_m}};
}

void fields(const uwb_rx_t& m, Fields& f) {
  f = {{"utime_us", m.utime},         {"source", m.source},
       {"anchor_id", m.anchor_id},    {"sender_id", m.sender_id},
       {"is_sync", m.is_sync != 0},        {"seq", int64_t{m.seq}},
       {"rx_counter", m.rx_counter},  {"counter_hz", m.counter_hz},
       {"rx_power_dbm", m.rx_power_dbm}, {"fp_power_dbm", m.fp_power_dbm},
       {"quality", m.quality}};
}

void fields(const ble_aoa_t& m, Fields& f) {
  f = {{"utime_us", m.utime},
       {"source", m.source},
       {"anchor_id", m.anchor_id},
       {"tag_id", m.tag_id},
       {"azimuth_deg", m.azimuth_deg},
       {"elevation_deg", m.elevation_deg},
       {"rssi_dbm", m.rssi_dbm},
       {"ble_channel", int64_t{m.channel}},
       {"anchor_uptime_ms", m.anchor_uptime_ms},
       {"seq", int64_t{m.seq}},
       {"user_string", m.user_string}};
}

void fields(const imu_t& m, Fields& f) {
  f = {{"utime_us", m.utime},
       {"source", m.source},
       {"device_id", m.device_id},
       {"device_utime_us", m.device_utime}};
  add3(f, "accel_x_mps2", "accel_y_mps2", "accel_z_mps2", m.accel);
  add3(f, "gyro_x_radps", "gyro_y_radps", "gyro_z_radps", m.gyro);
  add3(f, "mag_x_ut", "mag_y_ut", "mag_z_ut", m.mag_ut);
}

void fields(const baro_t& m, Fields& f) {
  f = {{"utime_us", m.utime},           {"source", m.source},
       {"sensor_id", m.sensor_id},      {"pressure_pa", m.pressure_pa},
       {"temperature_c", m.temperature_c}, {"humidity_pct", m.humidity_pct},
       {"is_reference", m.is_reference != 0}, {"known_height_m", m.known_height_m}};
}

void fields(const pose_t& m, Fields& f) {
  f = {{"utime_us", m.utime}, {"source", m.source}, {"tag_id", m.tag_id}};
  add3(f, "position_x_m", "position_y_m", "position_z_m", m.position);
  static const char* const kCov[9] = {"position_cov_xx_m2", "position_cov_xy_m2",
                                      "position_cov_xz_m2", "position_cov_yx_m2",
                                      "position_cov_yy_m2", "position_cov_yz_m2",
                                      "position_cov_zx_m2", "position_cov_zy_m2",
                                      "position_cov_zz_m2"};
  for (int i = 0; i < 9; ++i) f.emplace_back(kCov[i], m.position_cov[i]);
  add3(f, "velocity_x_mps", "velocity_y_mps", "velocity_z_mps", m.velocity);
  f.emplace_back("heading_rad", m.heading_rad);
  f.emplace_back("num_used", int64_t{m.num_used});
  f.emplace_back("residual_m", m.residual_m);
  f.emplace_back("status", int64_t{m.status});
}

void fields(const step_t& m, Fields& f) {
  f = {{"utime_us", m.utime},         {"source", m.source},
       {"tag_id", m.tag_id},          {"index", int64_t{m.index}},
       {"length_m", m.length_m},      {"heading_rad", m.heading_rad},
       {"cadence_hz", m.cadence_hz},  {"heading_known", m.heading_known != 0}};
}

void fields(const altitude_t& m, Fields& f) {
  f = {{"utime_us", m.utime},
       {"source", m.source},
       {"tag_id", m.tag_id},
       {"height_m", m.height_m},
       {"height_std_m", m.height_std_m},
       {"vertical_speed_mps", m.vertical_speed_mps},
       {"floor", int64_t{m.floor}},
       {"floor_valid", m.floor_valid != 0},
       {"relative", m.relative != 0}};
}

void fields(const clock_t& m, Fields& f) {
  f = {{"utime_us", m.utime},         {"source", m.source},
       {"anchor_id", m.anchor_id},    {"master_id", m.master_id},
       {"offset_s", m.offset_s},      {"offset_std_s", m.offset_std_s},
       {"rate_ppb", m.rate_ppb},      {"rate_std_ppb", m.rate_std_ppb},
       {"num_syncs", int64_t{m.num_syncs}}, {"status", int64_t{m.status}}};
}

void fields(const health_t& m, Fields& f) {
  f = {{"utime_us", m.utime},
       {"source", m.source},
       {"host", m.host},
       {"pid", int64_t{m.pid}},
       {"state", int64_t{m.state}},
       {"msgs_in", m.msgs_in},
       {"msgs_out", m.msgs_out},
       {"parse_errors", m.parse_errors},
       {"drops", m.drops},
       {"last_error", m.last_error},
       {"uptime_us", m.uptime_us},
       {"kernel_drops", m.kernel_drops},
       {"queue_drops", m.queue_drops},
       {"seq_lost", m.seq_lost},
       {"recv_buf_bytes", int64_t{m.recv_buf_bytes}},
       {"consistency", m.consistency},
       {"version", m.version},
       {"note", m.note}};
}

// The parts of site_t, should one ever be published on its own.
void fields(const anchor_t& m, Fields& f) {
  f = {{"id", m.id}, {"kind", m.kind}};
  add3(f, "position_x_m", "position_y_m", "position_z_m", m.position);
  add3(f, "orientation_roll_rad", "orientation_pitch_rad", "orientation_yaw_rad",
       m.orientation_rad);
  f.emplace_back("enabled", m.enabled != 0);
}

void fields(const baro_station_t& m, Fields& f) {
  f = {{"id", m.id}};
  add3(f, "position_x_m", "position_y_m", "position_z_m", m.position);
}

void fields(const tag_t& m, Fields& f) { f = {{"id", m.id}, {"height_m", m.height_m}}; }

void append_json_value(std::string& out, const Cell& c) {
  std::visit(
      [&out](const auto& v) {
        using T = std::decay_t<decltype(v)>;
        if constexpr (std::is_same_v<T, std::string>) {
          out += json_quote(v);
        } else if constexpr (std::is_same_v<T, bool>) {
          out += v ? "true" : "false";
        } else if constexpr (std::is_same_v<T, int64_t>) {
          out += std::to_string(v);
        } else {
          out += std::isfinite(v) ? format_number(v) : "null";
        }
      },
      c);
}

std::string json_object(const Fields& f) {
  std::string out = "{";
  for (size_t i = 0; i < f.size(); ++i) {
    if (i) out += ", ";
    out += '"';
    out += f[i].first;
    out += "\": ";
    append_json_value(out, f[i].second);
  }
  return out + "}";
}

template <class Msg>
std::optional<Decoded> try_flat(const void* data, size_t size, const char* type) {
  Msg m;
  if (!decode_message(m, data, size)) return std::nullopt;
  Fields f;
  fields(m, f);
  static const std::vector<std::string> columns = [&f] {
    std::vector<std::string> c;
    for (const auto& [name, value] : f) c.emplace_back(name);
    return c;
  }();
  Decoded d;
  d.type = type;
  d.columns = &columns;
  d.json = json_object(f);
  d.rows.emplace_back();
  d.rows.back().reserve(f.size());
  for (auto& [name, value] : f) d.rows.back().push_back(std::move(value));
  return d;
}

// site_t: one CSV row per element so that the table is rectangular; a column that does not
// apply to an element (a tag's position) is NaN or empty. The YAML goes to JSON only: a
// multi-line quoted field in every row would defeat line-based tools.
const std::vector<std::string>& site_columns() {
  static const std::vector<std::string> c = {
      "utime_us",           "source",        "site_name",           "element",
      "id",                 "kind",          "position_x_m",        "position_y_m",
      "position_z_m",       "orientation_roll_rad", "orientation_pitch_rad",
      "orientation_yaw_rad", "enabled",      "height_m"};
  return c;
}

std::optional<Decoded> try_site(const void* data, size_t size) {
  site_t m;
  if (!decode_message(m, data, size)) return std::nullopt;
  Decoded d;
  d.type = "site_t";
  d.columns = &site_columns();
  const double nan = std::nan("");
  auto row = [&](const char* element, const std::string& id, const std::string& kind,
                 const double* pos, const double* orient, bool enabled, double height) {
    d.rows.push_back({m.utime, m.source, m.name, std::string(element), id, kind,
                      pos ? pos[0] : nan, pos ? pos[1] : nan, pos ? pos[2] : nan,
                      orient ? orient[0] : nan, orient ? orient[1] : nan,
                      orient ? orient[2] : nan, enabled, height});
  };
  for (const auto& a : m.anchors)
    row("anchor", a.id, a.kind, a.position, a.orientation_rad, a.enabled, nan);
  for (const auto& b : m.baro_stations) row("baro_station", b.id, "", b.position, nullptr, true, nan);
  for (const auto& t : m.tags) row("tag", t.id, "", nullptr, nullptr, true, t.height_m);
  if (d.rows.empty()) row("", "", "", nullptr, nullptr, false, nan);  // still one row per message

  std::string& j = d.json;
  j = "{\"utime_us\": " + std::to_string(m.utime) + ", \"source\": " + json_quote(m.source) +
      ", \"site_name\": " + json_quote(m.name) + ", \"anchors\": [";
  Fields f;
  for (size_t i = 0; i < m.anchors.size(); ++i) {
    fields(m.anchors[i], f);
    j += (i ? ", " : "") + json_object(f);
  }
  j += "], \"baro_stations\": [";
  for (size_t i = 0; i < m.baro_stations.size(); ++i) {
    fields(m.baro_stations[i], f);
    j += (i ? ", " : "") + json_object(f);
  }
  j += "], \"tags\": [";
  for (size_t i = 0; i < m.tags.size(); ++i) {
    fields(m.tags[i], f);
    j += (i ? ", " : "") + json_object(f);
  }
  j += "], \"site_yaml\": " + json_quote(m.site_yaml) + "}";
  return d;
}

template <class T>
std::string shortest(T v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "Inf" : "-Inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

}  // namespace

std::optional<Decoded> decode_any(const void* data, size_t size) {
  // Most frequent types first; a fingerprint mismatch costs one 8-byte compare.
  if (auto d = try_flat<uwb_range_t>(data, size, "uwb_range_t")) return d;
  if (auto d = try_flat<pose_t>(data, size, "pose_t")) return d;
  if (auto d = try_flat<imu_t>(data, size, "imu_t")) return d;
  if (auto d = try_flat<uwb_rx_t>(data, size, "uwb_rx_t")) return d;
  if (auto d = try_flat<uwb_twr_timestamps_t>(data, size, "uwb_twr_timestamps_t")) return d;
  if (auto d = try_flat<ble_aoa_t>(data, size, "ble_aoa_t")) return d;
  if (auto d = try_flat<baro_t>(data, size, "baro_t")) return d;
  if (auto d = try_flat<step_t>(data, size, "step_t")) return d;
  if (auto d = try_flat<altitude_t>(data, size, "altitude_t")) return d;
  if (auto d = try_flat<clock_t>(data, size, "clock_t")) return d;
  if (auto d = try_flat<health_t>(data, size, "health_t")) return d;
  if (auto d = try_site(data, size)) return d;
  if (auto d = try_flat<anchor_t>(data, size, "anchor_t")) return d;
  if (auto d = try_flat<baro_station_t>(data, size, "baro_station_t")) return d;
  if (auto d = try_flat<tag_t>(data, size, "tag_t")) return d;
  return std::nullopt;
}

std::vector<std::string> known_types() {
  return {"altitude_t", "anchor_t", "baro_station_t", "baro_t",  "ble_aoa_t",   "clock_t",
          "health_t",   "imu_t",    "pose_t",         "site_t",  "step_t",      "tag_t",
          "uwb_range_t", "uwb_rx_t",  "uwb_twr_timestamps_t"};
}

std::string format_number(double v) { return shortest(v); }
std::string format_number(float v) { return shortest(v); }

std::string csv_quote(std::string_view s) {
  if (s.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(s);
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}


std::string csv_line(const std::vector<std::string>& columns) {
  std::string out;
  for (size_t i = 0; i < columns.size(); ++i) {
    if (i) out += ',';
    out += csv_quote(columns[i]);
  }
  return out + "\n";
}

std::string csv_line(const std::vector<Cell>& row) {
  std::string out;
  for (size_t i = 0; i < row.size(); ++i) {
    if (i) out += ',';
    std::visit(
        [&out](const auto& v) {
          using T = std::decay_t<decltype(v)>;
          if constexpr (std::is_same_v<T, std::string>) {
            out += csv_quote(v);
          } else if constexpr (std::is_same_v<T, bool>) {
            out += v ? '1' : '0';
          } else if constexpr (std::is_same_v<T, int64_t>) {
            out += std::to_string(v);
          } else {
            out += format_number(v);
          }
        },
        row[i]);
  }
  return out + "\n";
}

std::string json_line(std::string_view channel, int64_t log_time_us, const Decoded& msg) {
  std::string out = "{\"channel\": " + json_quote(channel) +
                    ", \"log_time_us\": " + std::to_string(log_time_us) +
                    ", \"type\": " + json_quote(msg.type);
  // msg.json is "{...}": splice its fields in after ours.
  if (msg.json.size() > 2) {
    out += ", ";
    out.append(msg.json, 1, msg.json.size() - 1);
  } else {
    out += '}';
  }
  return out + "\n";
}

std::string file_stem(std::string_view channel) {
  std::string out;
  out.reserve(channel.size() + 1);
  for (char c : channel) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-' || c == '.';
    out += ok ? c : '_';
  }
  if (out.empty() || out[0] == '.') out.insert(out.begin(), '_');
  return out;
}

}  // namespace ips::log_export
