// Rows of the UDP apps and recorded files (drivers/phone_imu/csv_row.hpp). The tagged example is
// the IMU+GPS-Stream datagram quoted in the app's description and its users' receivers:
//   890.71558, 3, 0.076, 9.809, 0.565, 4, -0.559, 0.032, -0.134, 5, -21.660,-36.960,-28.140
#include "drivers/phone_imu/csv_row.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ips::phone_imu {
namespace {

RowFormat tagged() {
  RowFormat f;
  EXPECT_EQ(parse_column_mapping("tagged", f), "");
  return f;
}

RowFormat positional(const char* spec, char sep = ';', TimeUnit unit = TimeUnit::kMs) {
  RowFormat f;
  f.separator = sep;
  f.time_unit = unit;
  EXPECT_EQ(parse_column_mapping(spec, f), "");
  return f;
}

TEST(CsvRow, ImuGpsStreamDatagramGivesThreeSensorsAtOneTime) {
  const RowParse r = parse_row(
      "890.71558, 3, 0.076, 9.809, 0.565, 4, -0.559, 0.032, -0.134, 5, -21.660,-36.960,-28.140",
      tagged());
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.device_us, 890'715'580);
  ASSERT_EQ(r.count, 3);
  EXPECT_EQ(r.samples[0].kind, SensorKind::kAccel);
  EXPECT_DOUBLE_EQ(r.samples[0].xyz[1], 9.809);
  EXPECT_EQ(r.samples[1].kind, SensorKind::kGyro);
  EXPECT_DOUBLE_EQ(r.samples[1].xyz[0], -0.559);
  EXPECT_EQ(r.samples[2].kind, SensorKind::kMag);
  EXPECT_DOUBLE_EQ(r.samples[2].xyz[2], -28.140);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(r.samples[i].device_us, 890'715'580);
}

TEST(CsvRow, TaggedSkipsTheAppsOtherSensorsAndTakesUnitScales) {
  RowFormat f = tagged();
  f.units.gyro = kRadPerDeg;
  f.units.accel = kStandardGravity;
  // 81 orientation (3 values), 85 pressure (1), 86 battery temperature (1, %d).
  const RowParse r =
      parse_row("12.5, 81, 1.0, 2.0, 3.0, 3, 0, 0, 1, 85, 1013.2, 86, 31, 4, 90, 0, -180", f);
  ASSERT_TRUE(r.ok) << r.reason;
  ASSERT_EQ(r.count, 2);
  EXPECT_DOUBLE_EQ(r.samples[0].xyz[2], 9.80665);
  EXPECT_DOUBLE_EQ(r.samples[1].xyz[0], M_PI / 2);
  EXPECT_DOUBLE_EQ(r.samples[1].xyz[2], -M_PI);
}

TEST(CsvRow, TaggedRowWithoutTheThreeSensorsIsEmptyNotAnError) {
  const RowParse r = parse_row("1.0, 1, 50.1, 14.3, 230", tagged());
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.count, 0);
}

TEST(CsvRow, TaggedBadRowsSayWhy) {
  const RowFormat f = tagged();
  const std::pair<const char*, const char*> cases[] = {
      {"abc, 3, 1, 2, 3", "time 'abc' is not a time >= 0"},
      {"-1, 3, 1, 2, 3", "time '-1' is not a time >= 0"},
      {"1.0", "a time and no sensor"},
      {"1.0, x, 1, 2, 3", "sensor id 'x' is not an integer"},
      {"1.0, 9, 1, 2, 3", "unknown sensor id 9"},
      {"1.0, 3, 1, 2", "sensor 3 cut short: 2 of 3 values"},
      {"1.0, 3, 1, nan, 3", "accelerometer y 'nan' is not a number"},
      {"1.0, 4, 1, 2, inf", "gyroscope z 'inf' is not a number"},
      {"1.0, 5, 1, 2, 3, 5, 1, 2, 3", "sensor 5 twice in one row"},
      {"1.0, 85, hPa", "sensor 85 value 'hPa' is not a number"},
      {"1.0, 3, 1, 2, 3,", "sensor id '' is not an integer"},
  };
  for (const auto& [row, why] : cases) {
    const RowParse r = parse_row(row, f);
    EXPECT_FALSE(r.ok) << row;
    EXPECT_EQ(r.reason, why) << row;
  }
}

TEST(CsvRow, HyperImuPositionalRowWithTrailingColumns) {
  // HyperIMU CSV: Timestamp (ms epoch), accelerometer, gyroscope, magnetometer, then others.
  const RowFormat f = positional("t,ax,ay,az,gx,gy,gz,mx,my,mz", ',', TimeUnit::kMs);
  const RowParse r =
      parse_row("1518819953744,0.09279,0.14842,9.7839,0.01,-0.02,0.03,20.1,-3.5,-40.2,1,2,3", f);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.device_us, 1'518'819'953'744'000);
  ASSERT_EQ(r.count, 3);
  EXPECT_DOUBLE_EQ(r.samples[0].xyz[2], 9.7839);
  EXPECT_DOUBLE_EQ(r.samples[2].xyz[0], 20.1);
}

TEST(CsvRow, FileRowsWithEmptySensorFieldsAndJavaExponents) {
  // The source app's file (reference 002 section 1): semicolon-separated, ms times; the 100 Hz
  // magnetometer is empty in rows of the 400 Hz accelerometer/gyroscope.
  const RowFormat f = positional("t,ax,ay,az,gx,gy,gz,mx,my,mz");
  const RowParse r = parse_row("1682424000000;0.1;-0.2;9.81;1.0E-4;-2.5e-3;0;;;", f);
  ASSERT_TRUE(r.ok) << r.reason;
  EXPECT_EQ(r.device_us, 1'682'424'000'000'000);
  ASSERT_EQ(r.count, 2);
  EXPECT_DOUBLE_EQ(r.samples[1].xyz[0], 1e-4);
  EXPECT_DOUBLE_EQ(r.samples[1].xyz[1], -2.5e-3);
}

TEST(CsvRow, PositionalBadRowsSayWhy) {
  const RowFormat f = positional("t,ax,ay,az,gx,gy,gz,mx,my,mz");
  const std::pair<const char*, const char*> cases[] = {
      {"1;2;3", "3 fields, expected at least 10"},
      {"time;ax;ay;az;gx;gy;gz;mx;my;mz", "time 'time' is not a time >= 0"},
      {"1;1;;3;;;;;;", "accelerometer y '' is not a number"},
      {"1;1;2;3;a;b;c;;;", "gyroscope x 'a' is not a number"},
      {"1;1;2;3;1;2;3;1;2;0x10", "magnetometer z '0x10' is not a number"},
      {"99999999999999999999;1;2;3;;;;;;", "time '99999999999999999999' is not a time >= 0"},
  };
  for (const auto& [row, why] : cases) {
    const RowParse r = parse_row(row, f);
    EXPECT_FALSE(r.ok) << row;
    EXPECT_EQ(r.reason, why) << row;
  }
  EXPECT_FALSE(parse_row(std::string(300, ';'), f).ok);
  EXPECT_EQ(parse_row(std::string(300, ';'), f).reason, "more than 256 fields");
}

TEST(CsvRow, ColumnMappingErrors) {
  RowFormat f;
  EXPECT_EQ(parse_column_mapping("ax,ay,az", f), "no t (time) column");
  EXPECT_EQ(parse_column_mapping("t,t,ax,ay,az", f), "t is given twice");
  EXPECT_EQ(parse_column_mapping("t,ax,ax,ay,az", f), "ax is given twice");
  EXPECT_EQ(parse_column_mapping("t,ax,ay", f), "accelerometer needs all three axes or none");
  EXPECT_EQ(parse_column_mapping("t,-,-", f), "no sensor columns (ax,ay,az / gx,gy,gz / mx,my,mz)");
  EXPECT_EQ(parse_column_mapping("t,qx", f),
            "unknown column 'qx' (expected t, ax, ay, az, gx, gy, gz, mx, my, mz, - or the word "
            "tagged)");
  EXPECT_EQ(parse_column_mapping("-,gx,gy,gz,t", f), "");
  EXPECT_FALSE(f.tagged);
  EXPECT_EQ(f.time_column, 4);
  EXPECT_EQ(f.columns_needed, 5);
}

TEST(CsvRow, TimeUnitsAreExact) {
  int64_t us = 0;
  ASSERT_TRUE(parse_time_us("1698501144401773000", TimeUnit::kNs, us));
  EXPECT_EQ(us, 1698501144401773);
  ASSERT_TRUE(parse_time_us("1698501144401773500", TimeUnit::kNs, us));
  EXPECT_EQ(us, 1698501144401774);
  ASSERT_TRUE(parse_time_us(" 1.5 ", TimeUnit::kS, us));
  EXPECT_EQ(us, 1'500'000);
  ASSERT_TRUE(parse_time_us("1682424000123", TimeUnit::kMs, us));
  EXPECT_EQ(us, 1'682'424'000'123'000);
  EXPECT_FALSE(parse_time_us("5e18", TimeUnit::kUs, us));
  EXPECT_FALSE(parse_time_us("4000000000000", TimeUnit::kS, us));
  EXPECT_FALSE(parse_time_us("", TimeUnit::kS, us));
  EXPECT_EQ(time_unit_from_name("ms"), TimeUnit::kMs);
  EXPECT_EQ(time_unit_from_name("min"), std::nullopt);
}

TEST(CsvRow, UnitNames) {
  double k = 0;
  EXPECT_TRUE(accel_scale_from_name("g", k));
  EXPECT_DOUBLE_EQ(k, 9.80665);
  EXPECT_TRUE(gyro_scale_from_name("deg/s", k));
  EXPECT_DOUBLE_EQ(k, M_PI / 180);
  EXPECT_TRUE(mag_scale_from_name("mG", k));
  EXPECT_DOUBLE_EQ(k, 0.1);
  EXPECT_FALSE(accel_scale_from_name("m/s^2", k));
  EXPECT_FALSE(gyro_scale_from_name("dps", k));
  EXPECT_FALSE(mag_scale_from_name("T", k));
}

}  // namespace
}  // namespace ips::phone_imu
