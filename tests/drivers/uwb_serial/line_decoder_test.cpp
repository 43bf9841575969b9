// LineDecoder: lines to uwb_range_t/pose_t with the fields documented in
// docs/hardware/uwb.md (source, ids, NaN for what the device does not give, sequence
// per tag/anchor), format selection, and whole-line rejection.
#include "drivers/uwb_serial/line_decoder.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace ips::uwb_serial {
namespace {

struct Captured {
  std::vector<uwb_range_t> ranges;
  std::vector<pose_t> poses;
};

LineDecoder make(LineFormat format, Captured& c, std::string tag = "1A2B") {
  return LineDecoder(
      {format, std::move(tag), "ips-uwb-serial:/dev/ttyACM0"},
      [&c](const uwb_range_t& m) { c.ranges.push_back(m); },
      [&c](const pose_t& m) { c.poses.push_back(m); });
}

constexpr const char* kGuideLec =
    "DIST,4,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,AN2,111C,5.00,0.00,2.25,"
    "3.24,AN3,1150,0.00,0.00,2.25,3.19,POS,2.55,2.01,1.71,98";

TEST(LineDecoder, PansLecLineGivesOneRangePerAnchorAndTheModulePosition) {
  Captured c;
  auto d = make(LineFormat::kPans, c);
  const auto out = d.decode(kGuideLec, 1767225600123456);
  EXPECT_EQ(out.kind, LineOutcome::Kind::kMeasurement);
  EXPECT_EQ(out.ranges, 4);
  EXPECT_TRUE(out.position);
  ASSERT_EQ(c.ranges.size(), 4u);
  const char* ids[4] = {"1151", "0CA8", "111C", "1150"};
  const double ranges[4] = {6.44, 6.50, 3.24, 3.19};
  for (size_t i = 0; i < 4; ++i) {
    const auto& m = c.ranges[i];
    EXPECT_EQ(m.utime, 1767225600123456);
    EXPECT_EQ(m.source, "ips-uwb-serial:/dev/ttyACM0");
    EXPECT_EQ(m.tag_id, "1A2B");
    EXPECT_EQ(m.anchor_id, ids[i]);
    EXPECT_DOUBLE_EQ(m.range_m, ranges[i]);
    EXPECT_TRUE(std::isnan(m.rx_power_dbm));
    EXPECT_TRUE(std::isnan(m.fp_power_dbm));
    EXPECT_TRUE(std::isnan(m.quality));
    EXPECT_EQ(m.seq, 0);
  }
  ASSERT_EQ(c.poses.size(), 1u);
  const auto& p = c.poses[0];
  EXPECT_EQ(p.utime, 1767225600123456);
  EXPECT_EQ(p.source, "ips-uwb-serial:/dev/ttyACM0");
  EXPECT_EQ(p.tag_id, "1A2B");
  EXPECT_DOUBLE_EQ(p.position[0], 2.55);
  EXPECT_DOUBLE_EQ(p.position[1], 2.01);
  EXPECT_DOUBLE_EQ(p.position[2], 1.71);
  for (double v : p.position_cov) EXPECT_TRUE(std::isnan(v));
  for (double v : p.velocity) EXPECT_TRUE(std::isnan(v));
  EXPECT_TRUE(std::isnan(p.heading_rad));
  EXPECT_TRUE(std::isnan(p.residual_m));
  EXPECT_EQ(p.num_used, 4);
  EXPECT_EQ(p.status, pose_t::STATUS_OK);
}

TEST(LineDecoder, SequenceCountsPerTagAndAnchor) {
  Captured c;
  auto d = make(LineFormat::kAuto, c);
  d.decode("RANGE T1 A1 1.0", 1);
  d.decode("RANGE T1 A2 2.0", 2);
  d.decode("RANGE T1 A1 1.1", 3);
  d.decode("RANGE T2 A1 3.0", 4);
  d.decode("DIST,1,AN0,00A1,0.00,0.00,0.00,5.00", 5);
  d.decode("RANGE T1 A1 1.2", 6);
  d.decode("DIST,1,AN0,00a1,0.00,0.00,0.00,5.10", 7);
  ASSERT_EQ(c.ranges.size(), 7u);
  const int expected[7] = {0, 0, 1, 0, 0, 2, 1};
  for (size_t i = 0; i < 7; ++i) EXPECT_EQ(c.ranges[i].seq, expected[i]) << i;
}

TEST(LineDecoder, SequenceIsUnknownBeyondTheLastTrackedPair) {
  Captured c;
  auto d = make(LineFormat::kRangeLine, c);
  for (size_t i = 0; i < LineDecoder::kMaxSequencedPairs; ++i)
    d.decode("RANGE T A" + std::to_string(i) + " 1.0", 1);
  d.decode("RANGE T B 1.0", 2);
  d.decode("RANGE T A0 1.0", 3);
  ASSERT_EQ(c.ranges.size(), LineDecoder::kMaxSequencedPairs + 2);
  EXPECT_EQ(c.ranges[c.ranges.size() - 2].seq, -1);
  EXPECT_EQ(c.ranges.back().seq, 1);
}

TEST(LineDecoder, RangeLineCarriesItsOwnIdsAndRssi) {
  Captured c;
  auto d = make(LineFormat::kRangeLine, c, "");
  d.decode("RANGE T7 A3 4.25 -78.5", 10);
  d.decode("RANGE T7 A4 5.5", 11);
  ASSERT_EQ(c.ranges.size(), 2u);
  EXPECT_EQ(c.ranges[0].tag_id, "T7");
  EXPECT_EQ(c.ranges[0].anchor_id, "A3");
  EXPECT_DOUBLE_EQ(c.ranges[0].range_m, 4.25);
  EXPECT_FLOAT_EQ(c.ranges[0].rx_power_dbm, -78.5f);
  EXPECT_TRUE(std::isnan(c.ranges[1].rx_power_dbm));
  EXPECT_EQ(c.ranges[1].utime, 11);
  EXPECT_TRUE(c.poses.empty());
}

TEST(LineDecoder, FormatDecidesWhatIsAnError) {
  Captured c;
  auto pans = make(LineFormat::kPans, c);
  EXPECT_EQ(pans.decode("RANGE T1 A1 1.0", 1).kind, LineOutcome::Kind::kError);
  EXPECT_EQ(pans.decode("# comment", 1).kind, LineOutcome::Kind::kError);
  EXPECT_EQ(pans.decode("dwm> ", 1).kind, LineOutcome::Kind::kIgnored);
  auto line = make(LineFormat::kRangeLine, c);
  EXPECT_EQ(line.decode(kGuideLec, 1).kind, LineOutcome::Kind::kError);
  EXPECT_EQ(line.decode("# comment", 1).kind, LineOutcome::Kind::kIgnored);
  auto either = make(LineFormat::kAuto, c);
  EXPECT_EQ(either.decode("RANGE T1 A1 1.0", 1).kind, LineOutcome::Kind::kMeasurement);
  EXPECT_EQ(either.decode(kGuideLec, 1).kind, LineOutcome::Kind::kMeasurement);
  EXPECT_EQ(either.decode("dwm> lec", 1).kind, LineOutcome::Kind::kIgnored);
  const auto bad = either.decode("hello", 1);
  EXPECT_EQ(bad.kind, LineOutcome::Kind::kError);
  EXPECT_EQ(bad.reason, "neither a PANS lec line (DIST,/POS,) nor a RANGE line");
  EXPECT_EQ(either.stats().lines, 4);
  EXPECT_EQ(either.stats().measurement_lines, 2);
  EXPECT_EQ(either.stats().ignored_lines, 1);
  EXPECT_EQ(either.stats().error_lines, 1);
  EXPECT_EQ(either.stats().ranges, 5);
  EXPECT_EQ(either.stats().positions, 1);
}

TEST(LineDecoder, GarbledLinePublishesNothingAtAll) {
  Captured c;
  auto d = make(LineFormat::kPans, c);
  // Three good anchors, then a cut fourth: none of the line's ranges may leak out.
  const auto out = d.decode(
      "DIST,4,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,AN2,111C,5.00,0.00,2.25,"
      "3.24,AN3,1150,0.00",
      1);
  EXPECT_EQ(out.kind, LineOutcome::Kind::kError);
  EXPECT_NE(out.reason.find("says 4 anchors, line has 3"), std::string::npos) << out.reason;
  EXPECT_TRUE(c.ranges.empty());
  EXPECT_TRUE(c.poses.empty());
}

TEST(LineDecoder, PositionWithoutFixIsNotPublished) {
  Captured c;
  auto d = make(LineFormat::kPans, c);
  const auto out = d.decode("DIST,1,AN0,1151,5.00,8.00,2.25,6.44,POS,0.00,0.00,0.00,0", 1);
  EXPECT_EQ(out.kind, LineOutcome::Kind::kMeasurement);
  EXPECT_TRUE(out.position_without_fix);
  EXPECT_FALSE(out.position);
  EXPECT_EQ(c.ranges.size(), 1u);
  EXPECT_TRUE(c.poses.empty());
  EXPECT_EQ(d.stats().positions_without_fix, 1);
}

TEST(LineDecoder, PansLineWithoutTagIdIsAnError) {
  Captured c;
  auto d = make(LineFormat::kAuto, c, "");
  const auto out = d.decode(kGuideLec, 1);
  EXPECT_EQ(out.kind, LineOutcome::Kind::kError);
  EXPECT_NE(out.reason.find("--tag"), std::string::npos);
  EXPECT_TRUE(c.ranges.empty());
}

TEST(LineDecoder, FormatNames) {
  EXPECT_EQ(line_format_from_name("pans"), LineFormat::kPans);
  EXPECT_EQ(line_format_from_name("line"), LineFormat::kRangeLine);
  EXPECT_EQ(line_format_from_name("auto"), LineFormat::kAuto);
  EXPECT_EQ(line_format_from_name("PANS"), std::nullopt);
}

}  // namespace
}  // namespace ips::uwb_serial
