// PANS lec/lep lines: the DWM1001 Firmware API Guide's example session, and bad input (cut lines,
// wrong anchor counts, non-numbers, nan/inf, huge and negative values, ids that are not hex,
// empty POS).
#include "drivers/uwb_serial/pans_parser.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ips::uwb_serial {
namespace {

using Kind = PansParseResult::Kind;

// The API guide's `lec` example (shell section): a tag with four anchors and a position.
constexpr const char* kGuideLec =
    "DIST,4,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,AN2,111C,5.00,0.00,2.25,"
    "3.24,AN3,1150,0.00,0.00,2.25,3.19,POS,2.55,2.01,1.71,98";

TEST(PansParser, ReadsTheApiGuideLecExample) {
  const auto r = parse_pans_line(kGuideLec);
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  ASSERT_EQ(r.line.num_ranges, 4u);
  EXPECT_EQ(r.line.ranges[0].id(), "1151");
  EXPECT_EQ(r.line.ranges[1].id(), "0CA8");
  EXPECT_EQ(r.line.ranges[2].id(), "111C");
  EXPECT_EQ(r.line.ranges[3].id(), "1150");
  EXPECT_DOUBLE_EQ(r.line.ranges[0].range_m, 6.44);
  EXPECT_DOUBLE_EQ(r.line.ranges[1].range_m, 6.50);
  EXPECT_DOUBLE_EQ(r.line.ranges[2].range_m, 3.24);
  EXPECT_DOUBLE_EQ(r.line.ranges[3].range_m, 3.19);
  EXPECT_DOUBLE_EQ(r.line.ranges[2].anchor_position_m[0], 5.00);
  EXPECT_DOUBLE_EQ(r.line.ranges[2].anchor_position_m[1], 0.00);
  EXPECT_DOUBLE_EQ(r.line.ranges[2].anchor_position_m[2], 2.25);
  ASSERT_TRUE(r.line.position.has_value());
  EXPECT_DOUBLE_EQ(r.line.position->position_m[0], 2.55);
  EXPECT_DOUBLE_EQ(r.line.position->position_m[1], 2.01);
  EXPECT_DOUBLE_EQ(r.line.position->position_m[2], 1.71);
  EXPECT_EQ(r.line.position->quality_percent, 98);
}

TEST(PansParser, ReadsLinesWithoutPositionLepLinesAndNegativeCoordinates) {
  // Location engine off: no POS part.
  auto r = parse_pans_line("DIST,2,AN0,2F2F,3.05,2.68,0.00,2.21,AN1,2c9d,-0.04,2.91,0.00,2.39");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.line.num_ranges, 2u);
  EXPECT_EQ(r.line.ranges[1].id(), "2C9D");  // upper-cased
  EXPECT_DOUBLE_EQ(r.line.ranges[1].anchor_position_m[0], -0.04);
  EXPECT_FALSE(r.line.position.has_value());
  // The API guide's `lep` example.
  r = parse_pans_line("POS,2.57,2.00,1.67,97");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.line.num_ranges, 0u);
  ASSERT_TRUE(r.line.position.has_value());
  EXPECT_DOUBLE_EQ(r.line.position->position_m[2], 1.67);
  EXPECT_EQ(r.line.position->quality_percent, 97);
  // No anchor in reach.
  r = parse_pans_line("DIST,0");
  ASSERT_EQ(r.kind, Kind::kMeasurement) << r.reason;
  EXPECT_EQ(r.line.num_ranges, 0u);
  // Trailing spaces are not part of the qf.
  EXPECT_EQ(parse_pans_line("POS,1.00,2.00,0.50,0  ").kind, Kind::kMeasurement);
}

TEST(PansParser, ThePromptAndEchoedCommandsAreShellText) {
  EXPECT_EQ(parse_pans_line("dwm> ").kind, Kind::kShellText);
  EXPECT_EQ(parse_pans_line("dwm> lec").kind, Kind::kShellText);
}

void expect_error(const std::string& line, const std::string& reason_part) {
  SCOPED_TRACE(line);
  const auto r = parse_pans_line(line);
  EXPECT_EQ(r.kind, Kind::kError);
  EXPECT_NE(r.reason.find(reason_part), std::string::npos) << "reason: " << r.reason;
}

TEST(PansParser, RejectsCutLinesAndWrongAnchorCounts) {
  expect_error("DIST,3,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50,POS,1,2,3,50",
               "says 3 anchors, line has 2");
  expect_error("DIST,3,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50",
               "says 3 anchors, line has 2");
  expect_error("DIST,2,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.0", "and a cut one");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,6.44,AN1,0CA8,0.00,8.00,2.25,6.50",
               "says 1 anchors, more follow");
  expect_error("DIST,2,AN0,1151,5.00,8.00,2.25,6.44,AN2,0CA8,0.00,8.00,2.25,6.50",
               "expected AN1 at field 9");
  expect_error("DIST", "no anchor count");
  expect_error("DIST,", "anchor count '' is not 0..16");
  expect_error("DIST,17", "is not 0..16");
  expect_error("DIST,-1", "is not 0..16");
  expect_error("DIST,x", "is not 0..16");
  expect_error("DIST,0,junk", "unexpected field 'junk'");
  // The interleaved output the shell produces at high update rates (seen in the field).
  expect_error(
      "DIST,4,AN0,0090,0.00,0.00,0.00,3.25,AN1,D91E,0.00,0.00,0.00,3.33,AN2,0487,0.00,"
      "0.00,0.00,0.18,AN3,15BA,0.00,0,AN3,15BA,0.00,0.00,0.00,0.00",
      "AN3: z 'AN3'");
  expect_error(std::string("DIST,16") + std::string(2000, ','), "more than 103 fields");
}

TEST(PansParser, RejectsNonNumbersNanInfHugeAndNegativeValues) {
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,abc", "distance 'abc' is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,nan", "distance 'nan' is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,inf", "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,-inf", "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,1e3", "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,+1.0", "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25, 1.0", "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,", "distance '' is not a number");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,-0.12", "outside 0..1000 m");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,1000.01", "outside 0..1000 m");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25," + std::string(400, '9'), "is not a number");
  expect_error("DIST,1,AN0,1151,5.00,NaN,2.25,1.00", "AN0: y 'NaN' is not a coordinate");
  expect_error("DIST,1,AN0,1151,100000.01,8.00,2.25,1.00", "AN0: x");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2..25,1.00", "AN0: z '2..25'");
  expect_error("POS,1.00,inf,0.50,50", "POS: y 'inf' is not a coordinate");
  expect_error("POS,1.00,2.00,0.50,101", "quality factor '101' is not 0..100");
  expect_error("POS,1.00,2.00,0.50,-1", "quality factor '-1'");
  expect_error("POS,1.00,2.00,0.50,9.5", "quality factor '9.5'");
  // Control bytes from the line never reach the reason.
  const auto r = parse_pans_line("DIST,1,AN0,1151,5.00,8.00,2.25,\x1b[2J");
  ASSERT_EQ(r.kind, Kind::kError);
  EXPECT_EQ(r.reason.find('\x1b'), std::string::npos) << r.reason;
}

TEST(PansParser, RejectsIdsThatAreNotFourHexDigits) {
  expect_error("DIST,1,AN0,11G1,5.00,8.00,2.25,6.44", "id '11G1' is not 4 hex digits");
  expect_error("DIST,1,AN0,151,5.00,8.00,2.25,6.44", "id '151' is not 4 hex digits");
  expect_error("DIST,1,AN0,01151,5.00,8.00,2.25,6.44", "is not 4 hex digits");
  expect_error("DIST,1,AN0,,5.00,8.00,2.25,6.44", "id '' is not 4 hex digits");
  expect_error("DIST,1,AN0,DW12,5.00,8.00,2.25,6.44", "is not 4 hex digits");
}

TEST(PansParser, RejectsEmptyOrShortPos) {
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,6.44,POS",
               "POS: expected x,y,z,qf (4 fields), got 0");
  expect_error("POS", "got 0");
  expect_error("POS,,,,", "POS: x '' is not a coordinate");
  expect_error("POS,1.00,2.00,0.50", "got 3");
  expect_error("POS,1.00,2.00,0.50,50,7", "got 5");
  expect_error("DIST,1,AN0,1151,5.00,8.00,2.25,6.44,POS,1.00,2.00,0.50,", "POS: quality factor ''");
}

TEST(PansParser, RejectsOtherText) {
  expect_error("", "not a PANS lec line");
  expect_error("RANGE T1 A1 2.0",
               "not a PANS lec line (expected DIST, POS or the dwm> prompt, got "
               "'RANGE T1 A1 2.0')");
  expect_error("DWM1001 TWR Real Time Location System", "not a PANS lec line");
  expect_error("@\x01\x01",
               "got '@?"
               "?'");  // split: no trigraph
  EXPECT_TRUE(looks_like_pans_line("DIST,0"));
  EXPECT_TRUE(looks_like_pans_line("POS,1,2,3,4"));
  EXPECT_TRUE(looks_like_pans_line("dwm> "));
  EXPECT_FALSE(looks_like_pans_line("DISTANCE"));
  EXPECT_FALSE(looks_like_pans_line("RANGE T1 A1 1"));
}

}  // namespace
}  // namespace ips::uwb_serial
