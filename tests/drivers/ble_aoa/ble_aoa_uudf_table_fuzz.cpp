// libFuzzer target: arbitrary bytes as a file of decoded +UUDF fields through what ips-ble-aoa
// --capture does with it (LineBuffer -> UudfTableDecoder with renames, by header or detected
// layout; the first byte picks a --separator/--columns/--time-unit variant). Checks that nothing
// crashes or throws, that every message is within its documented limits (ids of the alphabet,
// angles -90..90, RSSI -128..20, channel 0..39, a plausible utime), that the tally adds up
// (messages <= rows; the first bad reason printable and set when a row was rejected) and that the
// verdict is one printable line.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/line_buffer.hpp"
#include "core/time.hpp"
#include "drivers/ble_aoa/uudf_table.hpp"

namespace {

using namespace ips::ble_aoa;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

bool printable(const std::string& s) {
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  const uint8_t variant = data[0];
  std::string_view bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  UudfTableOptions options;
  if (variant & 1) options.read.separator = (variant & 2) ? ';' : ',';
  if (variant & 4) options.columns = "t,tag,rssi,azimuth,elevation,rssi2,channel,anchor";
  if (variant & 8) options.columns = "t,uudf";
  if (variant & 16) options.time_unit = ips::table::TimeUnit::kMs;
  if (variant & 32) options.read.header = ips::table::HeaderMode::kNone;
  EventDecoderConfig config;
  config.source = "ips-ble-aoa:fuzz.csv";
  config.anchor_names = {{"6C1DEBA09949", "A1"}};
  config.tag_names = {{"8401", "T1"}};
  if (variant & 64) config.angle_range = AngleRange::kAuto;
  int64_t published = 0;
  UudfTableDecoder decoder(options, config, [&](const ips::ble_aoa_t& m) {
    ++published;
    check(valid_id(m.tag_id) && valid_id(m.anchor_id), "id outside the alphabet");
    for (float a : {m.azimuth_deg, m.elevation_deg})
      check(std::isfinite(a) && a >= -90.0f && a <= 90.0f, "angle outside -90..90");
    check(m.rssi_dbm >= -128.0f && m.rssi_dbm <= 20.0f, "RSSI outside -128..20");
    check(m.channel >= 0 && m.channel <= 39, "channel outside 0..39");
    check(ips::plausible_utime(m.utime), "implausible utime");
    check(m.source == "ips-ble-aoa:fuzz.csv", "source");
  });
  ips::LineBuffer lines;
  lines.feed(bytes, [&](std::string_view line) { decoder.decode(line); });
  const std::string rest = lines.take_partial();
  if (!rest.empty()) decoder.decode(rest);
  const ips::table::ImportTally& t = decoder.tally();
  check(t.messages == published, "messages counted != published");
  check(t.messages <= t.rows, "more messages than rows");
  check(t.bad == 0 || !t.first_bad_reason.empty(), "a rejected row without a reason");
  check(printable(t.first_bad_reason) && printable(t.first_bad_text), "unprintable reason");
  const std::string verdict =
      ips::table::import_verdict(t, decoder.expectation("fuzz.csv"));
  check(printable(verdict), "unprintable verdict");
  check(printable(decoder.columns()), "unprintable columns");
  return 0;
}
