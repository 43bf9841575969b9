// libFuzzer: ips-import tdoa's row reader (read_tdoa) on arbitrary text: by the header's names (the
// UTIL layout), by --columns (with sigma, quality, seq and tag columns), with --tag or a rate.
// Never a crash; every difference is valid (finite, within +-1000 m, two different valid anchor
// ids, a valid tag, sigma NaN or in (0, 100] m, quality NaN or 0..1, a plausible time), every
// error and reason printable.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/device_text.hpp"
#include "core/time.hpp"
#include "drivers/import/tdoa_rows.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t mode = data[0];
  const std::string_view text(reinterpret_cast<const char*>(data + 1), size - 1);
  ips::import::TdoaOptions o;
  static const char* const kColumns[] = {"", "t,a,b,diff", "t,tag,a,b,diff,sigma",
                                         "t,a,b,diff,sigma,quality,seq", "-,t,b,a,diff"};
  o.columns = kColumns[mode % 5];
  if (mode & 0x08) o.tag = "T1";
  if (mode & 0x10) o.time.rate_hz = 100;
  if (mode & 0x20) o.unit = *ips::table::parse_unit("cm", ips::table::Quantity::kLength);
  if (mode & 0x40) o.read.header = ips::table::HeaderMode::kNone;
  const ips::import::TdoaFile f = ips::import::read_tdoa(text, "fuzz.csv", o);
  if (!ips::printable_ascii(f.error) || !ips::printable_ascii(f.tally.first_bad_reason)) std::abort();
  for (const auto& m : f.pairs) {
    if (!std::isfinite(m.diff_m) || std::fabs(m.diff_m) > ips::import::kMaxTdoaM) std::abort();
    if (!ips::valid_device_id(m.tag_id) || !ips::valid_device_id(m.anchor_a) ||
        !ips::valid_device_id(m.anchor_b) || m.anchor_a == m.anchor_b)
      std::abort();
    if (!(std::isnan(m.sigma_m) || (m.sigma_m > 0 && m.sigma_m <= 100))) std::abort();
    if (!(std::isnan(m.quality) || (m.quality >= 0 && m.quality <= 1))) std::abort();
    if (!ips::plausible_utime(m.utime) || m.seq < 0) std::abort();
  }
  return 0;
}
