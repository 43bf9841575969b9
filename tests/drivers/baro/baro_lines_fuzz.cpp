// libFuzzer target: arbitrary bytes from a serial barometer, and arbitrary sysfs attribute texts,
// through what ips-baro does with them: LineBuffer -> parse_baro_line, and parse_sysfs_number /
// iio_channel_value on the input cut into raw, scale and offset at '|'. Checks that nothing
// crashes or throws, that every sample passes the published limits (finite pressure within
// 30..125 kPa, finite temperature within -40..85 degC, humidity NaN or within 0..100 %), that
// every error has a printable reason, and that every accepted sysfs value is finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/line_buffer.hpp"
#include "drivers/baro/baro_line_parser.hpp"
#include "drivers/baro/sysfs_value.hpp"

namespace {

using namespace ips::baro;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

bool printable_reason(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

void check_line(std::string_view line) {
  const BaroLineResult r = parse_baro_line(line);
  switch (r.kind) {
    case BaroLineResult::Kind::kSample: {
      const BaroReading& s = r.reading;
      check(std::isfinite(s.pressure_pa) && s.pressure_pa >= kMinPressurePa &&
                s.pressure_pa <= kMaxPressurePa,
            "pressure outside the limits");
      check(std::isfinite(s.temperature_c) && s.temperature_c >= kMinTemperatureC &&
                s.temperature_c <= kMaxTemperatureC,
            "temperature outside the limits");
      check(std::isnan(s.humidity_pct) || (s.humidity_pct >= 0 && s.humidity_pct <= 100),
            "humidity outside the limits");
      check(reading_problem(s).empty(), "a sample with a problem");
      break;
    }
    case BaroLineResult::Kind::kComment:
      check(r.reason.empty(), "a comment with a reason");
      break;
    case BaroLineResult::Kind::kError:
      check(printable_reason(r.reason), "bad line reason");
      break;
  }
}

void check_sysfs(std::string_view bytes) {
  double v = 0;
  std::string reason;
  if (parse_sysfs_number(bytes, v, reason))
    check(std::isfinite(v), "sysfs number not finite");
  else
    check(printable_reason(reason), "sysfs reason");
  IioChannelText c{"in_pressure", std::nullopt, std::nullopt, std::nullopt, std::nullopt};
  std::string_view parts[3];
  size_t n = 0;
  for (size_t start = 0; n < 3;) {
    const size_t bar = bytes.find('|', start);
    parts[n++] = bytes.substr(start, bar == std::string_view::npos ? bar : bar - start);
    if (bar == std::string_view::npos) break;
    start = bar + 1;
  }
  c.raw = parts[0];
  if (n > 1) c.scale = parts[1];
  if (n > 2) c.offset = parts[2];
  if (iio_channel_value(c, v, reason))
    check(std::isfinite(v), "channel value not finite");
  else
    check(printable_reason(reason), "channel reason");
  c.input = bytes;
  if (iio_channel_value(c, v, reason))
    check(std::isfinite(v), "input value not finite");
  else
    check(printable_reason(reason), "input reason");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  ips::LineBuffer lines(256);
  lines.feed(bytes, check_line);
  const std::string rest = lines.take_partial();
  if (!rest.empty()) check_line(rest);
  check_line(bytes);  // the whole input as one line, whatever it holds
  check_sysfs(bytes);
  return 0;
}
