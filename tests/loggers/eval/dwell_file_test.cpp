// The --dwell file: the BLE dataset's ground-truth files as they are, header names, units, ISO
// times, tags, and rows that are rejected and counted.
#include "loggers/eval/dwell_file.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ips::eval {
namespace {

DwellFile read(const std::string& text, DwellFileOptions options = {}) {
  return read_dwell_file(text, "gt.csv", options);
}

TEST(DwellFile, BleDatasetStaticFileInEpochMsAndCm) {
  // The first rows of ble-byongho96/dataset/static/gt/gt_static_east.csv.
  DwellFileOptions options;
  options.unit = table::parse_unit("cm", table::Quantity::kLength);
  const DwellFile f = read(
      "StartTimestamp,EndTimestamp,X,Y\n"
      "1670575951854,1670576018036,120,120\n"
      "1670576022595,1670576087904,240,120\n",
      options);
  ASSERT_TRUE(f.error.empty()) << f.error;
  ASSERT_EQ(f.intervals.size(), 2u);
  EXPECT_EQ(f.intervals[0].start, 1670575951854'000);
  EXPECT_EQ(f.intervals[0].end, 1670576018036'000);
  EXPECT_DOUBLE_EQ(f.intervals[0].x, 1.2);
  EXPECT_DOUBLE_EQ(f.intervals[1].x, 2.4);
  EXPECT_DOUBLE_EQ(f.intervals[1].y, 1.2);
  EXPECT_TRUE(std::isnan(f.intervals[0].z));
  EXPECT_TRUE(f.intervals[0].tag.empty());
  EXPECT_EQ(f.columns, "start,end,x,y");
  EXPECT_EQ(f.time_unit, "ms (guessed)");
  EXPECT_DOUBLE_EQ(f.unit_factor, 0.01);
  EXPECT_EQ(f.tally.rows, 2);
  EXPECT_EQ(f.tally.bad, 0);
}

TEST(DwellFile, Ble0409FilePrefersTheEpochColumnsOverIsoAndReadsZ) {
  // ble-byongho96/dataset/0409/gt/anchor1.csv: ISO columns first, then epoch ms; z in cm.
  DwellFileOptions options;
  options.unit = table::parse_unit("cm", table::Quantity::kLength);
  const DwellFile f = read(
      "StartTimeISO,StartTimestamp,EndTimeISO,EndTimestamp,X,Y,Z\n"
      "2025-04-09T21:59:26.789,1744235966789,2025-04-09T21:59:38.223,1744235978223,0,360,138\n",
      options);
  ASSERT_TRUE(f.error.empty()) << f.error;
  ASSERT_EQ(f.intervals.size(), 1u);
  EXPECT_EQ(f.columns, "-,start,-,end,x,y,z");
  EXPECT_EQ(f.intervals[0].start, 1744235966789'000);
  EXPECT_EQ(f.intervals[0].end, 1744235978223'000);
  EXPECT_DOUBLE_EQ(f.intervals[0].y, 3.6);
  EXPECT_DOUBLE_EQ(f.intervals[0].z, 1.38);
}

TEST(DwellFile, IsoTimesTagsAndUnitsFromTheHeader) {
  const DwellFile f = read(
      "# two points, semicolon-separated\n"
      "Tag;Start;End;X(cm);Y(cm)\n"
      "T1-2;2024-12-18T05:58:05Z;2024-12-18T05:58:35.5Z;100;250\n"
      "T1;2024-12-18T06:00:00+01:00;2024-12-18T06:00:10+01:00;0;50\n");
  ASSERT_TRUE(f.error.empty()) << f.error;
  ASSERT_EQ(f.intervals.size(), 2u);
  EXPECT_EQ(f.intervals[0].tag, "T1-2");
  EXPECT_EQ(f.intervals[0].start, 1734501485'000000);  // date -d 2024-12-18T05:58:05Z +%s
  EXPECT_EQ(f.intervals[0].end, 1734501515'500000);
  EXPECT_DOUBLE_EQ(f.intervals[0].x, 1.0);
  EXPECT_DOUBLE_EQ(f.intervals[0].y, 2.5);
  EXPECT_EQ(f.intervals[1].start, 1734498000'000000);  // 05:00:00Z
  EXPECT_EQ(f.time_unit, "ISO-8601");
}

TEST(DwellFile, PositionalColumnsAndTimeUnitGiven) {
  DwellFileOptions options;
  options.columns = "tag,-,start,end,x,y,z";
  options.time_unit = table::TimeUnit::kS;
  const DwellFile f = read("T7 ignored 1700000000 1700000010.5 1.5 2.5 0.9\n", options);
  ASSERT_TRUE(f.error.empty()) << f.error;
  ASSERT_EQ(f.intervals.size(), 1u);
  EXPECT_EQ(f.intervals[0].tag, "T7");
  EXPECT_EQ(f.intervals[0].start, 1700000000'000000);
  EXPECT_EQ(f.intervals[0].end, 1700000010'500000);
  EXPECT_DOUBLE_EQ(f.intervals[0].z, 0.9);
}

TEST(DwellFile, BadRowsAreRejectedAndCounted) {
  const DwellFile f = read(
      "start,end,x,y\n"
      "1670575951854,1670576018036,1,1\n"
      "1670576087904,1670576022595,2,2\n"  // ends before it starts
      "1670576092295,1670576156597,abc,3\n"
      "1670576160596,1670576226125,4,4\n"
      "1670576230000,1670576240000,5,5\n");
  ASSERT_TRUE(f.error.empty()) << f.error;  // 2 of 5 rejected: usable, with a warning
  EXPECT_EQ(f.intervals.size(), 3u);
  EXPECT_EQ(f.tally.bad, 2);
  EXPECT_EQ(f.tally.first_bad_line, 3);
  EXPECT_EQ(f.tally.first_bad_reason, "the interval ends before it starts");
}

TEST(DwellFile, UnusableFilesAreOneErrorLine) {
  EXPECT_NE(read("").error.find("no dwell interval"), std::string::npos);
  // Small numbers are no epoch time in any unit: say which flag to give.
  const DwellFile relative = read("0,10,1,1\n20,30,2,2\n");
  EXPECT_NE(relative.error.find("--dwell-time-unit"), std::string::npos) << relative.error;
  // A header without an x column.
  const DwellFile no_x = read("Start,End,East,North\n1670575951854,1670576018036,1,1\n");
  EXPECT_NE(no_x.error.find("no x column"), std::string::npos) << no_x.error;
  DwellFileOptions bad_columns;
  bad_columns.columns = "start,end,x,y,w";
  EXPECT_NE(read("1,2,3,4,5\n", bad_columns).error.find("unknown column 'w'"), std::string::npos);
  for (const auto& e : {relative.error, no_x.error}) EXPECT_EQ(e.find('\n'), std::string::npos);
}

}  // namespace
}  // namespace ips::eval
