#pragma once
// The UWB range frame on CAN (docs/hardware/uwb.md): one two-way-ranging result per frame,
// sent by the anchor that measured it, on its own standard (11-bit) identifier
//   CAN id = base id + anchor number
// with 8 payload bytes, little endian:
//   bytes 0-1  u16 tag number
//   bytes 2-5  u32 range in millimetres
//   byte  6    u8  quality, 0..100 percent (100 best); 255 = the anchor gives none
//   byte  7    u8  sequence number, per anchor, wrapping at 256
// A classic frame has DLC 8; a CAN FD frame carries the same 8 bytes (length 8). The decoder and
// the encoder are pure: no I/O, no exceptions, a reason for every frame they refuse.
#include <cstdint>
#include <string>

#include "drivers/uwb_can/can_frame.hpp"

namespace ips::uwb_can {

inline constexpr uint8_t kRangePayloadBytes = 8;
inline constexpr uint8_t kQualityUnknown = 255;
inline constexpr uint8_t kQualityBest = 100;

// Which identifiers carry range frames: anchors 0..anchor_count-1 on base_id..base_id+count-1.
struct RangeFrameLayout {
  uint32_t base_id = 0x300;
  uint32_t anchor_count = 128;

  // Empty when the layout is usable, else why not (every id must be a standard 11-bit id).
  std::string check() const;
  bool carries(uint32_t id) const { return id >= base_id && id - base_id < anchor_count; }
};

struct RangeRecord {
  uint16_t anchor_number = 0;
  uint16_t tag_number = 0;
  uint32_t range_mm = 0;
  uint8_t quality = kQualityUnknown;
  uint8_t seq = 0;
  bool operator==(const RangeRecord&) const = default;
};

enum class FrameClass {
  kRange,     // a range frame: `record` is filled in
  kNotRange,  // another device's frame, a remote request or an error frame: not for us
  kBad,       // on a range identifier but not the range layout: `reason` says why
};

struct RangeFrameDecode {
  FrameClass what = FrameClass::kBad;
  RangeRecord record;
  std::string reason;  // for kNotRange and kBad
};

RangeFrameDecode decode_range_frame(const CanFrame& frame, const RangeFrameLayout& layout);

struct RangeFrameEncode {
  bool ok = false;
  CanFrame frame;
  std::string reason;  // when !ok
};

// A classic data frame (DLC 8), or a CAN FD frame of length 8 when `fd`. Refuses an anchor
// number the layout has no identifier for, and a quality byte outside 0..100 and not 255.
RangeFrameEncode encode_range_frame(const RangeRecord& record, const RangeFrameLayout& layout,
                                    bool fd = false);

}  // namespace ips::uwb_can
