// IIO sysfs attribute texts (drivers/baro/sysfs_value.hpp) as the kernel prints them
// (iio_format_value: "%d" for IIO_VAL_INT, "%d.%09u" for IIO_VAL_INT_PLUS_NANO and
// IIO_VAL_FRACTIONAL, then "\n"), and the channel value (raw + offset) * scale of the IIO ABI
// (Documentation/ABI/testing/sysfs-bus-iio).
#include "drivers/baro/sysfs_value.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ips::baro {
namespace {

TEST(BaroSysfsNumber, ReadsTheKernelsIntegerAndDecimalForms) {
  double v = 0;
  std::string reason;
  ASSERT_TRUE(parse_sysfs_number("101.325120000\n", v, reason)) << reason;
  EXPECT_EQ(v, 101.32512);
  ASSERT_TRUE(parse_sysfs_number("-12345\n", v, reason)) << reason;
  EXPECT_EQ(v, -12345.0);
  ASSERT_TRUE(parse_sysfs_number("0.000976562\n", v, reason)) << reason;
  EXPECT_EQ(v, 0.000976562);
  ASSERT_TRUE(parse_sysfs_number("-0.500000", v, reason)) << reason;  // no newline: also fine
  EXPECT_EQ(v, -0.5);
  ASSERT_TRUE(parse_sysfs_number("  21430 \r\n", v, reason)) << reason;
  EXPECT_EQ(v, 21430.0);
}

TEST(BaroSysfsNumber, RefusesWhatTheKernelNeverPrints) {
  struct Case {
    const char* text;
    const char* reason;
  };
  const Case cases[] = {
      {"", "empty"},
      {"\n", "empty"},
      {"nan\n", "'nan' is not a number"},
      {"1e5\n", "'1e5' is not a number"},
      {"+5\n", "'+5' is not a number"},
      {"1.2.3\n", "'1.2.3' is not a number"},
      {"12 34\n", "'12 34' is not a number"},
      {"-\n", "'-' is not a number"},
      {"0x10\n", "'0x10' is not a number"},
      {"\xff\x01\n", "'?\?' is not a number"},
  };
  for (const auto& c : cases) {
    double v = 7;
    std::string reason;
    EXPECT_FALSE(parse_sysfs_number(c.text, v, reason)) << c.text;
    EXPECT_EQ(reason, c.reason) << c.text;
    EXPECT_EQ(v, 7);  // untouched
  }
}

TEST(BaroIioChannelValue, TakesInputAsItIs) {
  double v = 0;
  std::string reason;
  ASSERT_TRUE(iio_channel_value(
      {"in_pressure", "101.325120000\n", std::nullopt, std::nullopt, std::nullopt}, v, reason))
      << reason;
  EXPECT_EQ(v, 101.32512);
}

TEST(BaroIioChannelValue, InputWinsOverRaw) {
  double v = 0;
  std::string reason;
  ASSERT_TRUE(iio_channel_value({"in_temp", "21430\n", "1\n", "2\n", "3\n"}, v, reason));
  EXPECT_EQ(v, 21430.0);
}

TEST(BaroIioChannelValue, RawPlusOffsetTimesScale) {
  double v = 0;
  std::string reason;
  // A BMP280-like pressure: 25331280 * 0.000004 kPa; a temperature with an offset:
  // (-357 + 2500) * 10 = 21430 milli degC.
  ASSERT_TRUE(iio_channel_value(
      {"in_pressure", std::nullopt, "25331280\n", "0.000004000\n", std::nullopt}, v, reason))
      << reason;
  EXPECT_EQ(v, 25331280.0 * 0.000004);
  ASSERT_TRUE(iio_channel_value({"in_temp", std::nullopt, "-357\n", "10\n", "2500\n"}, v, reason))
      << reason;
  EXPECT_EQ(v, 21430.0);
  // The offset is added before scaling, not after: (100 + 0.5) * 2 = 201, not 100 * 2 + 0.5.
  ASSERT_TRUE(iio_channel_value({"in_temp", std::nullopt, "100", "2", "0.5"}, v, reason));
  EXPECT_EQ(v, 201.0);
}

TEST(BaroIioChannelValue, NamesTheAttributeThatIsBad) {
  struct Case {
    IioChannelText text;
    const char* reason;
  };
  const Case cases[] = {
      {{"in_pressure", "abc\n", std::nullopt, std::nullopt, std::nullopt},
       "in_pressure_input: 'abc' is not a number"},
      {{"in_pressure", std::nullopt, "", "0.1", std::nullopt}, "in_pressure_raw: empty"},
      {{"in_temp", std::nullopt, "12", "x", std::nullopt}, "in_temp_scale: 'x' is not a number"},
      {{"in_temp", std::nullopt, "12", "1", "-"}, "in_temp_offset: '-' is not a number"},
      {{"in_humidityrelative", std::nullopt, "12", std::nullopt, std::nullopt},
       "in_humidityrelative: neither _input nor _raw with _scale"},
      {{"in_pressure", std::nullopt, std::nullopt, "1", std::nullopt},
       "in_pressure: neither _input nor _raw with _scale"},
  };
  for (const auto& c : cases) {
    double v = 7;
    std::string reason;
    EXPECT_FALSE(iio_channel_value(c.text, v, reason)) << c.reason;
    EXPECT_EQ(reason, c.reason);
    EXPECT_EQ(v, 7);
  }
}

}  // namespace
}  // namespace ips::baro
