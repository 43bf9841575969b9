// libFuzzer target: arbitrary bytes from an anchor's serial port or a capture file through what
// ips-ble-aoa does with them (LineBuffer -> +UUDF parser, EventDecoder in auto mode with a
// rename, AtEnabler; capture-line parser, CaptureDecoder). Checks that nothing crashes or
// throws, that every accepted event is within its documented limits (ids of the alphabet,
// finite angles within -90..90 after conversion, RSSI -128..20, channel 0..39, uptime >= 0, seq
// -1 or the counter), that every error has a printable reason, and that the decoder publishes
// exactly once per kPublished outcome.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/line_buffer.hpp"
#include "drivers/ble_aoa/at_enabler.hpp"
#include "drivers/ble_aoa/capture_decoder.hpp"
#include "drivers/ble_aoa/event_decoder.hpp"
#include "drivers/ble_aoa/uudf_parser.hpp"

namespace {

using namespace ips::ble_aoa;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

bool printable_reason(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

void check_message(const ips::ble_aoa_t& m) {
  check(valid_id(m.tag_id), "tag id outside the alphabet");
  check(valid_id(m.anchor_id), "anchor id outside the alphabet");
  for (float a : {m.azimuth_deg, m.elevation_deg})
    check(std::isfinite(a) && a >= -90.0f && a <= 90.0f, "angle outside -90..90");
  check(std::isfinite(m.rssi_dbm) && m.rssi_dbm >= -128.0f && m.rssi_dbm <= 20.0f, "RSSI");
  check(m.channel >= 0 && m.channel <= 39, "channel");
  check(m.anchor_uptime_ms >= 0, "uptime");
  check(m.seq >= -1, "seq");
  check(m.user_string.size() <= kMaxUserStringLength, "user string");
}

void check_outcome(const LineOutcome& out) {
  if (out.kind == LineOutcome::Kind::kError) check(printable_reason(out.reason), "bad reason");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  int64_t published = 0, sunk = 0;
  EventDecoderConfig config;
  config.source = "ips-ble-aoa:fuzz";
  config.angle_range = AngleRange::kAuto;
  config.anchor_names = {{"6C1DEBA09862", "A1"}};
  EventDecoder decoder(config, [&](const ips::ble_aoa_t& m) {
    check_message(m);
    ++sunk;
  });
  CaptureDecoder capture(
      "ips-ble-aoa", config, [](const CivilTime& t) { return utime_from_civil(t, 3600); },
      [&](const ips::ble_aoa_t& m) {
        check_message(m);
        check(m.utime > 0, "capture utime");
        ++sunk;
      });
  AtEnabler at(AtEnabler::commands_with({"AT+UDFCFG=1,50"}));
  at.on_open(0);
  double now = 0;
  ips::LineBuffer lines(256);
  int64_t utime = 1;
  lines.feed(bytes, [&](std::string_view line) {
    const UudfParseResult p = parse_uudf_line(line);
    if (p.kind == UudfParseResult::Kind::kError) check(printable_reason(p.reason), "parser reason");
    const LineOutcome out = decoder.decode(line, utime++);
    check_outcome(out);
    if (out.kind == LineOutcome::Kind::kPublished) ++published;
    if (out.kind == LineOutcome::Kind::kAtLine) at.on_line(out.at, line, now);
    now += 0.3;
    at.poll(now);
    const CaptureParseResult c = parse_capture_line(line);
    if (!c.ok) check(printable_reason(c.reason), "capture reason");
    const LineOutcome cout = capture.decode(line);
    check_outcome(cout);
    if (cout.kind == LineOutcome::Kind::kPublished) ++published;
  });
  check(published == sunk, "published and sunk differ");
  return 0;
}
