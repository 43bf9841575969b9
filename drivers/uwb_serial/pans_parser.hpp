#pragma once
// Parser for the CSV lines a Qorvo/Decawave DWM1001 tag prints in its PANS UART shell after the
// `lec` command (DWM1001 Firmware API Guide, shell command `lec`: "show measurement and position
// in CSV format"), and the position-only lines of `lep`:
//
//   DIST,<n>,AN0,<id>,<x>,<y>,<z>,<dist>,AN1,<id>,<x>,<y>,<z>,<dist>,...[,POS,<x>,<y>,<z>,<qf>]
//   POS,<x>,<y>,<z>,<qf>
//
// e.g. (from the API guide's example session)
//   DIST,4,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,AN2,111C,5.00,0.00,2.25,
//   3.24,AN3,1150,0.00,0.00,2.25,3.19,POS,2.55,2.01,1.71,98     (one line)
//
// <n> anchors follow, each "AN<i>" (i = 0..n-1), its 16-bit short id as 4 hex digits, the
// anchor position configured in the network (x, y, z in m) and the measured distance in m. POS
// is the tag's own position from its location engine (m) and its quality factor qf, 0..100 %;
// it is absent when the location engine is off. The lines do not carry the tag's own id.
// Numbers are printed with two decimals; we accept any plain decimal number.
//
// Pure: no I/O, no allocation beyond the result, never throws. A line is taken whole or not at
// all: a line garbled anywhere (the shell interleaves output at high update rates) gives no
// measurement and a reason.
#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace ips::uwb_serial {

// Plausibility limits, beyond which a number is taken as garbled: no UWB link reaches 1 km and
// PANS coordinates are site coordinates (its own limit is +-2^31 mm).
inline constexpr double kMaxRangeM = 1000.0;
inline constexpr double kMaxCoordinateM = 100000.0;
// The most anchors we accept on one line (a PANS tag ranges to at most 4 at a time).
inline constexpr size_t kMaxPansAnchors = 16;

struct PansAnchorRange {
  std::array<char, 5> anchor_id{};  // 4 upper-case hex digits and a terminating NUL
  double anchor_position_m[3] = {0, 0, 0};
  double range_m = 0;
  std::string_view id() const { return std::string_view(anchor_id.data(), 4); }
};

struct PansPosition {
  double position_m[3] = {0, 0, 0};
  int quality_percent = 0;  // qf, 0..100
};

struct PansLine {
  size_t num_ranges = 0;
  std::array<PansAnchorRange, kMaxPansAnchors> ranges{};
  std::optional<PansPosition> position;
};

struct PansParseResult {
  enum class Kind {
    kMeasurement,  // `line` holds ranges and/or a position
    kShellText,    // the shell's prompt or an echoed command ("dwm> lec"): not data, not an error
    kError,        // not a lec/lep line, or a garbled one: `reason` says why
  };
  Kind kind = Kind::kError;
  PansLine line;
  std::string reason;
};

// Parses one line (without its line terminator; trailing spaces are ignored).
PansParseResult parse_pans_line(std::string_view line);

// True when `line` starts like a lec/lep data line ("DIST," or "POS,") or the shell prompt:
// the line is meant for parse_pans_line (used by automatic format detection).
bool looks_like_pans_line(std::string_view line);

}  // namespace ips::uwb_serial
