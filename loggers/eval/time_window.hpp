#pragma once
// The bounds of `ips-eval --from S --to S`: seconds from the log's start (its first event's time
// stamp), or an absolute time: a number larger than kAbsoluteAfterS is Unix time in seconds, and
// an ISO-8601 date-time ("2024-12-18T05:58:05Z", UTC when no offset is given) is absolute too.
// Pure.
#include <optional>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace ips::eval {

// 1e9 s after the epoch is 2001-09-09; 1e9 s from a log's start is 31 years into it.
inline constexpr double kAbsoluteAfterS = 1e9;

struct TimeBound {
  bool absolute = false;
  utime_t utime = 0;      // when absolute
  double offset_s = 0.0;  // from the log's start, when not absolute

  // The bound as a utime, for a log whose first event is at log_start.
  utime_t resolve(utime_t log_start) const {
    return absolute ? utime : log_start + s_to_utime(offset_s);
  }
};

// nullopt, with `error` saying why, when `text` is neither a number of seconds >= 0 nor an
// ISO-8601 date-time.
std::optional<TimeBound> parse_time_bound(std::string_view text, std::string& error);

// A utime as ISO-8601 UTC with milliseconds ("2024-12-18T05:58:05.000Z"), for messages.
std::string iso8601_utc(utime_t t);

}  // namespace ips::eval
