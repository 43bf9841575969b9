#include "drivers/baro/baro_reading.hpp"

#include <cmath>
#include <cstdio>

namespace ips::baro {

std::string format_number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string reading_problem(const BaroReading& r) {
  const double p = r.pressure_pa;
  if (!std::isfinite(p)) return "pressure is not a finite number";
  if (p <= 0) return "pressure " + format_number(p) + " Pa is not positive";
  if (p < kMinPressurePa || p > kMaxPressurePa)
    return "pressure " + format_number(p) +
           " Pa is outside 30..125 kPa, the measuring range of the supported sensors";
  const double t = r.temperature_c;
  if (!std::isnan(t)) {
    if (!std::isfinite(t)) return "temperature is not a finite number";
    if (t < kMinTemperatureC || t > kMaxTemperatureC)
      return "temperature " + format_number(t) +
             " degC is outside -40..85 degC, the sensors' operating range";
  }
  const double h = r.humidity_pct;
  if (!std::isnan(h) && !(h >= 0 && h <= 100))
    return "humidity " + format_number(h) + " % is outside 0..100 %";
  return "";
}

baro_t to_message(const BaroReading& r, utime_t utime, const std::string& source,
                  const std::string& sensor_id, std::optional<double> reference_height_m) {
  baro_t m;
  m.utime = utime;
  m.source = source;
  m.sensor_id = sensor_id;
  m.pressure_pa = r.pressure_pa;
  m.temperature_c = r.temperature_c;
  m.humidity_pct = r.humidity_pct;
  m.is_reference = reference_height_m.has_value();
  m.known_height_m = reference_height_m.value_or(kNaN);
  return m;
}

}  // namespace ips::baro
