#include "core/twr_timestamps.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ips::twr {

bool fits_counter(int64_t v, int bits) {
  if (!valid_counter_bits(bits)) return false;
  const int64_t wrap = int64_t{1} << bits;
  return v >= -(wrap / 2) && v < wrap;
}

int64_t counter_elapsed(int64_t later, int64_t earlier, int bits) {
  const uint64_t mask = (uint64_t{1} << bits) - 1;
  return static_cast<int64_t>((static_cast<uint64_t>(later) - static_cast<uint64_t>(earlier)) &
                              mask);
}

int64_t counter_diff(int64_t a, int64_t b, int bits) {
  const int64_t d = counter_elapsed(a, b, bits);
  const int64_t wrap = int64_t{1} << bits;
  return d >= wrap / 2 ? d - wrap : d;
}

Intervals intervals(const Stamps& s, int bits) {
  Intervals iv;
  iv.ra = counter_elapsed(s.resp_rx, s.poll_tx, bits);
  iv.db = counter_elapsed(s.resp_tx, s.poll_rx, bits);
  iv.rb = counter_elapsed(s.final_rx, s.resp_tx, bits);
  iv.da = counter_elapsed(s.final_tx, s.resp_rx, bits);
  return iv;
}

double ss_twr_tof_ticks(const Intervals& iv, double clock_offset) {
  return (static_cast<double>(iv.ra) - static_cast<double>(iv.db) * (1.0 - clock_offset)) / 2.0;
}

// GCC's and Clang's 128-bit integer (__extension__: not ISO C++).
__extension__ typedef __int128 Int128;

double ds_twr_tof_ticks(const Intervals& iv) {
  // Each interval is below 2^62 ticks; the products are exact in 128 bits.
  const Int128 num = static_cast<Int128>(iv.ra) * iv.rb - static_cast<Int128>(iv.da) * iv.db;
  const Int128 den = static_cast<Int128>(iv.ra) + iv.rb + iv.da + iv.db;
  if (den <= 0) return std::numeric_limits<double>::quiet_NaN();
  // The quotient is small (a time of flight); its integer part and the remainder are exact.
  const Int128 q = num / den, rem = num % den;
  return static_cast<double>(q) + static_cast<double>(rem) / static_cast<double>(den);
}

double ds_twr_clock_offset(const Intervals& iv) {
  const double tag = static_cast<double>(iv.ra) + static_cast<double>(iv.da);
  if (!(tag > 0)) return std::numeric_limits<double>::quiet_NaN();
  return (static_cast<double>(iv.rb) + static_cast<double>(iv.db)) / tag - 1.0;
}

std::optional<double> ClockOffsetTracker::update(const std::string& key, int64_t utime,
                                                 int64_t poll_tx, int64_t poll_rx, int bits,
                                                 double tick_s) {
  ++tally_.exchanges;
  auto [it, added] = pairs_.try_emplace(key);
  Pair& p = it->second;
  const double dt_s = static_cast<double>(utime - p.utime) * 1e-6;
  const bool usable = !added && valid_counter_bits(bits) && tick_s > 0 && dt_s > 0 &&
                      dt_s <= options_.max_interval_s;
  if (!usable) {
    ++tally_.restarts;
    p.recent.clear();
  } else {
    const double wrap = std::ldexp(1.0, bits);
    const double host_ticks = dt_s / tick_s;
    const double tag_low = static_cast<double>(counter_elapsed(poll_tx, p.poll_tx, bits));
    const double wraps = (host_ticks - tag_low) / wrap;
    const double k = std::round(wraps);
    double length = host_ticks;
    bool from_counter = false;
    if (k >= 0 && std::fabs(wraps - k) <= options_.wrap_tolerance) {
      length = tag_low + k * wrap;
      from_counter = true;
    }
    // The anchor's advance less the tag's: small, read modulo the wrap.
    const double d =
        static_cast<double>(counter_diff(counter_elapsed(poll_rx, p.poll_rx, bits),
                                         counter_elapsed(poll_tx, p.poll_tx, bits), bits));
    const double r = length > 0 ? d / length : std::numeric_limits<double>::quiet_NaN();
    if (std::isfinite(r) && std::fabs(r) * 1e6 <= options_.max_abs_ppm) {
      ++tally_.measured;
      ++(from_counter ? tally_.counter_interval : tally_.host_interval);
      p.recent.push_back(r);
      while (static_cast<int>(p.recent.size()) > std::max(1, options_.median_of))
        p.recent.pop_front();
    } else {
      ++tally_.implausible;
    }
  }
  p.utime = utime;
  p.poll_tx = poll_tx;
  p.poll_rx = poll_rx;
  if (p.recent.empty()) return std::nullopt;
  std::vector<double> v(p.recent.begin(), p.recent.end());
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2.0;
}

}  // namespace ips::twr
