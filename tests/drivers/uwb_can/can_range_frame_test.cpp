// The UWB range frame layout (drivers/uwb_can/can_range_frame.hpp, docs/hardware/uwb.md):
// the worked example of the documentation byte for byte, round trips at the edges of every
// field, and the frames the decoder refuses or leaves to other devices.
#include "drivers/uwb_can/can_range_frame.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace ips::uwb_can {
namespace {

CanFrame classic(uint32_t id, std::vector<uint8_t> bytes) {
  CanFrame f;
  f.id = id;
  f.len = static_cast<uint8_t>(bytes.size());
  for (size_t i = 0; i < bytes.size(); ++i) f.data[i] = bytes[i];
  return f;
}

TEST(CanRangeFrame, DecodesTheWorkedExampleOfTheDocumentation) {
  // docs/hardware/uwb.md: anchor 3 (id 0x303), tag 1, 10.206 m, 87 %, seq 200.
  const auto d =
      decode_range_frame(classic(0x303, {0x01, 0x00, 0xDE, 0x27, 0x00, 0x00, 0x57, 0xC8}), {});
  ASSERT_EQ(d.what, FrameClass::kRange) << d.reason;
  EXPECT_EQ(d.record.anchor_number, 3);
  EXPECT_EQ(d.record.tag_number, 1);
  EXPECT_EQ(d.record.range_mm, 10206u);
  EXPECT_EQ(d.record.quality, 87);
  EXPECT_EQ(d.record.seq, 200);
}

TEST(CanRangeFrame, EncodesTheWorkedExampleOfTheDocumentation) {
  const auto e = encode_range_frame(
      {.anchor_number = 3, .tag_number = 1, .range_mm = 10206, .quality = 87, .seq = 200}, {});
  ASSERT_TRUE(e.ok) << e.reason;
  EXPECT_EQ(e.frame.id, 0x303u);
  EXPECT_FALSE(e.frame.extended || e.frame.remote || e.frame.error || e.frame.fd);
  ASSERT_EQ(e.frame.len, 8);
  const std::vector<uint8_t> want{0x01, 0x00, 0xDE, 0x27, 0x00, 0x00, 0x57, 0xC8};
  EXPECT_EQ(std::vector<uint8_t>(e.frame.data.begin(), e.frame.data.begin() + 8), want);
}

TEST(CanRangeFrame, RoundTripsEveryFieldAtItsEdges) {
  const RangeFrameLayout layout{.base_id = 0x700, .anchor_count = 256};  // ids 0x700..0x7FF
  for (int anchor : {0, 1, 127, 255})
    for (int tag : {0, 1, 9, 10, 99, 255, 256, 4095, 9999, 65535})
      for (uint32_t mm : {0u, 1u, 999u, 65535u, 65536u, 16777216u, 4294967295u})
        for (int quality : {0, 1, 100, 255})
          for (int seq : {0, 128, 255})
            for (bool fd : {false, true}) {
              const RangeRecord r{static_cast<uint16_t>(anchor), static_cast<uint16_t>(tag), mm,
                                  static_cast<uint8_t>(quality), static_cast<uint8_t>(seq)};
              const auto e = encode_range_frame(r, layout, fd);
              ASSERT_TRUE(e.ok) << e.reason;
              EXPECT_EQ(e.frame.id, 0x700u + static_cast<uint32_t>(anchor));
              EXPECT_EQ(e.frame.fd, fd);
              const auto d = decode_range_frame(e.frame, layout);
              ASSERT_EQ(d.what, FrameClass::kRange) << d.reason;
              EXPECT_EQ(d.record, r);
            }
}

TEST(CanRangeFrame, IsLittleEndian) {
  const auto e = encode_range_frame(
      {.anchor_number = 0, .tag_number = 0x1234, .range_mm = 0x89ABCDEF, .quality = 5, .seq = 6},
      {});
  ASSERT_TRUE(e.ok);
  const std::vector<uint8_t> want{0x34, 0x12, 0xEF, 0xCD, 0xAB, 0x89, 5, 6};
  EXPECT_EQ(std::vector<uint8_t>(e.frame.data.begin(), e.frame.data.begin() + 8), want);
}

TEST(CanRangeFrame, RefusesAnchorsWithoutAnIdAndReservedQuality) {
  const RangeFrameLayout layout{.base_id = 0x300, .anchor_count = 4};
  EXPECT_FALSE(encode_range_frame({.anchor_number = 4}, layout).ok);
  EXPECT_TRUE(encode_range_frame({.anchor_number = 3}, layout).ok);
  const auto e = encode_range_frame({.anchor_number = 0, .quality = 101}, layout);
  EXPECT_FALSE(e.ok);
  EXPECT_NE(e.reason.find("quality"), std::string::npos);
}

TEST(CanRangeFrame, LeavesOtherFramesToOtherDevices) {
  const RangeFrameLayout layout{.base_id = 0x300, .anchor_count = 16};
  const std::vector<uint8_t> payload{1, 0, 0xE8, 3, 0, 0, 100, 7};
  EXPECT_EQ(decode_range_frame(classic(0x2FF, payload), layout).what, FrameClass::kNotRange);
  EXPECT_EQ(decode_range_frame(classic(0x310, payload), layout).what, FrameClass::kNotRange);
  EXPECT_EQ(decode_range_frame(classic(0x30F, payload), layout).what, FrameClass::kRange);
  CanFrame ext = classic(0x301, payload);
  ext.extended = true;  // 29-bit id 0x301 is another id than standard 0x301
  EXPECT_EQ(decode_range_frame(ext, layout).what, FrameClass::kNotRange);
  CanFrame remote = classic(0x301, {});
  remote.remote = true;
  remote.len = 8;
  EXPECT_EQ(decode_range_frame(remote, layout).what, FrameClass::kNotRange);
  CanFrame err = classic(0x040, payload);  // bus-off
  err.error = true;
  EXPECT_EQ(decode_range_frame(err, layout).what, FrameClass::kNotRange);
}

TEST(CanRangeFrame, CallsWrongPayloadsOnAnAnchorIdBadWithAReason) {
  const RangeFrameLayout layout{};
  for (size_t len : {0u, 1u, 7u}) {
    const auto d = decode_range_frame(classic(0x301, std::vector<uint8_t>(len, 0)), layout);
    EXPECT_EQ(d.what, FrameClass::kBad);
    EXPECT_NE(d.reason.find(std::to_string(len) + " payload bytes"), std::string::npos) << d.reason;
  }
  CanFrame fd12 = classic(0x301, std::vector<uint8_t>(12, 0));
  fd12.fd = true;
  EXPECT_EQ(decode_range_frame(fd12, layout).what, FrameClass::kBad);
  CanFrame dlc15 = classic(0x301, std::vector<uint8_t>(8, 0));
  dlc15.len8_dlc = 15;
  EXPECT_EQ(decode_range_frame(dlc15, layout).what, FrameClass::kBad);
  const auto q = decode_range_frame(classic(0x301, {1, 0, 0, 0, 0, 0, 101, 0}), layout);
  EXPECT_EQ(q.what, FrameClass::kBad);
  EXPECT_NE(q.reason.find("quality byte 101"), std::string::npos) << q.reason;
  EXPECT_EQ(decode_range_frame(classic(0x301, {1, 0, 0, 0, 0, 0, 254, 0}), layout).what,
            FrameClass::kBad);
}

TEST(CanRangeFrame, LayoutCheckKeepsEveryIdStandard) {
  EXPECT_EQ(RangeFrameLayout{}.check(), "");
  EXPECT_EQ((RangeFrameLayout{.base_id = 0, .anchor_count = 2048}.check()), "");
  EXPECT_NE((RangeFrameLayout{.base_id = 0x800, .anchor_count = 1}.check()), "");
  EXPECT_NE((RangeFrameLayout{.base_id = 0x7F0, .anchor_count = 17}.check()), "");
  EXPECT_NE((RangeFrameLayout{.base_id = 0x300, .anchor_count = 0}.check()), "");
}

}  // namespace
}  // namespace ips::uwb_can
