// libFuzzer target: ips-eval's --dwell file is outside bytes. Reading it must give intervals (with
// start <= end, finite x, y, and a plausible time) or one printable error line, never crash or
// hang. The first byte picks the options, the rest is the file.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "loggers/eval/dwell_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t pick = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  ips::eval::DwellFileOptions options;
  if (pick & 1) options.columns = (pick & 2) ? "tag,start,end,x,y,z" : "start,end,-,x,y";
  if (pick & 4) options.time_unit = static_cast<ips::table::TimeUnit>((pick >> 3) & 3);
  if (pick & 32) options.unit = ips::table::parse_unit("cm", ips::table::Quantity::kLength);
  if (pick & 64) options.separator = (pick & 128) ? ';' : ' ';
  const auto f = ips::eval::read_dwell_file(text, "fuzz.csv", options);
  for (const auto& d : f.intervals)
    if (d.end < d.start || !ips::plausible_utime(d.start) || !std::isfinite(d.x) ||
        !std::isfinite(d.y) || std::isinf(d.z))
      std::abort();
  for (char c : f.error)
    if (c < 0x20 || c > 0x7e) std::abort();
  return 0;
}
