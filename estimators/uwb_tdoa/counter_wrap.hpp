#pragma once
// Arithmetic on the 40-bit UWB device counter of TDoA anchors: 63.8976 GHz (499.2 MHz x 128,
// 15.65 ps a tick), wrapping every 2^40 / 63.8976e9 = 17.207 s (../shared/reference/004_uwb_kf.md
// §1 and §4: "every interval must use modular subtraction"). Counter values are ticks in
// [0, 2^40); fractional tick values (converted times) are doubles, whose spacing near 2^40 is
// 1.2e-4 ticks (2 fs), far below the 0.17 ns timestamp noise.
#include <cmath>
#include <cstdint>

namespace ips::uwb_tdoa {

inline constexpr int64_t kCounterModulus = int64_t{1} << 40;
inline constexpr double kCounterModulusD = static_cast<double>(kCounterModulus);
inline constexpr double kSpeedOfLightMps = 299792458.0;

// True for a reading a 40-bit counter can give.
constexpr bool valid_counter(int64_t ticks) { return ticks >= 0 && ticks < kCounterModulus; }

// a - b reduced to [-2^39, 2^39) ticks: the elapsed count between two readings less than half a
// wrap (8.6 s) apart, whichever is later.
constexpr int64_t counter_diff(int64_t a, int64_t b) {
  const int64_t d = (a - b) & (kCounterModulus - 1);
  return d >= kCounterModulus / 2 ? d - kCounterModulus : d;
}

// The same for fractional ticks (any finite values).
inline double counter_diff(double a, double b) {
  double d = std::fmod(a - b, kCounterModulusD);
  if (d >= 0.5 * kCounterModulusD) d -= kCounterModulusD;
  if (d < -0.5 * kCounterModulusD) d += kCounterModulusD;
  return d;
}

// x reduced to [0, 2^40).
inline double counter_mod(double x) {
  double r = std::fmod(x, kCounterModulusD);
  if (r < 0) r += kCounterModulusD;
  return r >= kCounterModulusD ? 0.0 : r;
}
constexpr int64_t counter_mod(int64_t x) { return x & (kCounterModulus - 1); }

// Whole wraps across a long gap: the elapsed tick count that equals `modular_ticks` modulo 2^40
// and is nearest to `approx_ticks`, an estimate from the host clock (utime), which only has to
// be right to within half a wrap.
inline double unwrap_near(double modular_ticks, double approx_ticks) {
  return modular_ticks +
         kCounterModulusD * std::round((approx_ticks - modular_ticks) / kCounterModulusD);
}

}  // namespace ips::uwb_tdoa
