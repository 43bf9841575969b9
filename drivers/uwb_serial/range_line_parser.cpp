#include "drivers/uwb_serial/range_line_parser.hpp"

#include <array>

#include "core/device_text.hpp"
#include "drivers/uwb_serial/pans_parser.hpp"

namespace ips::uwb_serial {

namespace {

bool is_space(char c) { return c == ' ' || c == '\t'; }

}  // namespace

bool valid_range_line_id(std::string_view id) {
  if (id.empty() || id.size() > kMaxRangeLineIdLength) return false;
  for (char c : id) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '.' || c == ':' || c == '-';
    if (!ok) return false;
  }
  return true;
}

namespace {

RangeLineParseResult error(std::string reason) {
  RangeLineParseResult r;
  r.kind = RangeLineParseResult::Kind::kError;
  r.reason = std::move(reason);
  return r;
}

}  // namespace

bool looks_like_range_line(std::string_view line) {
  return line.starts_with('#') || line == "RANGE" || line.starts_with("RANGE ") ||
         line.starts_with("RANGE\t");
}

RangeLineParseResult parse_range_line(std::string_view line) {
  if (line.starts_with('#')) {
    RangeLineParseResult r;
    r.kind = RangeLineParseResult::Kind::kComment;
    return r;
  }
  constexpr size_t kMaxFields = 5;
  std::array<std::string_view, kMaxFields> fields;
  size_t count = 0;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    if (i == line.size()) break;
    const size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (count == kMaxFields) return error("RANGE: more than 5 fields");
    fields[count++] = line.substr(start, i - start);
  }
  if (count == 0 || fields[0] != "RANGE") {
    return error("not a RANGE line (got " + quoted_field(count ? fields[0] : line) + ")");
  }
  if (count < 4) {
    return error("RANGE: expected <tag> <anchor> <range_m> [<rssi_dbm>], got " +
                 std::to_string(count - 1) + " fields");
  }
  RangeLineParseResult r;
  r.kind = RangeLineParseResult::Kind::kMeasurement;
  if (!valid_range_line_id(fields[1])) {
    return error("RANGE: tag id " + quoted_field(fields[1]) + " is not 1 to 32 of A-Za-z0-9_.:-");
  }
  if (!valid_range_line_id(fields[2])) {
    return error("RANGE: anchor id " + quoted_field(fields[2]) +
                 " is not 1 to 32 of A-Za-z0-9_.:-");
  }
  r.range.tag_id = fields[1];
  r.range.anchor_id = fields[2];
  if (!parse_decimal(fields[3], r.range.range_m)) {
    return error("RANGE: range " + quoted_field(fields[3]) + " is not a number");
  }
  if (r.range.range_m < 0 || r.range.range_m > kMaxRangeM) {
    return error("RANGE: range " + quoted_field(fields[3]) + " m is outside 0..1000 m");
  }
  if (count == 5) {
    double rssi = 0;
    if (!parse_decimal(fields[4], rssi) || rssi < kMinRssiDbm || rssi > kMaxRssiDbm) {
      return error("RANGE: rssi " + quoted_field(fields[4]) +
                   " is not a number of dBm in -200..50");
    }
    r.range.rssi_dbm = rssi;
  }
  return r;
}

}  // namespace ips::uwb_serial
