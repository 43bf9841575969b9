// libFuzzer target: arbitrary bytes as candump text (drivers/uwb_can/candump_parser.hpp), line
// by line through core/line_buffer.hpp and the receiver, as ips-uwb-can reads a candump log.
// Checks that a frame read is a valid CAN frame (id range, lengths), that formatting it as a
// `candump -L` line and reading that back gives the same frame, time and interface, and that a
// refused line has a printable reason.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "core/line_buffer.hpp"
#include "drivers/uwb_can/can_range_receiver.hpp"
#include "drivers/uwb_can/candump_parser.hpp"

namespace {

using namespace ips::uwb_can;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

void check_line(std::string_view text, CanRangeReceiver& rx) {
  const CandumpLine l = parse_candump_line(text);
  if (l.kind == CandumpLineKind::kBad) {
    check(!l.reason.empty(), "a bad line without a reason");
    for (char c : l.reason) check(c >= 0x20 && c <= 0x7E, "reason not printable");
  }
  if (l.kind == CandumpLineKind::kFrame) {
    const CanFrame& f = l.frame;
    check(!l.interface.empty() && l.interface.size() <= 15, "interface name");
    check(f.extended || f.error ? f.id <= kMaxExtendedId : f.id <= kMaxStandardId, "id range");
    check(!(f.error && (f.remote || f.fd || f.extended)), "error frame flags");
    check(!(f.fd && f.remote), "remote CAN FD frame");
    check(f.fd ? valid_fd_len(f.len) : f.len <= kMaxClassicLen, "length");
    check(f.len8_dlc == 0 || (f.len == 8 && f.len8_dlc >= 9 && f.len8_dlc <= 15 && !f.fd),
          "raw DLC");
    check(!l.has_time || ips::plausible_utime(l.utime), "implausible time");
    const ips::utime_t t = l.has_time ? l.utime : 1767225600000000;
    const CandumpLine back = parse_candump_line(format_candump_line(f, t, l.interface));
    check(back.kind == CandumpLineKind::kFrame, "formatted line does not parse");
    check(back.has_time && back.utime == t && back.interface == l.interface, "time/interface");
    const CanFrame& g = back.frame;
    check(g.id == f.id && g.extended == f.extended && g.remote == f.remote && g.error == f.error &&
              g.fd == f.fd && g.fd_flags == f.fd_flags && g.len == f.len &&
              g.len8_dlc == f.len8_dlc,
          "round trip changed the frame");
    if (!f.remote)
      for (size_t i = 0; i < f.len; ++i) check(g.data[i] == f.data[i], "round trip data");
  }
  rx.on_candump_line(l, TimeFrom::kLine, 1);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  int64_t ranges = 0;
  CanRangeReceiver::Sink sink;
  sink.range = [&ranges](const ips::uwb_range_t& m) {
    check(m.range_m >= 0 && m.range_m <= 4294967.295, "range");
    check(ips::plausible_utime(m.utime), "published time");
    ++ranges;
  };
  CanRangeReceiver rx(RangeFrameLayout{},
                      RangeIds{IdNumbering("tag", "T", 0xFFFF), IdNumbering("anchor", "A", 127)},
                      std::move(sink));
  ips::LineBuffer lines(kMaxCandumpLineBytes);
  lines.feed(std::string_view(reinterpret_cast<const char*>(data), size),
             [&](std::string_view line) { check_line(line, rx); });
  const std::string rest = lines.take_partial();
  if (!rest.empty()) check_line(rest, rx);
  // The whole input as one line too: the parser's own length limit and whitespace handling.
  check_line(std::string_view(reinterpret_cast<const char*>(data), size), rx);
  check(rx.stats().ranges == ranges, "range count");
  return 0;
}
