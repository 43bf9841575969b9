#pragma once
// A reference barometer's recent readings (003_baro.md section 4: align the timestamps of p0 and
// p_T, handle a stale p0). at(t) gives the reference at a tag reading's time: interpolated
// linearly between the two readings around t, or the nearest reading held, with its age, when t
// is outside the kept span (the next reading has not come yet, or the reference went quiet).
// Bounded: readings older than keep_s before the newest, and more than kMaxReadings, are
// dropped. Pure.
#include <cstddef>
#include <deque>
#include <optional>

#include "core/time.hpp"

namespace ips::altitude {

struct ReferenceReading {
  utime_t utime = 0;
  double pressure_pa = 0;     // offset-corrected
  double temperature_c = 0;   // NaN when unknown
  double humidity_pct = 0;    // NaN when unmeasured
  double height_m = 0;        // the station's known height
};

struct ReferenceAt {
  ReferenceReading reading;   // utime: the time asked for
  double age_s = 0;           // how far the nearest reading used is from t
  bool interpolated = false;  // t lies between two readings (or on one)
};

class ReferenceSeries {
 public:
  static constexpr size_t kMaxReadings = 4096;
  explicit ReferenceSeries(double keep_s = 10.0) : keep_us_(s_to_utime(keep_s)) {}

  // False (and nothing kept) when the reading is not after the newest one.
  bool add(const ReferenceReading& r);
  std::optional<ReferenceAt> at(utime_t t) const;
  bool empty() const { return readings_.empty(); }
  utime_t newest_utime() const { return readings_.empty() ? 0 : readings_.back().utime; }

 private:
  utime_t keep_us_;
  std::deque<ReferenceReading> readings_;
};

}  // namespace ips::altitude
