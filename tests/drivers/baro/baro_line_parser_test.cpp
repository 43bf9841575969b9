// The serial barometer line (drivers/baro/baro_line_parser.hpp): "P <Pa> T <degC> [H <%>]" as
// the Arduino sketch of docs/hardware/barometer.md prints it (Serial.print(p, 2) gives
// "101325.12"), with CRLF, extra blanks, H absent, comments, and every reason for a bad line.
#include "drivers/baro/baro_line_parser.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace ips::baro {
namespace {

using Kind = BaroLineResult::Kind;

TEST(BaroLineParser, ReadsPressureTemperatureAndHumidity) {
  const auto r = parse_baro_line("P 101325.12 T 21.43 H 45.2");
  ASSERT_EQ(r.kind, Kind::kSample) << r.reason;
  EXPECT_EQ(r.reading.pressure_pa, 101325.12);
  EXPECT_EQ(r.reading.temperature_c, 21.43);
  EXPECT_EQ(r.reading.humidity_pct, 45.2);
  EXPECT_EQ(r.reason, "");
}

TEST(BaroLineParser, HumidityIsOptionalAndNaNWithoutIt) {
  const auto r = parse_baro_line("P 98765 T -5.5");
  ASSERT_EQ(r.kind, Kind::kSample) << r.reason;
  EXPECT_EQ(r.reading.pressure_pa, 98765.0);
  EXPECT_EQ(r.reading.temperature_c, -5.5);
  EXPECT_TRUE(std::isnan(r.reading.humidity_pct));
}

TEST(BaroLineParser, ToleratesCrlfTabsAndExtraBlanks) {
  for (const char* line : {"P 101325.12 T 21.43 H 45.2\r", "  P   101325.12\tT 21.43  H\t45.2  ",
                           "\tP 101325.12 T 21.43 H 45.2 \r"}) {
    const auto r = parse_baro_line(line);
    ASSERT_EQ(r.kind, Kind::kSample) << line << ": " << r.reason;
    EXPECT_EQ(r.reading.pressure_pa, 101325.12);
    EXPECT_EQ(r.reading.temperature_c, 21.43);
    EXPECT_EQ(r.reading.humidity_pct, 45.2);
  }
}

TEST(BaroLineParser, TakesTheFieldsInAnyOrder) {
  const auto r = parse_baro_line("H 0 T 85 P 30000");
  ASSERT_EQ(r.kind, Kind::kSample) << r.reason;
  EXPECT_EQ(r.reading.pressure_pa, 30000.0);
  EXPECT_EQ(r.reading.temperature_c, 85.0);
  EXPECT_EQ(r.reading.humidity_pct, 0.0);
}

TEST(BaroLineParser, TheRangeLimitsThemselvesAreSamples) {
  for (const char* line : {"P 30000 T -40", "P 125000 T 85 H 100", "P 30000.0 T 0 H 0"}) {
    EXPECT_EQ(parse_baro_line(line).kind, Kind::kSample) << line;
  }
}

TEST(BaroLineParser, ACommentIsNeitherSampleNorError) {
  for (const char* line : {"# ips-baro sketch, BMP280 at 0x76", "  #", "#P 1 T 2"}) {
    const auto r = parse_baro_line(line);
    EXPECT_EQ(r.kind, Kind::kComment) << line;
    EXPECT_EQ(r.reason, "");
  }
}

struct BadLine {
  const char* line;
  const char* reason;
};

TEST(BaroLineParser, EveryBadLineHasItsReason) {
  const BadLine cases[] = {
      {"", "empty line"},
      {" \t\r", "empty line"},
      {"P 101325 T", "T has no value"},
      {"P", "P has no value"},
      {"P 101325 T 21 P 101000", "P given twice"},
      {"P 101325 T 21 H 40 H 41", "H given twice"},
      {"T 21.5 H 40", "no pressure (P)"},
      {"P 101325.12", "no temperature (T)"},
      {"P 101325 T 21 X 5", "unknown field 'X' (expected P, T or H)"},
      {"p 101325 T 21", "unknown field 'p' (expected P, T or H)"},
      {"PRESSURE 101325 T 21", "unknown field 'PRESSURE' (expected P, T or H)"},
      {"P=101325 T=21", "unknown field 'P=101325' (expected P, T or H)"},
      {"P abc T 21", "pressure 'abc' is not a number"},
      {"P 101325 T nan", "temperature 'nan' is not a number"},
      {"P 101325 T inf", "temperature 'inf' is not a number"},
      {"P 1.01325e5 T 21", "pressure '1.01325e5' is not a number"},
      {"P +101325 T 21", "pressure '+101325' is not a number"},
      {"P 101325,5 T 21", "pressure '101325,5' is not a number"},
      {"P 101325 T 21 H ovf", "humidity 'ovf' is not a number"},
      {"P 0 T 21", "pressure 0 Pa is not positive"},
      {"P -101325 T 21", "pressure -101325 Pa is not positive"},
      {"P 1013.25 T 21",
       "pressure 1013.25 Pa is outside 30..125 kPa, the measuring range of the supported sensors"},
      {"P 29999.99 T 21",
       "pressure 29999.99 Pa is outside 30..125 kPa, the measuring range of the supported "
       "sensors"},
      {"P 125000.01 T 21",
       "pressure 125000.01 Pa is outside 30..125 kPa, the measuring range of the supported "
       "sensors"},
      {"P 101325 T 85.01",
       "temperature 85.01 degC is outside -40..85 degC, the sensors' operating range"},
      {"P 101325 T -273.15",
       "temperature -273.15 degC is outside -40..85 degC, the sensors' operating range"},
      {"P 101325 T 21 H 100.5", "humidity 100.5 % is outside 0..100 %"},
      {"P 101325 T 21 H -0.1", "humidity -0.1 % is outside 0..100 %"},
      {"P \x01\xff T 21", "pressure '?\?' is not a number"},
      {"\x1b[2J", "unknown field '?[2J' (expected P, T or H)"},
  };
  for (const auto& c : cases) {
    const auto r = parse_baro_line(c.line);
    EXPECT_EQ(r.kind, Kind::kError) << c.line;
    EXPECT_EQ(r.reason, c.reason) << c.line;
  }
}

TEST(BaroLineParser, ALongGarbageFieldIsCutInTheReason) {
  const std::string line = "P " + std::string(100, '9') + "x T 21";
  const auto r = parse_baro_line(line);
  ASSERT_EQ(r.kind, Kind::kError);
  EXPECT_EQ(r.reason, "pressure '" + std::string(24, '9') + "...' is not a number");
}

}  // namespace
}  // namespace ips::baro
