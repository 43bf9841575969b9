#include "loggers/eval/time_window.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>

#include "core/table_text.hpp"

namespace ips::eval {

std::optional<TimeBound> parse_time_bound(std::string_view text, std::string& error) {
  TimeBound b;
  double v = 0;
  if (table::parse_number(text, v)) {
    if (v < 0) {
      error = "expected seconds from the log's start (>= 0), a Unix time or an ISO-8601 time, got '" +
              table::excerpt(text) + "'";
      return std::nullopt;
    }
    // Beyond year 2286 (1e10 s) a utime still fits; beyond 9e12 s it would not.
    if (v > 9e12) {
      error = "time '" + table::excerpt(text) + "' is out of range";
      return std::nullopt;
    }
    if (v > kAbsoluteAfterS) {
      b.absolute = true;
      b.utime = static_cast<utime_t>(std::llround(v * 1e6));
    } else {
      b.offset_s = v;
    }
    return b;
  }
  int64_t us = 0;
  if (table::parse_iso8601_us(text, us)) {
    b.absolute = true;
    b.utime = us;
    return b;
  }
  error = "expected seconds from the log's start, a Unix time in s or an ISO-8601 time "
          "(2024-12-18T05:58:05Z), got '" + table::excerpt(text) + "'";
  return std::nullopt;
}

std::string iso8601_utc(utime_t t) {
  const utime_t secs_floor = t >= 0 ? t / 1'000'000 : -((-t + 999'999) / 1'000'000);
  const std::time_t secs = static_cast<std::time_t>(secs_floor);
  std::tm tm{};
  if (!gmtime_r(&secs, &tm)) return "?";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>((t - secs_floor * 1'000'000) / 1000));
  return buf;
}

}  // namespace ips::eval
