// libFuzzer target: arbitrary bytes from a serial port through what ips-uwb-serial does with them
// (LineBuffer -> PANS lec parser, RANGE line parser, LineDecoder in auto mode). Checks that no
// parser crashes or throws, that every measurement it accepts is within its documented limits
// (finite, ranges 0..1000 m, coordinates within 100 km, qf 0..100, ids of the documented
// alphabet), that every error has a printable reason, and that the decoder publishes exactly the
// ranges and positions its outcomes count, never from a line it rejected.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/line_buffer.hpp"
#include "drivers/uwb_serial/line_decoder.hpp"
#include "drivers/uwb_serial/pans_parser.hpp"
#include "drivers/uwb_serial/range_line_parser.hpp"

namespace {

using namespace ips::uwb_serial;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

bool printable_reason(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

bool upper_hex4(std::string_view id) {
  if (id.size() != 4) return false;
  for (char c : id)
    if (!((c >= '0' && c <= '9') || (c >= 'A' && c <= 'F'))) return false;
  return true;
}

bool range_id(std::string_view id) {
  if (id.empty() || id.size() > kMaxRangeLineIdLength) return false;
  for (char c : id)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '.' || c == ':' || c == '-'))
      return false;
  return true;
}

bool coordinate(double v) { return std::isfinite(v) && std::fabs(v) <= kMaxCoordinateM; }
bool range(double v) { return std::isfinite(v) && v >= 0 && v <= kMaxRangeM; }

void check_pans(std::string_view line) {
  const auto r = parse_pans_line(line);
  if (r.kind == PansParseResult::Kind::kError) {
    check(printable_reason(r.reason), "PANS: error without a printable reason");
    return;
  }
  if (r.kind == PansParseResult::Kind::kShellText) return;
  check(r.line.num_ranges <= kMaxPansAnchors, "PANS: too many ranges");
  check(r.line.num_ranges > 0 || r.line.position || line.starts_with("DIST,"),
        "PANS: a measurement with nothing in it");
  for (size_t i = 0; i < r.line.num_ranges; ++i) {
    const auto& a = r.line.ranges[i];
    check(upper_hex4(a.id()), "PANS: anchor id");
    check(range(a.range_m), "PANS: range");
    for (double v : a.anchor_position_m) check(coordinate(v), "PANS: anchor coordinate");
  }
  if (r.line.position) {
    for (double v : r.line.position->position_m) check(coordinate(v), "PANS: position");
    check(r.line.position->quality_percent >= 0 && r.line.position->quality_percent <= 100,
          "PANS: qf");
  }
}

void check_range_line(std::string_view line) {
  const auto r = parse_range_line(line);
  if (r.kind == RangeLineParseResult::Kind::kError) {
    check(printable_reason(r.reason), "RANGE: error without a printable reason");
    return;
  }
  if (r.kind == RangeLineParseResult::Kind::kComment) {
    check(line.starts_with('#'), "RANGE: comment that is not one");
    return;
  }
  check(range_id(r.range.tag_id) && range_id(r.range.anchor_id), "RANGE: ids");
  check(r.range.tag_id.data() >= line.data() &&
            r.range.anchor_id.data() + r.range.anchor_id.size() <= line.data() + line.size(),
        "RANGE: ids outside the line");
  check(range(r.range.range_m), "RANGE: range");
  check(std::isnan(r.range.rssi_dbm) ||
            (r.range.rssi_dbm >= kMinRssiDbm && r.range.rssi_dbm <= kMaxRssiDbm),
        "RANGE: rssi");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  int64_t published_ranges = 0, published_poses = 0;
  LineDecoder decoder(
      {LineFormat::kAuto, "1A2B", "fuzz"},
      [&](const ips::uwb_range_t& m) {
        ++published_ranges;
        check(range(m.range_m), "decoder: range");
        check(!m.tag_id.empty() && !m.anchor_id.empty(), "decoder: ids");
        check(std::isnan(m.fp_power_dbm) && std::isnan(m.quality), "decoder: NaN fields");
        check(m.seq >= -1, "decoder: seq");
      },
      [&](const ips::pose_t& m) {
        ++published_poses;
        for (double v : m.position) check(coordinate(v), "decoder: position");
      });
  int64_t counted_ranges = 0, counted_poses = 0;
  // A small limit so that the fuzzer reaches overlong lines.
  ips::LineBuffer lines(200);
  lines.feed(bytes, [&](std::string_view line) {
    check(!line.empty() && line.size() <= 200, "line length");
    check(line.find_first_of("\r\n") == std::string_view::npos, "line terminator in a line");
    check_pans(line);
    check_range_line(line);
    const int64_t before_ranges = published_ranges, before_poses = published_poses;
    const auto out = decoder.decode(line, 1);
    if (out.kind != LineOutcome::Kind::kMeasurement) {
      check(published_ranges == before_ranges && published_poses == before_poses,
            "decoder published from a line it did not accept");
    }
    if (out.kind == LineOutcome::Kind::kError) check(printable_reason(out.reason), "reason");
    counted_ranges += out.ranges;
    counted_poses += out.position ? 1 : 0;
  });
  check(counted_ranges == published_ranges && counted_poses == published_poses,
        "published counts differ from the outcomes");
  check(decoder.stats().ranges == published_ranges, "stats");
  return 0;
}
