// ips-baro --file: column layouts, banner dates, rates from the file, per-sensor rejections, and
// the nothing-silent verdicts, on hand-made lines shaped like baro-loruro's logs.
#include <gtest/gtest.h>

#include <cmath>

#include "drivers/baro/baro_file.hpp"

namespace ips::baro {
namespace {

// baro-loruro's shape: banner, header, 0.001 hPa / 0.001 degC rows, trailer; CRLF line ends.
constexpr const char* kLoruro =
    "Terminal log file\r\n"
    "Date: 13-06-2016 - 16:41:18\r\n"
    "-----------------------------------------------\r\n"
    "MPL115A1_Pressure;BMP180_Pressure;BMP180_Temperature\r\n"
    "967128;973004;26525\r\n"
    "966294;972795;26525\r\n"
    "0;972900;26530\r\n"
    "966300;972850;26530\r\n"
    "966310;972860;26535\r\n"
    "\r\n"
    "-----------------------------------------------\r\n"
    "Date: 13-06-2016 - 16:41:20\r\n"
    "End log file\r\n";

FileOptions loruro_options(double rate_hz = 0) {
  FileOptions o;
  o.name = "oss.log";
  std::string reason;
  EXPECT_TRUE(parse_file_layout("mpl,p,t", "0.001hPa,0.001hPa,0.001degC", "T1", o.layout, reason))
      << reason;
  o.rate_hz = rate_hz;
  return o;
}

TEST(BaroFile, LayoutNamesSensorsAndUnits) {
  FileLayout l;
  std::string reason;
  ASSERT_TRUE(parse_file_layout("time,-,mpl,p,t,B2.p,B2.t,h", "ms,-,-,0.001hPa,K,hPa,-,%", "bmp",
                                l, reason))
      << reason;
  ASSERT_EQ(l.sensors.size(), 3u);
  EXPECT_EQ(l.sensors[0], "bmp");
  EXPECT_EQ(l.sensors[1], "mpl");
  EXPECT_EQ(l.sensors[2], "B2");
  EXPECT_TRUE(l.has_time());
  EXPECT_EQ(l.time_unit, table::TimeUnit::kMs);
  EXPECT_EQ(l.describe(), "time,-,mpl.p,p,t,B2.p,B2.t,h");
  EXPECT_DOUBLE_EQ(l.columns[3].unit.to_si(973004), 97300.4);
  EXPECT_DOUBLE_EQ(l.columns[4].unit.to_si(300), 300 - 273.15);
  EXPECT_DOUBLE_EQ(l.columns[5].unit.to_si(1000), 100000);
}

TEST(BaroFile, LayoutErrorsSayWhat) {
  FileLayout l;
  std::string reason;
  EXPECT_FALSE(parse_file_layout("mpl,p,t", "0.001hPa,0.001hPa", "T1", l, reason));
  EXPECT_EQ(reason, "--units has 2 entries for 3 columns (one per column, '-' for the default)");
  EXPECT_FALSE(parse_file_layout("p,t", "0.001hPa,0.001hPa", "T1", l, reason));
  EXPECT_EQ(reason,
            "--units: '0.001hPa' for column 't' is not a unit of t (degC, K, degF, optionally "
            "after a factor: 0.001hPa)");
  EXPECT_FALSE(parse_file_layout("p,p", "", "T1", l, reason));
  EXPECT_EQ(reason, "--columns: 'p' is given twice");
  EXPECT_FALSE(parse_file_layout("t,-", "", "T1", l, reason));
  EXPECT_EQ(reason, "--columns 't,-' has no pressure column (p or NAME)");
  EXPECT_FALSE(parse_file_layout("p,B2.t", "", "T1", l, reason));
  EXPECT_EQ(reason, "--columns: sensor 'B2' has no pressure column (B2.p)");
  EXPECT_FALSE(parse_file_layout("p,a b", "", "T1", l, reason));
  EXPECT_NE(reason.find("'a b' is not a column name"), std::string::npos);
  EXPECT_FALSE(parse_file_layout("", "hPa", "T1", l, reason));
}

TEST(BaroFile, BannerDatesInBothOrders) {
  int64_t a = 0, b = 0;
  ASSERT_TRUE(parse_banner_date("Date: 13-06-2016 - 16:41:18\r", a));
  ASSERT_TRUE(parse_banner_date("Date: 2016-06-13 - 16:41:18", b));
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, 1465836078LL * 1'000'000);
  EXPECT_FALSE(parse_banner_date("Date: soon", a));
  EXPECT_FALSE(parse_banner_date("967128;973004;26525", a));
}

TEST(BaroFile, LoruroRowsSpreadBetweenTheDates) {
  const FileResult r = read_baro_file(kLoruro, loruro_options());
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.data_rows, 5);
  EXPECT_EQ(r.tally.rows, 5);
  EXPECT_EQ(r.tally.bad, 0);
  ASSERT_EQ(r.sensors.size(), 2u);
  EXPECT_EQ(r.sensors[0].samples, 5);  // T1 (BMP180)
  EXPECT_EQ(r.sensors[1].samples, 4);  // mpl: the 0 is rejected and counted
  EXPECT_EQ(r.sensors[1].rejected, 1);
  EXPECT_EQ(r.sensors[1].first_rejected_line, 7);
  EXPECT_EQ(r.sensors[1].first_reason, "mpl: pressure 0 Pa is not positive");
  EXPECT_DOUBLE_EQ(r.derived_hz, 2.0);  // 5 rows over 2 s: 4 intervals
  EXPECT_DOUBLE_EQ(r.rate_hz, 2.0);
  ASSERT_EQ(r.samples.size(), 9u);
  const int64_t start = 1465836078LL * 1'000'000;
  EXPECT_EQ(r.samples[0].utime, start);  // T1 (the file's sensor first)
  EXPECT_EQ(r.samples[1].utime, start);  // mpl
  EXPECT_EQ(r.samples[0].sensor, 0);
  EXPECT_EQ(r.samples[1].sensor, 1);
  EXPECT_NEAR(r.samples[0].reading.pressure_pa, 97300.4, 1e-9);
  EXPECT_NEAR(r.samples[0].reading.temperature_c, 26.525, 1e-9);
  EXPECT_NEAR(r.samples[1].reading.pressure_pa, 96712.8, 1e-9);
  EXPECT_TRUE(std::isnan(r.samples[1].reading.temperature_c));
  EXPECT_EQ(r.samples.back().utime, start + 2'000'000);
  EXPECT_NE(r.time_note.find("5 rows from 2016-06-13T16:41:18Z (the banner's start date) to "
                             "2016-06-13T16:41:20Z (the trailer's end date), evenly: 2.000 Hz"),
            std::string::npos)
      << r.time_note;
}

TEST(BaroFile, RateGivenWinsAndTheDatesAreStillPrinted) {
  const FileResult r = read_baro_file(kLoruro, loruro_options(10));
  ASSERT_TRUE(r.error.empty());
  EXPECT_EQ(r.samples.back().utime, 1465836078LL * 1'000'000 + 400'000);
  EXPECT_NE(r.time_note.find("times from --rate 10 Hz from 2016-06-13T16:41:18Z"),
            std::string::npos);
  EXPECT_NE(r.time_note.find("say 2.000 Hz"), std::string::npos) << r.time_note;
}

TEST(BaroFile, NoTimeAtAllIsAnError) {
  FileOptions o;
  o.name = "p.log";
  std::string reason;
  ASSERT_TRUE(parse_file_layout("", "", "T1", o.layout, reason));
  const FileResult r = read_baro_file("P 101325 T 21.5\nP 101320 T 21.5\n", o);
  EXPECT_EQ(r.error,
            "p.log: the rows have no time: give --rate HZ (and --file-start T), or --columns "
            "with a time column");
}

TEST(BaroFile, LineFormatWithRateAndStart) {
  FileOptions o;
  o.name = "p.log";
  std::string reason;
  ASSERT_TRUE(parse_file_layout("", "", "T2", o.layout, reason));
  o.rate_hz = 4;
  o.start_utime = 1'700'000'000'000'000;
  const FileResult r = read_baro_file(
      "# sketch v1\nP 101325 T 21.5 H 40\nP 0 T 21.5\nP 101320.5 T 21.6\ngarbage\n", o);
  ASSERT_TRUE(r.error.empty());
  EXPECT_EQ(r.tally.rows, 2);
  EXPECT_EQ(r.tally.bad, 2);
  EXPECT_EQ(r.tally.first_bad_line, 3);
  EXPECT_EQ(r.sensors[0].rejected, 2);
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.samples[0].utime, 1'700'000'000'000'000);
  EXPECT_EQ(r.samples[1].utime, 1'700'000'000'500'000);  // row 2: the rejected row kept its slot
  EXPECT_DOUBLE_EQ(r.samples[0].reading.humidity_pct, 40);
  EXPECT_DOUBLE_EQ(r.samples[1].reading.pressure_pa, 101320.5);
}

TEST(BaroFile, TimeColumnInMilliseconds) {
  FileOptions o;
  o.name = "t.csv";
  std::string reason;
  ASSERT_TRUE(parse_file_layout("time,p,t,h", "", "T1", o.layout, reason));
  const FileResult r =
      read_baro_file("time,p,t,h\n1700000000000,101325,21.5,40\n1700000000100,101320,21.5,41\n", o);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.samples[1].utime, 1'700'000'000'100'000);
  EXPECT_DOUBLE_EQ(r.samples[1].reading.humidity_pct, 41);
  EXPECT_NE(r.time_note.find("(ms)"), std::string::npos);
}

TEST(BaroFile, WronglySeparatedGivesTheVerdictWithTheHint) {
  FileOptions o = loruro_options(10);
  o.read.separator = ',';
  o.read.header = table::HeaderMode::kNone;
  const FileResult r = read_baro_file("967128;973004;26525\n966294;972795;26525\n", o);
  table::ImportExpectation e;
  e.input = "oss.log";
  e.columns = o.layout.describe();
  e.separator = ',';
  e.separator_given = true;
  EXPECT_EQ(table::import_verdict(r.tally, e),
            "oss.log: 0 messages from 2 lines; line 1 '967128;973004;26525': 1 fields, expected 3 "
            "(mpl.p,p,t) (columns mpl.p,p,t); looks semicolon-separated: try --separator ;");
}

TEST(BaroFile, AllPressuresBadFailsTheImport) {
  FileOptions o = loruro_options(10);
  const FileResult r = read_baro_file("MPL;BMP;T\n0;0;26525\n0;0;26525\n0;972795;26525\n", o);
  EXPECT_EQ(r.tally.rows, 1);
  EXPECT_EQ(r.tally.bad, 2);
  table::ImportExpectation e;
  e.input = "x.log";
  e.columns = o.layout.describe();
  EXPECT_EQ(table::import_verdict(r.tally, e).substr(0, 60),
            "x.log: 2 of 3 rows rejected; line 2 '0;0;26525': T1: pressur");
}

}  // namespace
}  // namespace ips::baro
