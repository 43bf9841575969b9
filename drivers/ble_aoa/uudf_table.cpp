#include "drivers/ble_aoa/uudf_table.hpp"

#include <cmath>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "drivers/ble_aoa/capture_line.hpp"

namespace ips::ble_aoa {

namespace {

// Epoch times before 2001 are not a recording's (a clock since boot, or the wrong --time-unit).
constexpr int64_t kEarliestUtime = 978'307'200'000'000;  // 2001-01-01T00:00:00Z

bool integer_field(std::string_view field, int64_t lo, int64_t hi, int64_t& out) {
  double v = 0;
  if (!table::parse_number(field, v) || v != std::floor(v) || v < static_cast<double>(lo) ||
      v > static_cast<double>(hi))
    return false;
  out = static_cast<int64_t>(v);
  return true;
}

std::string field_reason(std::string_view what, std::string_view field, std::string_view want) {
  return std::string(what) + " " + quoted_field(field) + " is not " + std::string(want);
}

}  // namespace

const std::vector<table::KnownColumn>& uudf_table_columns() {
  static const std::vector<table::KnownColumn> known = {
      {"t", "timestamp|time|t|utime|pctime|datetime"},
      {"tag", "tag|tagid|tagmac|taginstanceid|instanceid"},
      {"rssi", "rssi|1stp|rssi1|rssi1stp|rssidbm"},
      {"azimuth", "azimuth|az|azi|azimuthdeg"},
      {"elevation", "elevation|el|elev|elevationdeg"},
      {"rssi2", "2ndp|rssi2|rssi2ndp|reserved"},
      {"channel", "channel|ch|blechannel"},
      {"anchor", "anchor|anchorid|anchormac"},
      {"seq", "sequence|seq|counter|sequencenumber|eventcounter"},
      {"uptime", "uptime|uptimems|anchoruptime"},
      {"user", "user|userstring|userdefinedstring"},
      {"uudf", "uudf|data|line|event|raw"},
  };
  return known;
}

bool looks_like_capture_line(std::string_view line) {
  if (line.size() >= 3 && static_cast<unsigned char>(line[0]) == 0xEF) line.remove_prefix(3);
  const CaptureParseResult parsed = parse_capture_line(line);
  return parsed.ok && !parsed.line.payload.empty() &&
         (parsed.line.payload.front() == '+' || parsed.line.payload.substr(0, 2) == "AT" ||
          parsed.line.payload == "OK" || parsed.line.payload == "ERROR");
}

UudfTableDecoder::UudfTableDecoder(UudfTableOptions options, EventDecoderConfig base,
                                   EventDecoder::Sink sink)
    : options_(std::move(options)),
      reader_(options_.read),
      decoder_(std::move(base), std::move(sink)),
      unit_(options_.time_unit) {}

std::string UudfTableDecoder::columns() const {
  if (set_up_ && mapping_error_.empty()) return columns_.describe();
  return options_.columns.empty() ? std::string(kUudfTableDefaultColumns) : options_.columns;
}

table::ImportExpectation UudfTableDecoder::expectation(std::string input) const {
  table::ImportExpectation e;
  e.input = std::move(input);
  e.columns = columns();
  e.separator = reader_.separator_known() ? std::optional<char>(reader_.separator())
                                          : options_.read.separator;
  e.separator_given = options_.read.separator.has_value();
  return e;
}

void UudfTableDecoder::set_up_columns(const std::vector<std::string_view>& row) {
  set_up_ = true;
  const auto& known = uudf_table_columns();
  if (!options_.columns.empty()) {
    mapping_error_ = columns_.set_from_list(options_.columns, known);
    if (!mapping_error_.empty()) mapping_error_ = "--columns: " + mapping_error_;
  } else if (!reader_.header().empty()) {
    columns_.set_from_header(reader_.header_views(), known);
    if (!columns_.has("t") ||
        !(columns_.has("uudf") || (columns_.has("tag") && columns_.has("azimuth") &&
                                   columns_.has("elevation") && columns_.has("anchor")))) {
      std::string names;
      for (const std::string& h : reader_.header()) names += (names.empty() ? "" : ",") + h;
      mapping_error_ = "header '" + table::excerpt(names, 80) +
                       "' lacks a column of t, tag, azimuth, elevation, anchor (or uudf, a "
                       "+UUDF line): give --columns";
    }
  } else {
    std::string_view layout = kUudfTableDefaultColumns;
    double v = 0;
    if (row.size() == 2) {
      layout = "t,uudf";
    } else if (row.size() == 8 && table::parse_number(row[5], v) && v < 0) {
      layout = kUudfTableOlderColumns;
    }
    mapping_error_ = columns_.set_from_list(layout, known);
  }
  t_ = columns_.index("t");
  tag_ = columns_.index("tag");
  rssi_ = columns_.index("rssi");
  az_ = columns_.index("azimuth");
  el_ = columns_.index("elevation");
  rssi2_ = columns_.index("rssi2");
  channel_ = columns_.index("channel");
  anchor_ = columns_.index("anchor");
  seq_ = columns_.index("seq");
  uptime_ = columns_.index("uptime");
  user_ = columns_.index("user");
  uudf_ = columns_.index("uudf");
  if (mapping_error_.empty() &&
      (t_ < 0 || (uudf_ < 0 && (tag_ < 0 || az_ < 0 || el_ < 0 || anchor_ < 0))))
    mapping_error_ =
        "--columns '" + table::excerpt(options_.columns, 80) +
        "' needs t and either uudf or tag, azimuth, elevation and anchor";
}

std::string UudfTableDecoder::decode_row(const std::vector<std::string_view>& f) {
  if (!mapping_error_.empty()) return mapping_error_;
  if (static_cast<int>(f.size()) < columns_.needed())
    return std::to_string(f.size()) + " fields, expected at least " +
           std::to_string(columns_.needed()) + " (" + columns_.describe() + ")";
  const std::string_view time_field = f[static_cast<size_t>(t_)];
  if (!unit_) {
    double v = 0;
    if (table::parse_number(time_field, v)) {
      unit_ = table::guess_epoch_unit(v);
      if (!unit_)
        return "time " + quoted_field(time_field) +
               " is not a Unix epoch time in s, ms, us or ns (give --time-unit)";
    }
  }
  int64_t utime = 0;
  if (!table::parse_time_us(time_field, unit_.value_or(table::TimeUnit::kS), utime))
    return field_reason("time", time_field, "a number or an ISO-8601 date-time");
  if (utime < kEarliestUtime || !plausible_utime(utime))
    return "time " + quoted_field(time_field) + " is not a Unix epoch time after 2001" +
           (unit_ ? std::string(" in ") + table::time_unit_name(*unit_) : std::string()) +
           " (--time-unit)";
  LineOutcome out;
  if (uudf_ >= 0) {
    // A whole +UUDF line kept in one quoted field, its quotes doubled.
    const std::string_view raw = f[static_cast<size_t>(uudf_)];
    event_line_.clear();
    for (size_t i = 0; i < raw.size(); ++i) {
      event_line_ += raw[i];
      if (raw[i] == '"' && i + 1 < raw.size() && raw[i + 1] == '"') ++i;
    }
    out = decoder_.decode(event_line_, utime);
  } else {
    UudfEvent e;
    e.tag_id = f[static_cast<size_t>(tag_)];
    if (!valid_id(e.tag_id)) return field_reason("tag", e.tag_id, "an id (MAC or number)");
    e.anchor_id = f[static_cast<size_t>(anchor_)];
    if (!valid_id(e.anchor_id)) return field_reason("anchor", e.anchor_id, "an id (MAC or number)");
    if (rssi_ >= 0) {
      const std::string_view s = f[static_cast<size_t>(rssi_)];
      if (!table::parse_number(s, e.rssi_dbm) || e.rssi_dbm < kMinRssiDbm ||
          e.rssi_dbm > kMaxRssiDbm)
        return field_reason("RSSI", s, "a number of dBm in -128..20");
    }
    const std::string_view az = f[static_cast<size_t>(az_)];
    if (!table::parse_number(az, e.azimuth_raw_deg) || e.azimuth_raw_deg < kMinRawAngleDeg ||
        e.azimuth_raw_deg > kMaxRawAngleDeg)
      return field_reason("azimuth", az, "an angle in -90..180 deg");
    const std::string_view el = f[static_cast<size_t>(el_)];
    if (!table::parse_number(el, e.elevation_raw_deg) || e.elevation_raw_deg < kMinRawAngleDeg ||
        e.elevation_raw_deg > kMaxRawAngleDeg)
      return field_reason("elevation", el, "an angle in -90..180 deg");
    if (rssi2_ >= 0) {
      const std::string_view s = f[static_cast<size_t>(rssi2_)];
      if (!s.empty() && !table::parse_number(s, e.reserved))
        return field_reason("second RSSI", s, "a number");
    }
    int64_t v = 0;
    if (channel_ >= 0) {
      const std::string_view s = f[static_cast<size_t>(channel_)];
      if (!integer_field(s, 0, kMaxBleChannel, v))
        return field_reason("channel", s, "a BLE channel 0..39");
      e.channel = static_cast<int>(v);
    }
    if (seq_ >= 0 && !f[static_cast<size_t>(seq_)].empty()) {
      const std::string_view s = f[static_cast<size_t>(seq_)];
      if (!integer_field(s, 0, INT32_MAX, v))
        return field_reason("sequence", s, "an event counter 0..2147483647");
      e.has_counter = true;
      e.counter = static_cast<int32_t>(v);
    }
    if (uptime_ >= 0 && !f[static_cast<size_t>(uptime_)].empty()) {
      const std::string_view s = f[static_cast<size_t>(uptime_)];
      if (!integer_field(s, 0, int64_t{1} << 53, e.uptime_ms))
        return field_reason("uptime", s, "a number of ms");
    }
    if (user_ >= 0) {
      e.user_string = f[static_cast<size_t>(user_)];
      if (e.user_string.size() > kMaxUserStringLength || !printable_ascii(e.user_string))
        return field_reason("user string", e.user_string, "printable, at most 64 characters");
    }
    out = decoder_.decode_event(e, utime);
  }
  if (out.kind == LineOutcome::Kind::kError) return out.reason;
  if (out.kind == LineOutcome::Kind::kPublished) {
    ++tally_.messages;
    if (first_utime_ == 0 || utime < first_utime_) first_utime_ = utime;
    if (utime > last_utime_) last_utime_ = utime;
  }
  return {};
}

void UudfTableDecoder::decode(std::string_view line) {
  const table::TableReader::Kind kind = reader_.feed(line);
  tally_.note(reader_, kind, line);
  if (kind != table::TableReader::Kind::kData) return;
  if (!set_up_) set_up_columns(reader_.fields());
  const std::string reason = decode_row(reader_.fields());
  if (reason.empty()) {
    ++tally_.rows;
  } else {
    tally_.reject(reader_.line_number(), line, reason);
  }
}

}  // namespace ips::ble_aoa
