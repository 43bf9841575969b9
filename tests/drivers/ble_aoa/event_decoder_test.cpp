// The event decoder (drivers/ble_aoa/event_decoder.hpp): +UUDF lines to exact ble_aoa_t, the
// 0..180 deg range of older firmware (theta = raw - 90, our documented assumption; source 000
// section 1), --angle-range auto, duplicates with and without a counter, anchor renames.
#include "drivers/ble_aoa/event_decoder.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::ble_aoa {
namespace {

using Kind = LineOutcome::Kind;

struct Fixture {
  explicit Fixture(EventDecoderConfig c = {})
      : decoder(with_source(std::move(c)), [this](const ble_aoa_t& m) { out.push_back(m); }) {}
  static EventDecoderConfig with_source(EventDecoderConfig c) {
    c.source = "ips-ble-aoa:/dev/ttyACM0";
    return c;
  }
  std::vector<ble_aoa_t> out;
  EventDecoder decoder;
};

constexpr const char* kEvent =
    "+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,25";

TEST(EventDecoder, PublishesTheSourceEventExactly) {
  Fixture f;
  EXPECT_EQ(f.decoder.decode(kEvent, 1702374626643000).kind, Kind::kPublished);
  ASSERT_EQ(f.out.size(), 1u);
  const ble_aoa_t& m = f.out[0];
  EXPECT_EQ(m.utime, 1702374626643000);
  EXPECT_EQ(m.source, "ips-ble-aoa:/dev/ttyACM0");
  EXPECT_EQ(m.anchor_id, "6C1DEBA09862");
  EXPECT_EQ(m.tag_id, "6C1DEBA5F60C");
  EXPECT_EQ(m.azimuth_deg, -30.0f);
  EXPECT_EQ(m.elevation_deg, 42.0f);
  EXPECT_EQ(m.rssi_dbm, -68.0f);
  EXPECT_EQ(m.channel, 37);
  EXPECT_EQ(m.anchor_uptime_ms, 1606101);
  EXPECT_EQ(m.seq, 25);
  EXPECT_EQ(m.user_string, "");
}

TEST(EventDecoder, GivesSeqMinusOneWithoutACounterAndKeepsTheUserStringRaw) {
  Fixture f;
  f.decoder.decode("+UUDF:CCF9578E0D8A,-42,20,0,-43,38,\"CCF9578E0D89\",\"\x1b[2J\",15869", 5);
  ASSERT_EQ(f.out.size(), 1u);
  EXPECT_EQ(f.out[0].seq, -1);
  EXPECT_EQ(f.out[0].user_string, "\x1b[2J");
}

TEST(EventDecoder, ConvertsTheLegacyRangeWithTheConfiguredOffset) {
  EventDecoderConfig c;
  c.angle_range = AngleRange::kZeroTo180;
  Fixture f(c);
  f.decoder.decode("+UUDF:T1,-70,150,95,0,39,\"A\",\"\",100", 1);
  f.decoder.decode("+UUDF:T1,-70,0,90,0,39,\"A\",\"\",200", 2);
  const auto neg = f.decoder.decode("+UUDF:T1,-70,-10,90,0,39,\"A\",\"\",300", 3);
  EXPECT_EQ(neg.kind, Kind::kError);
  EXPECT_EQ(neg.reason, "+UUDF: negative angle from an anchor giving 0..180 deg (--angle-range)");
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.out[0].azimuth_deg, 60.0f);
  EXPECT_EQ(f.out[0].elevation_deg, 5.0f);
  EXPECT_EQ(f.out[1].azimuth_deg, -90.0f);
  EXPECT_EQ(f.out[1].elevation_deg, 0.0f);

  c.legacy_offset_deg = 85;
  Fixture g(c);
  g.decoder.decode("+UUDF:T1,-70,150,95,0,39,\"A\",\"\",100", 1);
  ASSERT_EQ(g.out.size(), 1u);
  EXPECT_EQ(g.out[0].azimuth_deg, 65.0f);
  EXPECT_EQ(g.out[0].elevation_deg, 10.0f);
}

TEST(EventDecoder, RefusesLegacyAnglesInThePlusMinus90Range) {
  Fixture f;
  const auto r = f.decoder.decode("+UUDF:T1,-70,150,5,0,39,\"A\",\"\",100", 1);
  EXPECT_EQ(r.kind, Kind::kError);
  EXPECT_EQ(r.reason,
            "+UUDF: angle above 90 deg from an anchor giving -90..90 deg (--angle-range)");
  EXPECT_TRUE(f.out.empty());
}

TEST(EventDecoder, AutoDecidesPerAnchorFromWhatItSends) {
  EventDecoderConfig c;
  c.angle_range = AngleRange::kAuto;
  Fixture f(c);
  // L (legacy, nine fields): 45/80 fits both ranges: dropped until an angle above 90 comes.
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,45,80,0,37,\"L\",\"\",100", 1).kind,
            Kind::kRangeUnknown);
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,120,95,0,38,\"L\",\"\",200", 2).kind, Kind::kPublished);
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,45,80,0,39,\"L\",\"\",300", 3).kind, Kind::kPublished);
  // N (nine fields, a negative angle): -90..90 from then on.
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,-5,10,0,37,\"N\",\"\",100", 4).kind, Kind::kPublished);
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,45,80,0,38,\"N\",\"\",200", 5).kind, Kind::kPublished);
  // C (ten fields: newest firmware): -90..90 at once.
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,45,80,0,37,\"C\",\"\",100,1", 6).kind, Kind::kPublished);
  ASSERT_EQ(f.out.size(), 5u);
  EXPECT_EQ(f.out[0].azimuth_deg, 30.0f);
  EXPECT_EQ(f.out[0].elevation_deg, 5.0f);
  EXPECT_EQ(f.out[1].azimuth_deg, -45.0f);
  EXPECT_EQ(f.out[1].elevation_deg, -10.0f);
  EXPECT_EQ(f.out[2].azimuth_deg, -5.0f);
  EXPECT_EQ(f.out[3].azimuth_deg, 45.0f);
  EXPECT_EQ(f.out[4].azimuth_deg, 45.0f);
  EXPECT_EQ(f.decoder.stats().range_unknown, 1);
}

TEST(EventDecoder, DropsARepeatedCounterOfTheSameAnchorAndTag) {
  Fixture f;
  EXPECT_EQ(f.decoder.decode(kEvent, 1).kind, Kind::kPublished);
  EXPECT_EQ(f.decoder.decode(kEvent, 60'000'000).kind, Kind::kDuplicate);  // any time later
  // Another tag, another anchor, another counter: not duplicates.
  EXPECT_EQ(
      f.decoder.decode("+UUDF:6C1DEBA5F60D,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,25", 2)
          .kind,
      Kind::kPublished);
  EXPECT_EQ(
      f.decoder.decode("+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09863\",\"\",1606101,25", 3)
          .kind,
      Kind::kPublished);
  EXPECT_EQ(
      f.decoder.decode("+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09862\",\"\",1606101,26", 4)
          .kind,
      Kind::kPublished);
  // The same counter with other values (multipath: a late copy of one advertisement).
  EXPECT_EQ(
      f.decoder.decode("+UUDF:6C1DEBA5F60C,-75,12,3,0,38,\"6C1DEBA09862\",\"\",1606120,26", 5).kind,
      Kind::kDuplicate);
  EXPECT_EQ(f.out.size(), 4u);
  EXPECT_EQ(f.decoder.stats().duplicates, 2);
}

TEST(EventDecoder, DropsIdenticalCounterlessEventsOnlyWithinTheWindow) {
  Fixture f;  // window 0.5 s
  const char* e = "+UUDF:T1,-70,12,3,-71,37,\"A\",\"u\",5000";
  EXPECT_EQ(f.decoder.decode(e, 1'000'000).kind, Kind::kPublished);
  EXPECT_EQ(f.decoder.decode(e, 1'500'000).kind, Kind::kDuplicate);
  EXPECT_EQ(f.decoder.decode(e, 2'000'001).kind, Kind::kPublished);  // 1.000001 s after the first
  // One field differs (RSSI; channel; user string): a different event.
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-69,12,3,-71,37,\"A\",\"u\",5000", 2'000'002).kind,
            Kind::kPublished);
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,12,3,-71,38,\"A\",\"u\",5000", 2'000'003).kind,
            Kind::kPublished);
  EXPECT_EQ(f.decoder.decode("+UUDF:T1,-70,12,3,-71,37,\"A\",\"v\",5000", 2'000'004).kind,
            Kind::kPublished);
  EXPECT_EQ(f.out.size(), 5u);
}

TEST(EventDecoder, RenamesAnchorsByTheirHardwareId) {
  EventDecoderConfig c;
  c.anchor_names = {{"6C1DEBA09862", "A1"}};
  Fixture f(c);
  f.decoder.decode(kEvent, 1);
  f.decoder.decode("+UUDF:6C1DEBA5F60C,-68,-30,42,0,37,\"6C1DEBA09863\",\"\",1606101,25", 2);
  ASSERT_EQ(f.out.size(), 2u);
  EXPECT_EQ(f.out[0].anchor_id, "A1");
  EXPECT_EQ(f.out[1].anchor_id, "6C1DEBA09863");
}

TEST(EventDecoder, CountsEveryOutcome) {
  Fixture f;
  f.decoder.decode(kEvent, 1);
  f.decoder.decode(kEvent, 2);
  f.decoder.decode("OK", 3);
  f.decoder.decode("garbage", 4);
  const auto& s = f.decoder.stats();
  EXPECT_EQ(s.lines, 4);
  EXPECT_EQ(s.published, 1);
  EXPECT_EQ(s.duplicates, 1);
  EXPECT_EQ(s.at_lines, 1);
  EXPECT_EQ(s.errors, 1);
}

TEST(EventDecoder, NamesTheAngleRanges) {
  EXPECT_EQ(angle_range_from_name("pm90"), AngleRange::kPlusMinus90);
  EXPECT_EQ(angle_range_from_name("0-180"), AngleRange::kZeroTo180);
  EXPECT_EQ(angle_range_from_name("auto"), AngleRange::kAuto);
  EXPECT_FALSE(angle_range_from_name("0..180").has_value());
}

}  // namespace
}  // namespace ips::ble_aoa
