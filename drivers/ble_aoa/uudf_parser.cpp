#include "drivers/ble_aoa/uudf_parser.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <system_error>

#include "core/device_text.hpp"

namespace ips::ble_aoa {

namespace {

constexpr std::string_view kPrefix = "+UUDF:";
constexpr size_t kMaxFields = 10;

struct Field {
  std::string_view text;
  bool quoted = false;
};

// Splits at commas; a field that starts with '"' runs to the next '"' (it may hold commas), which
// must end it. Spaces and tabs around unquoted fields are dropped. False with `reason` when the
// line has too many fields or a quote is not closed.
bool split_fields(std::string_view s, std::array<Field, kMaxFields>& out, size_t& n,
                  std::string& reason) {
  n = 0;
  size_t i = 0;
  for (;;) {
    if (n == kMaxFields) {
      reason = "+UUDF: more than 10 fields";
      return false;
    }
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    Field f;
    if (i < s.size() && s[i] == '"') {
      const size_t close = s.find('"', i + 1);
      if (close == std::string_view::npos) {
        reason = "+UUDF: field " + std::to_string(n + 1) + ": quote not closed";
        return false;
      }
      f.text = s.substr(i + 1, close - i - 1);
      f.quoted = true;
      i = close + 1;
      while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
      if (i < s.size() && s[i] != ',') {
        reason = "+UUDF: field " + std::to_string(n + 1) + ": text after its closing quote";
        return false;
      }
    } else {
      size_t end = s.find(',', i);
      if (end == std::string_view::npos) end = s.size();
      std::string_view t = s.substr(i, end - i);
      while (!t.empty() && (t.back() == ' ' || t.back() == '\t')) t.remove_suffix(1);
      f.text = t;
      i = end;
    }
    out[n++] = f;
    if (i >= s.size()) return true;
    ++i;  // the comma
  }
}

bool number_in(std::string_view text, double lo, double hi, double& v) {
  return parse_decimal(text, v) && v >= lo && v <= hi;
}

}  // namespace

bool valid_id(std::string_view id) { return valid_device_id(id, kMaxIdLength); }

UudfParseResult parse_uudf_line(std::string_view line) {
  UudfParseResult r;
  while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
  if (line.substr(0, kPrefix.size()) != kPrefix) {
    r.kind = UudfParseResult::Kind::kAtLine;
    if (line == "OK") {
      r.at = AtLine::kOk;
    } else if (line == "ERROR" || line.substr(0, 10) == "+CME ERROR") {
      r.at = AtLine::kError;
    } else if (line == "+STARTUP") {
      r.at = AtLine::kStartup;
    } else if (line.size() >= 2 && (line[0] == 'A' || line[0] == 'a') &&
               (line[1] == 'T' || line[1] == 't') && printable_ascii(line)) {
      r.at = AtLine::kEcho;
    } else if (line.size() >= 3 && line[0] == '+' && line[1] >= 'A' && line[1] <= 'Z' &&
               line.find(':') != std::string_view::npos && printable_ascii(line)) {
      // "+NAME:..." with NAME of capitals: an information response (+UMLA:, +UDFCFG:, ...).
      const size_t colon = line.find(':');
      bool name = true;
      for (size_t k = 1; k < colon; ++k)
        if (!((line[k] >= 'A' && line[k] <= 'Z') || (line[k] >= '0' && line[k] <= '9')))
          name = false;
      if (!name) {
        r.kind = UudfParseResult::Kind::kError;
        r.reason = "not a +UUDF event or an AT response: " + quoted_field(line);
        return r;
      }
      r.at = AtLine::kResponse;
    } else {
      r.kind = UudfParseResult::Kind::kError;
      r.reason = "not a +UUDF event or an AT response: " + quoted_field(line);
    }
    return r;
  }

  r.kind = UudfParseResult::Kind::kError;
  std::array<Field, kMaxFields> f;
  size_t n = 0;
  if (!split_fields(line.substr(kPrefix.size()), f, n, r.reason)) return r;
  if (n != 9 && n != 10) {
    r.reason = "+UUDF: " + std::to_string(n) + " fields, expected 9 or 10";
    return r;
  }
  for (size_t k = 0; k < n; ++k) {
    const bool want_quoted = k == 6 || k == 7;
    if (f[k].quoted != want_quoted) {
      static const char* const kNames[] = {"tag id",   "RSSI",    "azimuth",   "elevation",
                                           "reserved", "channel", "anchor id", "user string",
                                           "uptime",   "counter"};
      r.reason = std::string("+UUDF: ") + kNames[k] +
                 (want_quoted ? " is not a quoted string" : " is quoted");
      return r;
    }
  }
  UudfEvent& e = r.event;
  e.tag_id = f[0].text;
  if (!valid_id(e.tag_id)) {
    r.reason = "+UUDF: tag id " + quoted_field(e.tag_id) + " is not 1 to 32 of A-Za-z0-9_.:-";
    return r;
  }
  if (!number_in(f[1].text, kMinRssiDbm, kMaxRssiDbm, e.rssi_dbm)) {
    r.reason = "+UUDF: RSSI " + quoted_field(f[1].text) + " is not a number in -128..20 dBm";
    return r;
  }
  if (!number_in(f[2].text, kMinRawAngleDeg, kMaxRawAngleDeg, e.azimuth_raw_deg)) {
    r.reason = "+UUDF: azimuth " + quoted_field(f[2].text) + " is not a number in -90..180 deg";
    return r;
  }
  if (!number_in(f[3].text, kMinRawAngleDeg, kMaxRawAngleDeg, e.elevation_raw_deg)) {
    r.reason = "+UUDF: elevation " + quoted_field(f[3].text) + " is not a number in -90..180 deg";
    return r;
  }
  if (!number_in(f[4].text, -1e6, 1e6, e.reserved)) {
    r.reason = "+UUDF: reserved field " + quoted_field(f[4].text) + " is not a number";
    return r;
  }
  int64_t v = 0;
  if (!parse_integer(f[5].text, v) || v < 0 || v > kMaxBleChannel) {
    r.reason = "+UUDF: channel " + quoted_field(f[5].text) + " is not 0..39";
    return r;
  }
  e.channel = static_cast<int>(v);
  e.anchor_id = f[6].text;
  if (!valid_id(e.anchor_id)) {
    r.reason = "+UUDF: anchor id " + quoted_field(e.anchor_id) + " is not 1 to 32 of A-Za-z0-9_.:-";
    return r;
  }
  e.user_string = f[7].text;
  if (e.user_string.size() > kMaxUserStringLength) {
    r.reason = "+UUDF: user string longer than 64 bytes";
    return r;
  }
  if (!parse_integer(f[8].text, v) || v < 0) {
    r.reason = "+UUDF: uptime " + quoted_field(f[8].text) + " is not a count of ms";
    return r;
  }
  e.uptime_ms = v;
  if (n == 10) {
    if (!parse_integer(f[9].text, v) || v < 0 || v > INT32_MAX) {
      r.reason = "+UUDF: counter " + quoted_field(f[9].text) + " is not 0..2147483647";
      return r;
    }
    e.has_counter = true;
    e.counter = static_cast<int32_t>(v);
  }
  r.kind = UudfParseResult::Kind::kEvent;
  return r;
}

}  // namespace ips::ble_aoa
