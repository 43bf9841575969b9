// libFuzzer target: arbitrary CAN frames (flags, id, length, payload from the input) through the
// range frame decoder (drivers/uwb_can/can_range_frame.hpp) with an arbitrary valid layout.
// Checks that a frame decoded as a range encodes back to the same id and payload, that the
// message made from it converts back to the same record, and that refusals have reasons.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "drivers/uwb_can/can_range_frame.hpp"
#include "drivers/uwb_can/range_naming.hpp"

namespace {

using namespace ips::uwb_can;

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 9) return 0;
  RangeFrameLayout layout;
  layout.base_id = (data[0] | data[1] << 8) & 0x7FFu;
  layout.anchor_count = 1 + (data[2] | (data[3] & 0x7) << 8);
  if (!layout.check().empty()) layout.anchor_count = kMaxStandardId + 1 - layout.base_id;
  check(layout.check().empty(), "layout");
  CanFrame f;
  const uint8_t flags = data[4];
  f.extended = flags & 1;
  f.remote = flags & 2;
  f.error = flags & 4;
  f.fd = flags & 8;
  f.fd_flags = static_cast<uint8_t>(flags >> 4 & 3);
  uint32_t id;
  std::memcpy(&id, data + 5, 4);
  f.id = id & (f.extended || f.error ? kMaxExtendedId : kMaxStandardId);
  const size_t payload = size - 9;
  const size_t max = f.fd ? kMaxFdLen : kMaxClassicLen;
  f.len = static_cast<uint8_t>(payload > max ? max : payload);
  if (!f.fd && f.len == 8 && (flags & 0xC0))
    f.len8_dlc = static_cast<uint8_t>(8 + (flags >> 6) * 2);
  std::memcpy(f.data.data(), data + 9, f.len);

  const RangeFrameDecode d = decode_range_frame(f, layout);
  if (d.what != FrameClass::kRange) {
    check(!d.reason.empty(), "refusal without a reason");
    return 0;
  }
  check(!f.error && !f.extended && !f.remote && f.len == 8 && f.len8_dlc == 0, "accepted");
  check(layout.carries(f.id) && d.record.anchor_number == f.id - layout.base_id, "anchor");
  const RangeFrameEncode e = encode_range_frame(d.record, layout, f.fd);
  check(e.ok, "a decoded record does not encode");
  check(e.frame.id == f.id && e.frame.len == 8 && e.frame.fd == f.fd, "re-encoded frame");
  check(std::memcmp(e.frame.data.data(), f.data.data(), 8) == 0, "re-encoded payload");

  const RangeIds ids{IdNumbering("tag", "T", 0xFFFF),
                     IdNumbering("anchor", "A", layout.anchor_count - 1)};
  const ips::uwb_range_t m = range_message(d.record, ids, 1767225600000000, "fuzz");
  check(std::isfinite(m.range_m) && m.range_m >= 0, "range_m");
  check(std::isnan(m.quality) || (m.quality >= 0 && m.quality <= 1), "quality");
  const RangeRecordResult back = range_record(m, ids);
  check(back.ok && back.record == d.record, "message does not convert back to the record");
  return 0;
}
