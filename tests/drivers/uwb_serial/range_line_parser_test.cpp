// RANGE line protocol (docs/hardware/uwb.md): the spec's examples and bad input.
#include "drivers/uwb_serial/range_line_parser.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ips::uwb_serial {
namespace {

using Kind = RangeLineParseResult::Kind;

TEST(RangeLineParser, ReadsTheSpecExamples) {
  auto r = parse_range_line("RANGE T1 A1 4.527");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.range.tag_id, "T1");
  EXPECT_EQ(r.range.anchor_id, "A1");
  EXPECT_DOUBLE_EQ(r.range.range_m, 4.527);
  EXPECT_TRUE(std::isnan(r.range.rssi_dbm));

  r = parse_range_line("RANGE tag-7 anchor_2.north 12.05 -81.5");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.range.tag_id, "tag-7");
  EXPECT_EQ(r.range.anchor_id, "anchor_2.north");
  EXPECT_DOUBLE_EQ(r.range.range_m, 12.05);
  EXPECT_DOUBLE_EQ(r.range.rssi_dbm, -81.5);

  // Runs of spaces and tabs, trailing blanks.
  r = parse_range_line("RANGE\tT1   1151\t0  -90 \t");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.range.anchor_id, "1151");
  EXPECT_DOUBLE_EQ(r.range.range_m, 0.0);
  EXPECT_DOUBLE_EQ(r.range.rssi_dbm, -90.0);

  EXPECT_EQ(parse_range_line("# fw 1.2.0 build 42").kind, Kind::kComment);
  EXPECT_EQ(parse_range_line("#").kind, Kind::kComment);
}

void expect_error(const std::string& line, const std::string& reason_part) {
  SCOPED_TRACE(line);
  const auto r = parse_range_line(line);
  EXPECT_EQ(r.kind, Kind::kError);
  EXPECT_NE(r.reason.find(reason_part), std::string::npos) << "reason: " << r.reason;
}

TEST(RangeLineParser, RejectsWrongFieldCounts) {
  expect_error("RANGE", "got 0 fields");
  expect_error("RANGE T1 A1", "got 2 fields");
  expect_error("RANGE T1 A1 1.0 -80 7", "more than 5 fields");
  expect_error("range T1 A1 1.0", "not a RANGE line (got 'range')");
  expect_error("RANGES T1 A1 1.0", "not a RANGE line");
  expect_error("   ", "not a RANGE line");
}

TEST(RangeLineParser, RejectsBadNumbers) {
  expect_error("RANGE T1 A1 abc", "range 'abc' is not a number");
  expect_error("RANGE T1 A1 nan", "is not a number");
  expect_error("RANGE T1 A1 inf", "is not a number");
  expect_error("RANGE T1 A1 1e2", "is not a number");
  expect_error("RANGE T1 A1 -0.05", "outside 0..1000 m");
  expect_error("RANGE T1 A1 1000000", "outside 0..1000 m");
  expect_error("RANGE T1 A1 " + std::string(300, '7'), "is not a number");
  expect_error("RANGE T1 A1 1.0 loud", "rssi 'loud'");
  expect_error("RANGE T1 A1 1.0 -250", "rssi '-250'");
  expect_error("RANGE T1 A1 1.0 51", "rssi '51'");
  expect_error("RANGE T1 A1 1.0 NaN", "rssi 'NaN'");
}

TEST(RangeLineParser, RejectsBadIds) {
  expect_error("RANGE T/1 A1 1.0", "tag id 'T/1'");
  expect_error("RANGE T1 A\x01 1.0", "anchor id 'A?'");
  expect_error("RANGE " + std::string(33, 'T') + " A1 1.0", "tag id '" + std::string(24, 'T') + "...'");
  EXPECT_EQ(parse_range_line("RANGE " + std::string(32, 'T') + " A1 1.0").kind, Kind::kMeasurement);
}

TEST(RangeLineParser, LooksLikeRangeLine) {
  EXPECT_TRUE(looks_like_range_line("RANGE T1 A1 1"));
  EXPECT_TRUE(looks_like_range_line("RANGE\tT1"));
  EXPECT_TRUE(looks_like_range_line("RANGE"));
  EXPECT_TRUE(looks_like_range_line("# comment"));
  EXPECT_FALSE(looks_like_range_line("RANGES"));
  EXPECT_FALSE(looks_like_range_line("DIST,0"));
}

}  // namespace
}  // namespace ips::uwb_serial
