#pragma once
// Microsecond timestamps (utime) as carried by every message.
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdint>

namespace ips {

using utime_t = int64_t;

constexpr double utime_to_s(utime_t us) { return static_cast<double>(us) * 1e-6; }
// Seconds to microseconds, rounded, saturating at +-4e18 us (and NaN to 0) so that no value from
// a file or the wire can overflow the conversion.
inline utime_t s_to_utime(double s) {
  constexpr double kMaxUs = 4e18;
  const double us = s * 1e6;
  if (std::isnan(us)) return 0;
  if (us >= kMaxUs) return static_cast<utime_t>(kMaxUs);
  if (us <= -kMaxUs) return -static_cast<utime_t>(kMaxUs);
  return static_cast<utime_t>(us + (us >= 0 ? 0.5 : -0.5));
}

// A utime an estimator can do arithmetic on: positive, and small enough (< year 2096) that the
// difference of two never overflows. Anything else off the wire is invalid input.
constexpr bool plausible_utime(utime_t us) { return us > 0 && us < 4'000'000'000'000'000'000; }

// Host wall clock in us since the Unix epoch. Only drivers and the node runtime call this;
// estimators run on message time.
inline utime_t wall_utime_now() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

// The CPU time the calling thread has used, in seconds (for where a run's time went).
inline double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// The host's monotonic clock in us (from an arbitrary origin): for how long something took or
// how long ago it was, which a step of the wall clock (NTP, by hand) must not change.
inline utime_t monotonic_utime_now() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace ips
