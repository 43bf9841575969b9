// Recorded IMU files through the shared table reader (drivers/phone_imu/file_import.hpp). The
// lines are the first rows of the real recordings of ../shared/realdata: the Oxford step
// counter's accelerometer.csv (Pixel_Jamie_Hard_InHand_1: t_ns since boot, accuracy, ax, ay, az)
// and OpenShoe's OpenShoeDataSet.txt (ax, ay, az, gx, gy, gz at 820 Hz, no time).
#include "drivers/phone_imu/file_import.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace ips::phone_imu {
namespace {

struct Imported {
  std::vector<imu_t> out;
  std::string verdict, setup;
  table::ImportTally tally;
  std::string described;
  std::vector<std::string> warnings;
  int64_t dropped = 0;
};

Imported run(FileImportOptions o, const std::vector<std::string>& lines) {
  Imported r;
  FileImport imp(std::move(o), [&](const imu_t& m) { r.out.push_back(m); });
  r.setup = imp.setup_error();
  for (const auto& l : lines) imp.feed(l);
  r.verdict = imp.finish();
  r.tally = imp.tally();
  r.described = imp.describe();
  r.warnings = imp.warnings();
  r.dropped = imp.dropped();
  return r;
}

const std::vector<std::string> kOxford = {
    "583718602288785,3,-1.829795,2.5267458,9.544153",
    "583718622014098,3,-1.223855,3.1973512,7.077283",
    "583718641739411,3,-1.465752,3.2189064,7.8197393",
};

TEST(FileImport, OxfordAccelerometerCsvWithColumnsAndNanoseconds) {
  FileImportOptions o;
  o.columns = "t,-,ax,ay,az";
  o.time_unit = table::TimeUnit::kNs;
  const Imported r = run(o, kOxford);
  EXPECT_EQ(r.setup, "");
  EXPECT_EQ(r.verdict, "");
  ASSERT_EQ(r.out.size(), 3u);
  // ns to the us (table::parse_time_us); since boot, kept as they are (and said).
  EXPECT_EQ(r.out[0].utime, 583718602288);
  EXPECT_EQ(r.out[1].utime, 583718622014);
  EXPECT_EQ(r.out[0].device_utime, 583718602288);
  EXPECT_DOUBLE_EQ(r.out[0].accel[0], -1.829795);
  EXPECT_DOUBLE_EQ(r.out[2].accel[2], 7.8197393);
  for (const imu_t& m : r.out)
    for (int i = 0; i < 3; ++i) EXPECT_TRUE(std::isnan(m.gyro[i]) && std::isnan(m.mag_ut[i]));
  EXPECT_EQ(r.out[0].device_id, "phone");
  EXPECT_EQ(r.out[0].source, "ips-phone-imu:file");
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("give --file-start"), std::string::npos);
  EXPECT_EQ(r.described,
            "comma-separated (detected), columns t,-,ax,ay,az (from --columns), times in ns "
            "(--time-unit)");
}

TEST(FileImport, FileStartPlacesTimesSinceBoot) {
  FileImportOptions o;
  o.columns = "t,-,ax,ay,az";
  o.time_unit = table::TimeUnit::kNs;
  o.start_utime = 1'500'000'000'000'000;
  const Imported r = run(o, kOxford);
  ASSERT_EQ(r.out.size(), 3u);
  EXPECT_EQ(r.out[0].utime, 1'500'000'000'000'000);
  EXPECT_EQ(r.out[1].utime, 1'500'000'000'000'000 + (583718622014 - 583718602288));
  EXPECT_TRUE(r.warnings.empty());
}

TEST(FileImport, SecondsDefaultRejectsNanosecondTimesWithTheTimeUnitHint) {
  FileImportOptions o;
  o.input = "accelerometer.csv";
  o.columns = "t,-,ax,ay,az";
  const Imported r = run(o, kOxford);
  EXPECT_TRUE(r.out.empty());
  EXPECT_EQ(r.verdict,
            "accelerometer.csv: 0 messages from 3 lines; line 1 "
            "'583718602288785,3,-1.829795,2.5267458,9.544153': time '583718602288785' is not a "
            "time in s (columns t,-,ax,ay,az); check --time-unit, or give --rate HZ for a file "
            "without times");
}

TEST(FileImport, WrongSeparatorGivesTheSeparatorHint) {
  FileImportOptions o;
  o.input = "accelerometer.csv";
  o.columns = "t,-,ax,ay,az";
  o.read.separator = ';';
  const Imported r = run(o, kOxford);
  EXPECT_EQ(r.verdict,
            "accelerometer.csv: 0 messages from 3 lines; line 1 "
            "'583718602288785,3,-1.829795,2.5267458,9.544153': 1 fields, expected at least 5 "
            "(t,-,ax,ay,az) (columns t,-,ax,ay,az); looks comma-separated: try --separator ,");
}

TEST(FileImport, OpenShoeRowsAtARateWithNoTimeColumn) {
  FileImportOptions o;
  o.columns = "ax,ay,az,gx,gy,gz";
  o.rate_hz = 820;
  o.device_id = "foot1";
  const Imported r =
      run(o, {"0.19594386,-0.42454505,9.86250782,-0.00349064,-0.01745320,-0.02443448",
              "-0.03265731,-0.42454505,9.73187828,-0.02443448,0.02094384,-0.01396256",
              "0.06531462,-0.29391581,9.73187828,-0.01047192,0.03141576,0.00349064"});
  EXPECT_EQ(r.verdict, "");
  ASSERT_EQ(r.out.size(), 3u);
  // Row k at 1 s + k / 820 Hz (no --file-start), rounded to the us.
  EXPECT_EQ(r.out[0].utime, 1'000'000);
  EXPECT_EQ(r.out[1].utime, 1'001'220);
  EXPECT_EQ(r.out[2].utime, 1'002'439);
  EXPECT_EQ(r.out[1].device_utime, 1'220);
  EXPECT_DOUBLE_EQ(r.out[0].gyro[2], -0.02443448);
  EXPECT_DOUBLE_EQ(r.out[2].accel[1], -0.29391581);
  EXPECT_TRUE(std::isnan(r.out[0].mag_ut[0]));
  EXPECT_EQ(r.out[0].device_id, "foot1");
}

TEST(FileImport, HeaderNamesMapColumnsOnSemicolonRows) {
  FileImportOptions o;
  const Imported r = run(
      o, {"time;ax;ay;az;gx;gy;gz;mx;my;mz", "1682424000000;0.1;-0.2;9.81;0.01;0.02;0.03;20;-3;-40",
          "1682424000003;0.2;-0.1;9.8;0.02;;;;;", "1682424000005;0.3;0;9.79;;;;;;", "garbage",
          "1682424000100;0.4;0;9.7;0.5;0.5;0.5;;;", "1682424000100;0.4;0;9.7;;;;;;"});
  EXPECT_EQ(r.verdict, "");
  ASSERT_EQ(r.out.size(), 3u);
  const int64_t t0 = 1682424000000000;
  EXPECT_EQ(r.out[0].utime, t0);
  EXPECT_EQ(r.out[1].utime, t0 + 5000);
  EXPECT_DOUBLE_EQ(r.out[1].gyro[2], 0.03);  // carried from within 50 ms
  EXPECT_EQ(r.out[2].utime, t0 + 100000);
  EXPECT_TRUE(std::isnan(r.out[2].mag_ut[0]));
  EXPECT_EQ(r.tally.rows, 4);
  EXPECT_EQ(r.tally.bad, 2);
  EXPECT_EQ(r.tally.first_bad_line, 3);
  EXPECT_EQ(r.tally.first_bad_reason, "gyroscope y '' is not a number");
  EXPECT_EQ(r.dropped, 1);  // the repeated time
  EXPECT_EQ(r.described,
            "semicolon-separated (detected), columns t,ax,ay,az,gx,gy,gz,mx,my,mz (from the "
            "header), times in ms (guessed from the first time's magnitude)");
}

TEST(FileImport, AccelerometerHeaderNamesOfAnotherApp) {
  FileImportOptions o;
  const Imported r = run(o, {"timestamp_ns,acc_x,acc_y,acc_z", "1700000000000000000,0,0,9.8",
                             "1700000000010000000,0,0.1,9.8"});
  EXPECT_EQ(r.verdict, "");
  ASSERT_EQ(r.out.size(), 2u);
  EXPECT_EQ(r.out[1].utime, 1700000000010000);
  EXPECT_DOUBLE_EQ(r.out[1].accel[1], 0.1);
}

TEST(FileImport, HeaderWithoutSensorNamesIsAnErrorNamingIt) {
  FileImportOptions o;
  o.input = "f.csv";
  const Imported r = run(o, {"a,b,c", "1,2,3"});
  EXPECT_EQ(r.verdict,
            "f.csv: the header 'a,b,c' names no usable columns (no t (time) column: give one in "
            "--columns, or --rate HZ for a file without times); give --columns, e.g. --columns "
            "t,ax,ay,az,gx,gy,gz,mx,my,mz");
}

TEST(FileImport, BadColumnListsAreSetupErrors) {
  FileImportOptions o;
  o.columns = "t,ax";
  EXPECT_EQ(run(o, {}).setup,
            "--columns: accelerometer needs all three axes or none (columns t,ax)");
  o.columns = "t,gx,gy,gz";
  EXPECT_NE(run(o, {}).setup.find("no accelerometer columns"), std::string::npos);
  o.assembler.per_sample = true;
  EXPECT_EQ(run(o, {}).setup, "");
  o.columns = "t,ax,ay,az";
  o.rate_hz = 100;
  EXPECT_EQ(run(o, {}).setup,
            "--columns: --rate is for a file without a time column, and the columns have t");
  o.columns = "t,qx";
  EXPECT_NE(run(o, {}).setup.find("--columns: "), std::string::npos);
}

TEST(FileImport, GarbageIsNeverSilent) {
  FileImportOptions o;
  o.input = "g.bin";
  const Imported r = run(o, {"\x01\x02\x03 hello", "world", "\xff\xfe"});
  EXPECT_TRUE(r.out.empty());
  EXPECT_NE(r.verdict, "");
  EXPECT_EQ(r.verdict.rfind("g.bin: 0 messages from 3 lines", 0), 0u) << r.verdict;
}

TEST(FileImport, UnitsScaleToSi) {
  FileImportOptions o;
  o.columns = "t,ax,ay,az,gx,gy,gz";
  o.time_unit = table::TimeUnit::kS;
  o.units.accel = kStandardGravity;
  o.units.gyro = kRadPerDeg;
  const Imported r = run(o, {"1700000000.5 1 0 0 180 0 0"});
  ASSERT_EQ(r.out.size(), 1u);
  EXPECT_EQ(r.out[0].utime, 1700000000500000);
  EXPECT_DOUBLE_EQ(r.out[0].accel[0], kStandardGravity);
  EXPECT_NEAR(r.out[0].gyro[0], M_PI, 1e-12);
}

}  // namespace
}  // namespace ips::phone_imu
