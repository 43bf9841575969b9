#pragma once
// Parser for the capture files of the source experiments (../shared/reference/000_ble_aoa.md,
// section 2, "UUDF-time"): a logger on the PC read every anchor's serial port and wrote one CSV
// line per line read, with the PC's local time (ms) and the port in front:
//
//   2023-12-12 9:50:26.643,COM8,+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25
//
// <date> <time>: YYYY-MM-DD and H:MM:SS with 1 to 6 fractional digits (the hour may have one
// digit); <port>: the PC's name for the anchor's port (1 to 32 of [A-Za-z0-9_.:/-]); the rest of
// the line, commas and all, is what the anchor printed. A UTF-8 byte-order mark before the first
// line is skipped. The time carries no zone: utime_from_civil() applies the one the user gives.
//
// Pure: no I/O, never throws.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ips::ble_aoa {

inline constexpr size_t kMaxPortLength = 32;

// A wall-clock reading without a zone.
struct CivilTime {
  int year = 1970;
  int month = 1;  // 1..12
  int day = 1;    // 1..31 (checked against the month)
  int hour = 0;
  int minute = 0;
  int second = 0;      // 0..59 (no leap seconds: Windows clocks never show 60)
  int64_t micros = 0;  // 0..999999
};

struct CaptureLine {
  CivilTime pc_time;
  std::string_view port;     // views into the parsed line
  std::string_view payload;  // the anchor's line
};

struct CaptureParseResult {
  bool ok = false;
  CaptureLine line;
  std::string reason;  // when !ok
};

CaptureParseResult parse_capture_line(std::string_view line);

// `t` read in a zone `utc_offset_s` seconds east of UTC (+3600 for CET) -> us since the Unix
// epoch (proleptic Gregorian calendar, days_from_civil). Years 1970..2095 (plausible utimes);
// nullopt outside them.
std::optional<int64_t> utime_from_civil(const CivilTime& t, int64_t utc_offset_s);

// "UTC", "Z", "+01:00", "-05:30", "+0100" -> seconds east of UTC; nullopt for anything else (a
// zone name such as Europe/Prague, which main resolves with the system's zone database).
std::optional<int64_t> parse_utc_offset(std::string_view text);

}  // namespace ips::ble_aoa
