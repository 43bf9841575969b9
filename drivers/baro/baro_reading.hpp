#pragma once
// One barometer sample as ips-baro publishes it, whether it came from a Linux IIO device or a
// serial line, the checks every sample passes before it goes out, and its baro_t. A sample that
// fails a check is counted and skipped, never published. Pure.
#include <ips/baro_t.hpp>
#include <limits>
#include <optional>
#include <string>

#include "core/time.hpp"

namespace ips::baro {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct BaroReading {
  double pressure_pa = kNaN;
  double temperature_c = kNaN;  // NaN: the device has no temperature channel
  double humidity_pct = kNaN;   // relative humidity; NaN: not measured
};

// Pressure: 30..125 kPa, the measuring ranges of the barometers this driver is for
// (../shared/reference/003_baro.md Table 2.1: BMP280 30-110, BMP390 30-125, DPS310 30-120,
// MS5637 30-120 kPa; the LPS22HH's 26-126 is wider). Anything outside is a fault, not weather:
// the record sea-level pressure is 108.4 kPa, and 30 kPa is less than on the summit of Everest.
inline constexpr double kMinPressurePa = 30'000.0;
inline constexpr double kMaxPressurePa = 125'000.0;
// Temperature: the operating range of the BMP280 (datasheet BST-BMP280-DS001, key parameters:
// -40 ... +85 degC); the BMP390 and the LPS22 parts state the same.
inline constexpr double kMinTemperatureC = -40.0;
inline constexpr double kMaxTemperatureC = 85.0;

// Why `r` must not be published, empty when it may: a pressure that is not finite, not positive
// or outside 30..125 kPa; a temperature that is not finite (NaN, "unknown", is allowed) or
// outside -40..85 degC; a humidity outside 0..100 % (NaN, "not measured", is allowed).
std::string reading_problem(const BaroReading& r);

// "101325.12": a number for a reason text, with enough digits to find the sample again.
std::string format_number(double v);

// The message for a checked sample. `reference_height_m` marks a reference station (its known
// height above the site origin); without it is_reference is false and known_height_m NaN.
baro_t to_message(const BaroReading& r, utime_t utime, const std::string& source,
                  const std::string& sensor_id, std::optional<double> reference_height_m);

}  // namespace ips::baro
