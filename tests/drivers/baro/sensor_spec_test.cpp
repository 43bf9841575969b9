// ips-baro's sensor and reference specs (drivers/baro/sensor_spec.hpp): --iio by name or path,
// --serial, --reference with a height or from the site's baro_stations, and every refusal.
#include "drivers/baro/sensor_spec.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace ips::baro {
namespace {

using Kind = SensorSpec::Kind;

TEST(BaroSensorSpec, IioByNameOrByPath) {
  SensorSpec s;
  std::string reason;
  ASSERT_TRUE(parse_iio_spec("T1=bmp280", s, reason)) << reason;
  EXPECT_EQ(s.kind, Kind::kIioByName);
  EXPECT_EQ(s.id, "T1");
  EXPECT_EQ(s.target, "bmp280");
  ASSERT_TRUE(parse_iio_spec("B1=/sys/bus/iio/devices/iio:device1", s, reason)) << reason;
  EXPECT_EQ(s.kind, Kind::kIioByPath);
  EXPECT_EQ(s.target, "/sys/bus/iio/devices/iio:device1");
  ASSERT_TRUE(parse_iio_spec("B2=iio:device3", s, reason)) << reason;
  EXPECT_EQ(s.kind, Kind::kIioByPath);
  EXPECT_EQ(s.target, "iio:device3");
  ASSERT_TRUE(parse_iio_spec("B3=./fake/iio:device0", s, reason)) << reason;
  EXPECT_EQ(s.kind, Kind::kIioByPath);
}

TEST(BaroSensorSpec, SerialIsIdAndPath) {
  SensorSpec s;
  std::string reason;
  ASSERT_TRUE(parse_serial_spec("T2=/dev/ttyUSB0", s, reason)) << reason;
  EXPECT_EQ(s.kind, Kind::kSerial);
  EXPECT_EQ(s.id, "T2");
  EXPECT_EQ(s.target, "/dev/ttyUSB0");
}

TEST(BaroSensorSpec, RefusesBadSpecsWithTheirReason) {
  SensorSpec s;
  std::string reason;
  EXPECT_FALSE(parse_iio_spec("bmp280", s, reason));
  EXPECT_EQ(reason,
            "'bmp280' is not ID=NAME or ID=PATH (e.g. T1=bmp280 or "
            "B1=/sys/bus/iio/devices/iio:device1)");
  EXPECT_FALSE(parse_iio_spec("=bmp280", s, reason));
  EXPECT_EQ(reason, "'=bmp280' is not ID=NAME or ID=PATH (ID: 1 to 32 of A-Za-z0-9_.:-)");
  EXPECT_FALSE(parse_iio_spec("T 1=bmp280", s, reason));
  EXPECT_EQ(reason, "'T 1=bmp280' is not ID=NAME or ID=PATH (ID: 1 to 32 of A-Za-z0-9_.:-)");
  EXPECT_FALSE(parse_iio_spec("T1=bmp\x1b", s, reason));
  EXPECT_EQ(reason,
            "'T1=bmp\\x1b' is not ID=NAME or ID=PATH (e.g. T1=bmp280 or "
            "B1=/sys/bus/iio/devices/iio:device1)");
  EXPECT_FALSE(parse_serial_spec("/dev/ttyUSB0", s, reason));
  EXPECT_EQ(reason, "'/dev/ttyUSB0' is not ID=PATH (ID: 1 to 32 of A-Za-z0-9_.:-)");
  EXPECT_FALSE(parse_serial_spec("T2=", s, reason));
  EXPECT_EQ(reason, "'T2=' is not ID=PATH (e.g. T2=/dev/ttyUSB0)");
  EXPECT_FALSE(parse_serial_spec(std::string(33, 'A') + "=/dev/x", s, reason));
}

TEST(BaroSensorSpec, ReferenceWithOrWithoutHeight) {
  ReferenceSpec r;
  std::string reason;
  ASSERT_TRUE(parse_reference_spec("B1=2.4", r, reason)) << reason;
  EXPECT_EQ(r.id, "B1");
  ASSERT_TRUE(r.height_m.has_value());
  EXPECT_EQ(*r.height_m, 2.4);
  ASSERT_TRUE(parse_reference_spec("B1=-3", r, reason)) << reason;
  EXPECT_EQ(*r.height_m, -3.0);
  ASSERT_TRUE(parse_reference_spec("B2", r, reason)) << reason;
  EXPECT_EQ(r.id, "B2");
  EXPECT_FALSE(r.height_m.has_value());
  for (const char* bad : {"B1=", "B1=high", "B1=1e3", "B1=10000.5", "B1=nan"}) {
    EXPECT_FALSE(parse_reference_spec(bad, r, reason)) << bad;
    EXPECT_EQ(reason, "'" + std::string(bad) +
                          "': the height is not a number of metres within +-10000 (e.g. B1=2.4)");
  }
}

TEST(BaroSensorSpec, IdsAndSerialPathsAreUnique) {
  std::string reason;
  EXPECT_TRUE(
      check_sensors({{Kind::kIioByName, "T1", "bmp280"}, {Kind::kSerial, "T2", "/dev/a"}}, reason));
  EXPECT_FALSE(
      check_sensors({{Kind::kIioByName, "T1", "bmp280"}, {Kind::kSerial, "T1", "/dev/a"}}, reason));
  EXPECT_EQ(reason, "sensor id T1 is given twice");
  EXPECT_FALSE(
      check_sensors({{Kind::kSerial, "T1", "/dev/a"}, {Kind::kSerial, "T2", "/dev/a"}}, reason));
  EXPECT_EQ(reason, "--serial /dev/a is given twice");
}

class BaroReferenceHeights : public ::testing::Test {
 protected:
  const std::vector<SensorSpec> sensors{{Kind::kIioByName, "T1", "bmp280"},
                                        {Kind::kIioByPath, "B1", "iio:device1"},
                                        {Kind::kSerial, "B2", "/dev/ttyUSB0"}};
  const Site site = parse_site_text(R"(
anchors:
  - {id: A1, position: [0, 0, 2.4]}
baro_stations:
  - {id: B1, position: [1.0, 2.0, 2.35]}
  - {id: B2, position: [5.0, 0.0, 0.8]}
)",
                                    "lab.yaml");
  std::map<std::string, double> heights;
  std::vector<std::string> warnings;
  std::string reason;
};

TEST_F(BaroReferenceHeights, FromTheCommandLineWithoutASite) {
  ASSERT_TRUE(reference_heights({{"B1", 2.4}}, sensors, nullptr, heights, warnings, reason))
      << reason;
  EXPECT_EQ(heights, (std::map<std::string, double>{{"B1", 2.4}}));
  EXPECT_TRUE(warnings.empty());
}

TEST_F(BaroReferenceHeights, FromTheSitesBaroStations) {
  ASSERT_TRUE(reference_heights({{"B1", std::nullopt}, {"B2", std::nullopt}}, sensors, &site,
                                heights, warnings, reason))
      << reason;
  EXPECT_EQ(heights, (std::map<std::string, double>{{"B1", 2.35}, {"B2", 0.8}}));
  EXPECT_TRUE(warnings.empty());
}

TEST_F(BaroReferenceHeights, TheCommandLineWinsAndTheDifferenceIsSaid) {
  ASSERT_TRUE(reference_heights({{"B1", 2.4}}, sensors, &site, heights, warnings, reason));
  EXPECT_EQ(heights, (std::map<std::string, double>{{"B1", 2.4}}));
  EXPECT_EQ(warnings,
            (std::vector<std::string>{
                "--reference B1: height 2.4 m from the command line, not the site's 2.35 m",
                "sensor B2 is a baro_stations entry of the site but not a --reference: it is "
                "published as a tag barometer"}));
}

TEST_F(BaroReferenceHeights, EveryRefusal) {
  EXPECT_FALSE(reference_heights({{"X9", 1.0}}, sensors, nullptr, heights, warnings, reason));
  EXPECT_EQ(reason, "--reference X9: no sensor X9 (give it with --iio, --serial or a --file column)");
  EXPECT_FALSE(
      reference_heights({{"B1", 1.0}, {"B1", 2.0}}, sensors, nullptr, heights, warnings, reason));
  EXPECT_EQ(reason, "--reference B1 is given twice");
  EXPECT_FALSE(
      reference_heights({{"B1", std::nullopt}}, sensors, nullptr, heights, warnings, reason));
  EXPECT_EQ(reason,
            "--reference B1: no height: give B1=HEIGHT_M, or --site with a baro_stations "
            "entry B1");
  EXPECT_FALSE(
      reference_heights({{"T1", std::nullopt}}, sensors, &site, heights, warnings, reason));
  EXPECT_EQ(reason,
            "--reference T1: no height: the site lab.yaml has no baro_stations entry T1 "
            "(it has B1, B2); or give T1=HEIGHT_M");
}

}  // namespace
}  // namespace ips::baro
