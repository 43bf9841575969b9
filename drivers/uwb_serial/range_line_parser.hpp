#pragma once
// Parser for our RANGE line protocol, for tags and listeners running custom firmware
// (docs/hardware/uwb.md#the-range-line-protocol):
//
//   RANGE <tag> <anchor> <range_m> [<rssi_dbm>]
//
// one measurement a line, fields separated by one or more spaces or tabs, lines ending in LF or
// CRLF. <tag>, <anchor>: 1 to 32 of [A-Za-z0-9_.:-], as in the site file. <range_m>: the
// two-way-ranging distance in metres, a plain decimal 0..1000. <rssi_dbm>: optional receive
// power in dBm, a plain decimal -200..+50. Lines starting with '#' are comments (boot banners,
// firmware version) and are ignored.
//
// Pure: no I/O, never throws.
#include <cmath>
#include <string>
#include <string_view>

namespace ips::uwb_serial {

inline constexpr size_t kMaxRangeLineIdLength = 32;
inline constexpr double kMinRssiDbm = -200.0;
inline constexpr double kMaxRssiDbm = 50.0;

struct RangeLine {
  std::string_view tag_id;  // views into the parsed line
  std::string_view anchor_id;
  double range_m = 0;
  double rssi_dbm = NAN;  // NaN when the line has none
};

struct RangeLineParseResult {
  enum class Kind { kMeasurement, kComment, kError };
  Kind kind = Kind::kError;
  RangeLine range;
  std::string reason;  // for kError
};

RangeLineParseResult parse_range_line(std::string_view line);

// True for a tag or anchor id the protocol allows: 1 to 32 of [A-Za-z0-9_.:-].
bool valid_range_line_id(std::string_view id);

// True when `line` is meant for parse_range_line (starts with the word RANGE or with '#').
bool looks_like_range_line(std::string_view line);

}  // namespace ips::uwb_serial
