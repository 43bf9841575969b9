#pragma once
// can-utils' candump text, one line at a time, into CAN frames, and CAN frames into the
// `candump -L` log format. Pure: no I/O, no exceptions; every line it cannot read gets a reason.
//
// Lines read (docs/hardware/uwb.md has examples):
//  - the log format of `candump -L` and `candump -l` files:
//      (1436509052.249713) can0 123#DEADBEEF
//    with the compact frame syntax of can-utils (lib.h, parse_canframe): a 3-hex-digit standard
//    or 8-hex-digit extended id; 8 digits with bit 29 (0x20000000) set is an error frame; then
//    `#` and 0..8 data bytes as hex pairs, optionally separated by `.`, and for an 8-byte frame an
//    optional `_D` raw DLC 9..F; or `#R` (remote request) with an optional length digit; or
//    `##F` and 0..64 data bytes for CAN FD, F being one hex digit of flags (BRS 1, ESI 2). One
//    trailing `T` or `R` (candump -x: sent or received) is allowed;
//  - candump's default screen format, with or without a timestamp (-t a/d/z/A) and -x fields:
//      (1436509052.249713)  can0  123   [8]  DE AD BE EF 00 11 22 33
//        can0  123   [3]  remote request
//        can0  12345678  [12]  00 11 22 33 44 55 66 77 88 99 AA BB     (CAN FD: 2-digit length)
//    with an optional ASCII column (-a) and the ERRORFRAME marker after the data;
//  - `DROPCOUNT: dropped N CAN frames on 'can0' socket ...` (frames candump lost), error-frame
//    detail lines starting with a tab (candump -e) and blank lines.
//
// Timestamps: an absolute time is `(seconds.fraction)` with 10 or more digits of seconds, as
// candump prints it for -L and -t a (since the Unix epoch, host clock of the capturing machine).
// Fewer digits are relative times (-t d, -t z) and the -t A date form is local time: such lines
// carry no absolute time (has_time false).
#include <cstdint>
#include <string>
#include <string_view>

#include "core/time.hpp"
#include "drivers/uwb_can/can_frame.hpp"

namespace ips::uwb_can {

enum class CandumpLineKind {
  kFrame,      // `frame` (and `has_time`/`utime`, `interface`) filled in
  kEmpty,      // blank line
  kNote,       // an error-frame detail line of candump -e: nothing to do
  kDropCount,  // candump reports `dropped` frames it lost
  kBad,        // `reason` says why
};

struct CandumpLine {
  CandumpLineKind kind = CandumpLineKind::kBad;
  CanFrame frame;
  bool has_time = false;
  utime_t utime = 0;      // when has_time: microseconds since the Unix epoch
  std::string interface;  // as written on the line, e.g. "can0"
  uint64_t dropped = 0;   // kDropCount
  std::string reason;     // kBad
};

// Longest line accepted (an FD frame in the screen format with -a and -x is about 250 chars).
inline constexpr size_t kMaxCandumpLineBytes = 1024;

CandumpLine parse_candump_line(std::string_view line);

// The `candump -L` line for a frame, without the newline, e.g.
// "(1767225600.100000) can0 301#01004C0F0000FF07". utime must be >= 0.
std::string format_candump_line(const CanFrame& frame, utime_t utime, std::string_view interface);

}  // namespace ips::uwb_can
