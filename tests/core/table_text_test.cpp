#include "core/table_text.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::table {
namespace {

const std::vector<KnownColumn> kImu = {{"t", "t|time|timestamp|t_ns"},
                                       {"ax", "ax|acc_x|accel_x"},
                                       {"ay", "ay|acc_y"},
                                       {"az", "az|acc_z"}};

TEST(TableText, DetectsTheSeparatorOfRealFiles) {
  // steps-oxford accelerometer.csv, baro-loruro oss_0.log, libRSF Indoor_UWB_Input.txt.
  EXPECT_EQ(detect_separator("583718602288785,3,-1.829795,2.5267458,9.544153"), ',');
  EXPECT_EQ(detect_separator("967128;973004;26525"), ';');
  EXPECT_EQ(detect_separator("range2 0.1279 2.9552 0.01 -0.02 -0.01 105 0 "), kBlanks);
  EXPECT_EQ(detect_separator("1\t2\t3,5"), '\t');
  EXPECT_EQ(detect_separator("\"a,b\";c;d"), ';');  // commas inside quotes do not count
}

TEST(TableText, SplitsTrimsAndUnquotes) {
  std::vector<std::string_view> f;
  ASSERT_TRUE(split_fields(" 1 , \"x y\" ,,3 ", ',', f));
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0], "1");
  EXPECT_EQ(f[1], "x y");
  EXPECT_EQ(f[2], "");
  EXPECT_EQ(f[3], "3");
  ASSERT_TRUE(split_fields("  a \t b  c ", kBlanks, f));
  ASSERT_EQ(f.size(), 3u);
  EXPECT_EQ(f[2], "c");
  std::string wide(kMaxFields + 1, ',');
  EXPECT_FALSE(split_fields(wide, ',', f));
}

TEST(TableText, NumbersAreFiniteDecimals) {
  double v = 0;
  EXPECT_TRUE(parse_number("1.7345014855003267e+18", v));
  EXPECT_DOUBLE_EQ(v, 1.7345014855003267e+18);
  EXPECT_TRUE(parse_number("+.5", v));
  EXPECT_DOUBLE_EQ(v, 0.5);
  EXPECT_FALSE(parse_number("nan", v));
  EXPECT_FALSE(parse_number("inf", v));
  EXPECT_FALSE(parse_number("1e999", v));
  EXPECT_FALSE(parse_number("6C1DEBA3FFAC", v));
  EXPECT_FALSE(parse_number("", v));
}

TEST(TableText, UnitsWithFactors) {
  auto u = parse_unit("0.001hPa", Quantity::kPressure);
  ASSERT_TRUE(u);
  EXPECT_DOUBLE_EQ(u->to_si(973004), 97300.4);  // baro-loruro's BMP180 column
  u = parse_unit("0.001degC", Quantity::kTemperature);
  ASSERT_TRUE(u);
  EXPECT_DOUBLE_EQ(u->to_si(26525), 26.525);
  u = parse_unit("K", Quantity::kTemperature);
  ASSERT_TRUE(u);
  EXPECT_DOUBLE_EQ(u->to_si(300), 300 - 273.15);
  u = parse_unit("cm", Quantity::kLength);
  ASSERT_TRUE(u);
  EXPECT_DOUBLE_EQ(u->to_si(120), 1.2);
  u = parse_unit("g", Quantity::kAcceleration);
  ASSERT_TRUE(u);
  EXPECT_DOUBLE_EQ(u->to_si(1), 9.80665);
  EXPECT_TRUE(parse_unit("deg/s", Quantity::kAngularRate));
  EXPECT_FALSE(parse_unit("hPa", Quantity::kLength));
  EXPECT_FALSE(parse_unit("-1m", Quantity::kLength));
  EXPECT_FALSE(parse_unit("", Quantity::kLength));
}

TEST(TableText, TimesInEveryUnitAndIso8601) {
  int64_t us = 0;
  ASSERT_TRUE(parse_time_us("1734501485317590607", TimeUnit::kNs, us));  // exact, no double
  EXPECT_EQ(us, 1734501485317590);
  ASSERT_TRUE(parse_time_us("1744235951945", TimeUnit::kMs, us));
  EXPECT_EQ(us, 1744235951945000);
  ASSERT_TRUE(parse_time_us("0.127943992614746", TimeUnit::kS, us));
  EXPECT_EQ(us, 127944);
  ASSERT_TRUE(parse_time_us("1.7345014855003267e+18", TimeUnit::kNs, us));
  EXPECT_NEAR(static_cast<double>(us), 1734501485500327.0, 1.0);
  ASSERT_TRUE(parse_iso8601_us("1970-01-02T00:00:01.5Z", us));
  EXPECT_EQ(us, 86401500000);
  ASSERT_TRUE(parse_time_us("2024-12-18 05:58:05+09:00", TimeUnit::kS, us));
  EXPECT_EQ(us, (1734501485LL - 9 * 3600) * 1000000LL);
  EXPECT_FALSE(parse_iso8601_us("2024-13-18T05:58:05Z", us));
  EXPECT_FALSE(parse_iso8601_us("2024-12-18T05:58:05Q", us));
  EXPECT_FALSE(parse_time_us("1e300", TimeUnit::kS, us));
  EXPECT_EQ(guess_epoch_unit(1744235951945.0), TimeUnit::kMs);
  EXPECT_EQ(guess_epoch_unit(1.7345014855003267e+18), TimeUnit::kNs);
  EXPECT_FALSE(guess_epoch_unit(583718.6));
}

TEST(TableText, RowClockPlacesRows) {
  RowClock epoch;
  EXPECT_EQ(epoch.next(1'700'000'000'000'000), 1'700'000'000'000'000);
  EXPECT_FALSE(epoch.since_boot());
  RowClock boot;
  EXPECT_EQ(boot.next(583'718'602'288), 583'718'602'288);
  EXPECT_TRUE(boot.since_boot());
  RowClock started(1'000'000'000'000'000, 0);
  EXPECT_EQ(started.next(583'718'602'288), 1'000'000'000'000'000);
  EXPECT_EQ(started.next(583'718'622'014), 1'000'000'000'019'726);
  RowClock rate(std::nullopt, 820);  // OpenShoe: 820 Hz, no time column
  EXPECT_EQ(rate.next(std::nullopt), 0);
  EXPECT_EQ(rate.next(std::nullopt), 1220);
  EXPECT_EQ(rate.next(std::nullopt), 2439);
  RowClock none;
  EXPECT_FALSE(none.next(std::nullopt));
}

TEST(TableText, ColumnsFromAListAndFromAHeader) {
  Columns c;
  EXPECT_EQ(c.set_from_list("t,-,ax,ay,az", kImu), "");
  EXPECT_EQ(c.index("t"), 0);
  EXPECT_EQ(c.index("ax"), 2);
  EXPECT_EQ(c.needed(), 5);
  EXPECT_EQ(c.describe(), "t,-,ax,ay,az");
  EXPECT_NE(c.set_from_list("t,bx", kImu).find("unknown column 'bx'"), std::string::npos);
  EXPECT_NE(c.set_from_list("t,ax,ax", kImu).find("twice"), std::string::npos);
  // A ROS topic dump's header (uwb-cucudasluv) and units in brackets.
  const std::vector<KnownColumn> ranges = {{"t", "time|stamp"},
                                           {"anchor", "anchor|id"},
                                           {"range", "range|distance|distanceFromTag"},
                                           {"fp", "rssi_fp|fp_power"}};
  std::vector<std::string_view> h = {"%time", "field.stamp", "field.id", "field.x",
                                     "field.distanceFromTag", "field.rssi", "field.rssi_fp"};
  EXPECT_EQ(c.set_from_header(h, ranges), 4);
  EXPECT_EQ(c.index("t"), 0);
  EXPECT_EQ(c.index("anchor"), 2);
  EXPECT_EQ(c.index("range"), 4);
  EXPECT_EQ(c.index("fp"), 6);
  h = {"Timestamp(ms)", "Acc X [m/s^2]"};
  EXPECT_EQ(c.set_from_header(h, kImu), 2);
  EXPECT_EQ(c.index("ax"), 1);
}

// Feeds lines and returns the kinds.
std::vector<TableReader::Kind> feed_all(TableReader& r, const std::vector<std::string>& lines) {
  std::vector<TableReader::Kind> k;
  for (const std::string& l : lines) k.push_back(r.feed(l));
  return k;
}

TEST(TableReader, SkipsABannerAndFindsTheHeader) {
  // baro-loruro's terminal log: a three-line banner, the column names, then data.
  TableReader r;
  using K = TableReader::Kind;
  const auto k = feed_all(r, {"Terminal log file", "Date: 13-06-2016 - 16:41:18",
                              "-----------------------------------------------",
                              "MPL115A1_Pressure;BMP180_Pressure;BMP180_Temperature",
                              "967128;973004;26525", "967100;973010;26520", ""});
  EXPECT_EQ(k, (std::vector<K>{K::kPreamble, K::kPreamble, K::kPreamble, K::kPreamble, K::kData,
                               K::kData, K::kEmpty}));
  EXPECT_EQ(r.separator(), ';');
  ASSERT_EQ(r.header().size(), 3u);
  EXPECT_EQ(r.header()[1], "BMP180_Pressure");
  EXPECT_EQ(r.data_rows(), 2);
}

TEST(TableReader, DataWithIdsIsData) {
  // ble-byongho96: MAC ids among the numbers.
  TableReader r;
  EXPECT_EQ(r.feed("Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor,Sequence"),
            TableReader::Kind::kPreamble);
  EXPECT_EQ(r.feed("1744235951945,6C1DEBA3FFAC,-55,-4,-15,20,6C1DEBA09A56,15232"),
            TableReader::Kind::kData);
  EXPECT_TRUE(r.first_data());
  EXPECT_EQ(r.fields().size(), 8u);
  EXPECT_EQ(r.header().size(), 8u);
  EXPECT_EQ(r.feed("1744235951946,6C1DEBA3FFAC,-55,0,-29,24,6C1DEBA09A56,15233"),
            TableReader::Kind::kData);
  EXPECT_FALSE(r.first_data());
}

TEST(TableReader, TaggedRows) {
  ReadOptions o;
  o.row_tag = "range2";
  TableReader r(o);
  EXPECT_EQ(r.feed("odom2diff 0.1 0.2 0.3"), TableReader::Kind::kOtherRow);
  EXPECT_EQ(r.feed("range2 0.1279 2.9552 0.01 -0.02 -0.01 105 0 "), TableReader::Kind::kData);
  EXPECT_EQ(r.fields().size(), 8u);
  EXPECT_EQ(r.fields()[6], "105");
}

TEST(ImportVerdict, ACommaFileReadAsSemicolonsSaysSo) {
  ReadOptions o;
  o.separator = ';';
  TableReader r(o);
  ImportTally t;
  const std::vector<std::string> lines = {"583718602288785,3,-1.829795,2.5267458,9.544153",
                                          "583718622014098,3,-1.223855,3.1973512,7.077283"};
  for (const std::string& l : lines) {
    const auto kind = r.feed(l);
    t.note(r, kind, l);
    if (kind == TableReader::Kind::kData) t.reject(r.line_number(), l, "1 fields, expected 4");
  }
  ImportExpectation e{"x.csv", "t,ax,ay,az", ';', true, true};
  const std::string v = import_verdict(t, e);
  EXPECT_NE(v.find("x.csv: 0 messages from 2 lines; line 1 '583718602288785,3,"), std::string::npos) << v;
  EXPECT_NE(v.find("looks comma-separated: try --separator ,"), std::string::npos) << v;
}

TEST(ImportVerdict, AcceptsMostlyGoodInputAndRefusesMostlyBad) {
  ImportTally t;
  t.lines = 10;
  t.rows = 6;
  t.messages = 6;
  for (int i = 0; i < 4; ++i) t.reject(i + 1, "x", "bad time");
  EXPECT_EQ(import_verdict(t, {"f", "", std::nullopt, false, true}), "");
  t.reject(5, "x", "bad time");
  t.reject(6, "x", "bad time");
  t.reject(7, "x", "bad time");
  const std::string v = import_verdict(t, {"f", "", std::nullopt, false, true});
  EXPECT_NE(v.find("7 of 13 rows rejected; line 1 'x': bad time"), std::string::npos) << v;
  EXPECT_NE(v.find("--time-unit"), std::string::npos) << v;
  // An empty file is not an error of the import (nothing to read), a file of blanks neither.
  ImportTally empty;
  EXPECT_EQ(import_verdict(empty, {"f", "", std::nullopt, false, true}), "");
}

TEST(ImportVerdict, GarbageSaysNoLineLooksLikeData) {
  TableReader r;
  ImportTally t;
  for (const std::string l : {"hello world", "this is not a table"}) t.note(r, r.feed(l), l);
  const std::string v = import_verdict(t, {"g.txt", "", std::nullopt, false, true});
  EXPECT_NE(v.find("0 messages from 2 lines; no line looks like data (the first reads 'hello "
                   "world')"),
            std::string::npos)
      << v;
}

}  // namespace
}  // namespace ips::table
