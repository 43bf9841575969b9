#include "estimators/altitude/reference_series.hpp"

#include <algorithm>
#include <cmath>

namespace ips::altitude {

bool ReferenceSeries::add(const ReferenceReading& r) {
  if (!readings_.empty() && r.utime <= readings_.back().utime) return false;
  readings_.push_back(r);
  while (readings_.size() > kMaxReadings ||
         (readings_.size() > 2 && readings_.front().utime < r.utime - keep_us_))
    readings_.pop_front();
  return true;
}

std::optional<ReferenceAt> ReferenceSeries::at(utime_t t) const {
  if (readings_.empty()) return std::nullopt;
  ReferenceAt out;
  if (t <= readings_.front().utime || t >= readings_.back().utime) {
    const ReferenceReading& held = t <= readings_.front().utime ? readings_.front()
                                                                : readings_.back();
    out.reading = held;
    out.age_s = std::abs(utime_to_s(t - held.utime));
    out.interpolated = out.age_s == 0;
    out.reading.utime = t;
    return out;
  }
  const auto after = std::upper_bound(
      readings_.begin(), readings_.end(), t,
      [](utime_t v, const ReferenceReading& r) { return v < r.utime; });
  const ReferenceReading& b = *after;
  const ReferenceReading& a = *(after - 1);
  const double f = static_cast<double>(t - a.utime) / static_cast<double>(b.utime - a.utime);
  auto lerp = [f](double x, double y) {
    // A field known at only one end is taken from that end.
    if (std::isnan(x)) return y;
    if (std::isnan(y)) return x;
    return x + f * (y - x);
  };
  out.reading.utime = t;
  out.reading.pressure_pa = lerp(a.pressure_pa, b.pressure_pa);
  out.reading.temperature_c = lerp(a.temperature_c, b.temperature_c);
  out.reading.humidity_pct = lerp(a.humidity_pct, b.humidity_pct);
  out.reading.height_m = lerp(a.height_m, b.height_m);
  out.interpolated = true;
  // Across a gap the reading is no better than the nearer end.
  out.age_s = utime_to_s(std::min(t - a.utime, b.utime - t));
  return out;
}

}  // namespace ips::altitude
