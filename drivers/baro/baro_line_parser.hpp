#pragma once
// The line a microcontroller with a barometer prints on its serial port, once per sample
// (docs/hardware/barometer.md has an Arduino sketch that prints it):
//
//   P <pressure, Pa> T <temperature, degC> [H <relative humidity, %>]
//   P 101325.12 T 21.43 H 45.2
//
// Fields are a letter and a number separated by spaces or tabs (any number of them), in any
// order, each at most once; P and T are required, H is optional. Numbers are plain decimals
// (core/device_text.hpp: no exponent, no "nan"/"inf", which Arduino's print(float) gives for a
// failed read). A trailing CR (CRLF line ends) is ignored. A line starting with '#' is the
// sketch's own comment (a banner, a status) and no sample. Every sample passes reading_problem()
// (30..125 kPa, -40..85 degC, 0..100 %).
//
// Pure: no I/O, never throws. Reasons are printable ASCII (quoted_field).
#include <string>
#include <string_view>

#include "drivers/baro/baro_reading.hpp"

namespace ips::baro {

struct BaroLineResult {
  enum class Kind { kSample, kComment, kError };
  Kind kind = Kind::kError;
  BaroReading reading;  // kSample
  std::string reason;   // kError
};

BaroLineResult parse_baro_line(std::string_view line);

}  // namespace ips::baro
