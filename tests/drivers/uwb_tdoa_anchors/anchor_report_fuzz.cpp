// libFuzzer target: arbitrary bytes as a stream of anchor report records
// (drivers/uwb_tdoa_anchors/anchor_report_parser.hpp), split as ips-uwb-tdoa-anchors splits a TCP
// stream and a UDP datagram (record_splitter.hpp). Checks that a refused record has a printable
// reason, that an accepted one holds only what the format allows (4-hex ids, a 40-bit counter,
// seq 0..999999, finite values, 'E' only for a sync naming itself), and that encoding it and
// parsing that back gives the same message; the DW1000 receive power is never infinite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string_view>

#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"
#include "drivers/uwb_tdoa_anchors/record_splitter.hpp"

namespace {

using namespace ips::uwb_tdoa_anchors;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

void check_record(std::string_view text) {
  const AnchorReportParse p = parse_anchor_report(text);
  if (!p.ok) {
    check(!p.reason.empty(), "a refused record without a reason");
    for (char c : p.reason) check(c >= 0x20 && c <= 0x7E, "reason not printable");
    return;
  }
  const AnchorReport& r = p.report;
  check(is_wire_id(r.anchor_id) && is_wire_id(r.sender_id), "ids");
  check(r.rx_counter >= 0 && r.rx_counter < kCounterModulus, "counter range");
  check(r.seq() >= 0 && r.seq() < kSeqModulus, "seq range");
  check(std::isfinite(r.temperature_c), "temperature");
  check(r.diagnostic_count == 0 || r.diagnostic_count == kDiagnosticCount, "diagnostic count");
  for (size_t i = 0; i < r.diagnostic_count; ++i)
    check(std::isfinite(r.diagnostics[i]), "diagnostic");
  check((r.anchor_id == r.sender_id) == r.transmit, "'E' iff the record names itself");
  check(!r.transmit || r.is_sync, "'E' of a blink");

  for (PowerModel model : {PowerModel::kDw1000Prf16, PowerModel::kDw1000Prf64}) {
    const ReceivePower pw = receive_power(r, model);
    for (float v : {pw.rx_power_dbm, pw.fp_power_dbm}) check(!std::isinf(v), "infinite power");
    check(r.diagnostic_count > 0 || std::isnan(pw.rx_power_dbm), "power without diagnostics");
  }
  const ips::uwb_rx_t m = to_uwb_rx(r, 1767225600000000, "fuzz", r.anchor_id, r.sender_id);
  check(m.counter_hz == kCounterHz && std::isnan(m.rx_power_dbm), "message");
  const AnchorReportEncode e =
      encode_anchor_report(m, std::fabs(r.temperature_c) <= 100 ? r.temperature_c : 25.0);
  check(e.ok, "an accepted record cannot be encoded");
  const AnchorReportParse back = parse_anchor_report(e.record);
  check(back.ok, "the encoded record does not parse");
  const AnchorReport& b = back.report;
  check(b.anchor_id == r.anchor_id && b.sender_id == r.sender_id && b.is_sync == r.is_sync &&
            b.transmit == r.transmit && b.seq() == r.seq() && b.rx_counter == r.rx_counter,
        "round trip changed the record");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  RecordSplitter stream;
  stream.feed(bytes, [](std::string_view r) {
    check(r.size() <= kMaxRecordBytes, "record longer than the limit");
    check_record(r);
  });
  stream.finish(check_record);
  RecordSplitter datagram;
  datagram.feed_datagram(bytes, check_record);
  // The whole input as one record: the parser's own length limit and blank handling.
  check_record(bytes);
  return 0;
}
