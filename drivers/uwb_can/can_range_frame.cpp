#include "drivers/uwb_can/can_range_frame.hpp"

#include <cstdio>

namespace ips::uwb_can {

namespace {

std::string hex_id(uint32_t id) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%03X", static_cast<unsigned>(id));
  return buf;
}

}  // namespace

std::string RangeFrameLayout::check() const {
  if (base_id > kMaxStandardId)
    return "base id " + hex_id(base_id) + " is not a standard 11-bit id (0x000..0x7FF)";
  if (anchor_count < 1) return "at least one anchor is needed";
  if (anchor_count > kMaxStandardId + 1 - base_id)
    return std::to_string(anchor_count) + " anchors from base id " + hex_id(base_id) +
           " go past 0x7FF (at most " + std::to_string(kMaxStandardId + 1 - base_id) + ")";
  return {};
}

RangeFrameDecode decode_range_frame(const CanFrame& f, const RangeFrameLayout& layout) {
  RangeFrameDecode out;
  if (f.error) {
    out.what = FrameClass::kNotRange;
    out.reason = "error frame";
    return out;
  }
  if (f.extended) {
    out.what = FrameClass::kNotRange;
    out.reason = "extended (29-bit) id";
    return out;
  }
  if (!layout.carries(f.id)) {
    out.what = FrameClass::kNotRange;
    out.reason = "id " + hex_id(f.id) + " is not an anchor's";
    return out;
  }
  if (f.remote) {
    out.what = FrameClass::kNotRange;
    out.reason = "remote request";
    return out;
  }
  out.what = FrameClass::kBad;
  const std::string where = "id " + hex_id(f.id) + ": ";
  if (f.len != kRangePayloadBytes) {
    out.reason = where + std::to_string(f.len) + " payload bytes; a range frame has 8";
    return out;
  }
  if (f.len8_dlc != 0) {
    out.reason = where + "DLC " + std::to_string(f.len8_dlc) + "; a range frame has DLC 8";
    return out;
  }
  const auto& d = f.data;
  RangeRecord r;
  r.anchor_number = static_cast<uint16_t>(f.id - layout.base_id);
  r.tag_number = static_cast<uint16_t>(d[0] | d[1] << 8);
  r.range_mm = static_cast<uint32_t>(d[2]) | static_cast<uint32_t>(d[3]) << 8 |
               static_cast<uint32_t>(d[4]) << 16 | static_cast<uint32_t>(d[5]) << 24;
  r.quality = d[6];
  r.seq = d[7];
  if (r.quality > kQualityBest && r.quality != kQualityUnknown) {
    out.reason =
        where + "quality byte " + std::to_string(r.quality) + " is outside 0..100 (255: unknown)";
    return out;
  }
  out.what = FrameClass::kRange;
  out.record = r;
  return out;
}

RangeFrameEncode encode_range_frame(const RangeRecord& r, const RangeFrameLayout& layout, bool fd) {
  RangeFrameEncode out;
  if (r.anchor_number >= layout.anchor_count || layout.base_id + r.anchor_number > kMaxStandardId) {
    out.reason = "anchor number " + std::to_string(r.anchor_number) + " has no id (anchors 0.." +
                 std::to_string(layout.anchor_count - 1) + " from base id " +
                 hex_id(layout.base_id) + ")";
    return out;
  }
  if (r.quality > kQualityBest && r.quality != kQualityUnknown) {
    out.reason = "quality byte " + std::to_string(r.quality) + " is outside 0..100 (255: unknown)";
    return out;
  }
  CanFrame& f = out.frame;
  f.id = layout.base_id + r.anchor_number;
  f.fd = fd;
  f.len = kRangePayloadBytes;
  f.data[0] = static_cast<uint8_t>(r.tag_number & 0xFF);
  f.data[1] = static_cast<uint8_t>(r.tag_number >> 8);
  for (int i = 0; i < 4; ++i)
    f.data[static_cast<size_t>(2 + i)] = static_cast<uint8_t>(r.range_mm >> (8 * i));
  f.data[6] = r.quality;
  f.data[7] = r.seq;
  out.ok = true;
  return out;
}

}  // namespace ips::uwb_can
