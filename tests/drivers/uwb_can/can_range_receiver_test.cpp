// From frames to uwb_range_t and back (drivers/uwb_can/range_naming.hpp,
// can_range_receiver.hpp; core/replay_pacer.hpp): ids and numbers, units, what is counted for bad
// input, error frames and other devices, and the pacing of replayed frames.
#include "drivers/uwb_can/can_range_receiver.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/replay_pacer.hpp"
#include "drivers/uwb_can/range_naming.hpp"

namespace ips::uwb_can {
namespace {

TEST(RangeNaming, NamesNumbersWithThePrefixUnlessMapped) {
  IdNumbering anchors("anchor", "A", 127);
  EXPECT_EQ(anchors.name(0), "A0");
  EXPECT_EQ(anchors.name(3), "A3");
  ASSERT_EQ(anchors.add("5=hall-east"), "");
  EXPECT_EQ(anchors.check(), "");
  EXPECT_EQ(anchors.name(5), "hall-east");
  EXPECT_EQ(anchors.number("hall-east"), 5u);
  EXPECT_EQ(anchors.number("A3"), 3u);
  EXPECT_EQ(anchors.number("A5"), std::nullopt) << "anchor 5 goes by its mapped id";
  EXPECT_EQ(anchors.number("A03"), std::nullopt) << "only the names the forward direction makes";
  EXPECT_EQ(anchors.number("A128"), std::nullopt);
  EXPECT_EQ(anchors.number("A"), std::nullopt);
  EXPECT_EQ(anchors.number("B3"), std::nullopt);
  EXPECT_EQ(anchors.number("A-1"), std::nullopt);
}

TEST(RangeNaming, RefusesBadAndAmbiguousMappings) {
  IdNumbering tags("tag", "T", 0xFFFF);
  EXPECT_NE(tags.add("T1"), "");
  EXPECT_NE(tags.add("65536=x"), "");
  EXPECT_NE(tags.add("01=x"), "");
  EXPECT_NE(tags.add("1="), "");
  EXPECT_NE(tags.add("1=has space"), "");
  EXPECT_EQ(tags.add("1=alice"), "");
  EXPECT_NE(tags.add("1=bob"), "");
  EXPECT_NE(tags.add("2=alice"), "");
  EXPECT_EQ(tags.add("7=T3"), "");
  EXPECT_NE(tags.check(), "") << "T3 would name both 7 and 3";
  EXPECT_EQ(tags.add("3=carol"), "");
  EXPECT_EQ(tags.check(), "");
}

RangeIds lab_ids() {
  return RangeIds{IdNumbering("tag", "T", 0xFFFF), IdNumbering("anchor", "A", 127)};
}

TEST(RangeNaming, ConvertsUnitsBothWays) {
  const RangeRecord r{
      .anchor_number = 3, .tag_number = 1, .range_mm = 10206, .quality = 87, .seq = 200};
  const uwb_range_t m = range_message(r, lab_ids(), 1767225600051000, "ips-uwb-can:can0");
  EXPECT_EQ(m.utime, 1767225600051000);
  EXPECT_EQ(m.tag_id, "T1");
  EXPECT_EQ(m.anchor_id, "A3");
  EXPECT_DOUBLE_EQ(m.range_m, 10.206);
  EXPECT_FLOAT_EQ(m.quality, 0.87f);
  EXPECT_EQ(m.seq, 200);
  EXPECT_TRUE(std::isnan(m.rx_power_dbm) && std::isnan(m.fp_power_dbm));
  const auto back = range_record(m, lab_ids());
  ASSERT_TRUE(back.ok) << back.reason;
  EXPECT_EQ(back.record, r);
  EXPECT_TRUE(std::isnan(range_message({.quality = kQualityUnknown}, lab_ids(), 1, "s").quality));
}

TEST(RangeNaming, RoundsToMillimetresAndWrapsSeq) {
  uwb_range_t m;
  m.tag_id = "T65535";
  m.anchor_id = "A127";
  m.range_m = 2.0004999;
  m.quality = std::nanf("");
  m.seq = 1000;
  auto r = range_record(m, lab_ids());
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.record.range_mm, 2000u);
  EXPECT_EQ(r.record.tag_number, 65535);
  EXPECT_EQ(r.record.anchor_number, 127);
  EXPECT_EQ(r.record.quality, kQualityUnknown);
  EXPECT_EQ(r.record.seq, 1000 % 256);
  m.range_m = 2.0005;
  m.seq = -1;  // unknown
  r = range_record(m, lab_ids());
  EXPECT_EQ(r.record.range_mm, 2001u);
  EXPECT_EQ(r.record.seq, 255);
  m.range_m = 0;
  EXPECT_EQ(range_record(m, lab_ids()).record.range_mm, 0u);
  m.range_m = 4294967.295;
  EXPECT_EQ(range_record(m, lab_ids()).record.range_mm, 4294967295u);
}

TEST(RangeNaming, RefusesWhatTheFrameCannotCarry) {
  uwb_range_t m;
  m.tag_id = "T1";
  m.anchor_id = "A1";
  m.range_m = 1;
  m.quality = 0.5f;
  EXPECT_TRUE(range_record(m, lab_ids()).ok);
  for (double bad : {-0.001, 4294967.296, std::nan(""), HUGE_VAL}) {
    m.range_m = bad;
    EXPECT_FALSE(range_record(m, lab_ids()).ok) << bad;
  }
  m.range_m = 1;
  m.quality = 1.5f;
  EXPECT_FALSE(range_record(m, lab_ids()).ok);
  m.quality = 0.5f;
  m.anchor_id = "A128";
  EXPECT_NE(range_record(m, lab_ids()).reason.find("has no anchor number"), std::string::npos);
  m.anchor_id = "A1";
  m.tag_id = "alice";
  EXPECT_NE(range_record(m, lab_ids()).reason.find("--tag-id N=alice"), std::string::npos);
}

struct Received {
  std::vector<uwb_range_t> ranges;
  std::vector<std::string> bad, errors;
  int64_t lost = 0;
};

CanRangeReceiver receiver(Received& got) {
  CanRangeReceiver::Sink sink;
  sink.range = [&got](const uwb_range_t& m) { got.ranges.push_back(m); };
  sink.bad_input = [&got](const std::string& r) { got.bad.push_back(r); };
  sink.error_frame = [&got](const std::string& r) { got.errors.push_back(r); };
  sink.lost = [&got](int64_t n, const std::string&) { got.lost += n; };
  return CanRangeReceiver(RangeFrameLayout{}, lab_ids(), std::move(sink));
}

TEST(CanRangeReceiver, PublishesRangesAndCountsEverythingElse) {
  Received got;
  CanRangeReceiver rx = receiver(got);
  const char* lines[] = {
      "(1767225600.051000) can0 303#0100DE27000057C8",       // range
      "(1767225600.052000) can0 123#DEADBEEF",               // another device
      "(1767225600.053000) can0 00000301#0100DE27000057C8",  // extended: another device
      "(1767225600.054000) can0 301#R",                      // remote request
      "(1767225600.055000) can0 302#0100",                   // bad: 2 bytes
      "(1767225600.056000) can0 302#0100DE2700006500",       // bad: quality 101
      "(1767225600.057000) can0 20000004#0001000000000000",  // error frame: rx overflow
      "DROPCOUNT: dropped 2 CAN frames on 'can0' socket (total drops 2)",
      "\tcontroller-problem{rx-overflow}",
      "",
      "nonsense",                                    // bad line
      "  can0  304   [8]  01 00 DE 27 00 00 57 C8",  // range without a time
  };
  for (const char* l : lines) rx.on_candump_line(parse_candump_line(l), TimeFrom::kLine, 42);
  ASSERT_EQ(got.ranges.size(), 1u);
  EXPECT_EQ(got.ranges[0].anchor_id, "A3");
  EXPECT_EQ(got.ranges[0].utime, 1767225600051000);
  EXPECT_EQ(got.ranges[0].source, "ips-uwb-can:can0");
  EXPECT_EQ(got.bad.size(), 4u);  // 2-byte frame, quality 101, nonsense, no time
  EXPECT_NE(got.bad.back().find("--time-from host"), std::string::npos) << got.bad.back();
  ASSERT_EQ(got.errors.size(), 1u);
  EXPECT_NE(got.errors[0].find("rx-overflow"), std::string::npos);
  EXPECT_EQ(got.lost, 3);
  const CanRangeStats& s = rx.stats();
  EXPECT_EQ(s.frames, 8);
  EXPECT_EQ(s.ranges, 1);
  EXPECT_EQ(s.bad_input, 4);
  EXPECT_EQ(s.error_frames, 1);
  EXPECT_EQ(s.lost_frames, 3);
  EXPECT_EQ(s.other_frames, 3);
  EXPECT_EQ(s.other_ids.at(0x123), 1);
  EXPECT_EQ(s.other_ids.at(0x301), 1);  // the remote request

  // With host time, the line without a timestamp is a range too, stamped with `now`.
  rx.on_candump_line(parse_candump_line(lines[11]), TimeFrom::kHost, 42);
  ASSERT_EQ(got.ranges.size(), 2u);
  EXPECT_EQ(got.ranges[1].utime, 42);
  EXPECT_EQ(got.ranges[1].anchor_id, "A4");
}

TEST(ReplayPacer, HandsFramesOnAtTheirTimesDividedBySpeed) {
  using namespace std::chrono_literals;
  const auto t0 = ReplayPacer::Clock::time_point{} + 1h;
  ReplayPacer x2(2.0);
  EXPECT_EQ(x2.wait_ms(1'000'000, t0), 0);   // the first frame: at once
  EXPECT_EQ(x2.wait_ms(1'100'000, t0), 50);  // 100 ms later at x2: 50 ms
  EXPECT_EQ(x2.wait_ms(1'100'000, t0 + 50ms), 0);
  EXPECT_EQ(x2.wait_ms(3'000'000, t0 + 50ms), 950);  // 2 s at x2 = 1000 ms after the start
  EXPECT_EQ(x2.wait_ms(1'000'001, t0 + 60ms), 0);    // behind but within kMaxLag: no restart
  EXPECT_EQ(x2.wait_ms(1'300'000, t0 + 60ms), 90);   // so the schedule still holds
  // Behind by more than kMaxLag: the schedule restarts there, no burst to catch up.
  EXPECT_EQ(x2.wait_ms(1'400'000, t0 + 5s), 0);
  EXPECT_EQ(x2.wait_ms(1'500'000, t0 + 5s), 50);
  // Timestamps going backwards restart it too.
  EXPECT_EQ(x2.wait_ms(500'000, t0 + 5s), 0);
  EXPECT_EQ(x2.wait_ms(700'000, t0 + 5s), 100);
  ReplayPacer asap(0);
  EXPECT_EQ(asap.wait_ms(1'000'000, t0), 0);
  EXPECT_EQ(asap.wait_ms(9'000'000, t0), 0);
}

}  // namespace
}  // namespace ips::uwb_can
