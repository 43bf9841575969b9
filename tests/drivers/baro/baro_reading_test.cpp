// The checks every barometer sample passes (drivers/baro/baro_reading.hpp: 30..125 kPa from
// ../shared/reference/003_baro.md Table 2.1, -40..85 degC, 0..100 %) and its baro_t.
#include "drivers/baro/baro_reading.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace ips::baro {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(BaroReading, UnknownTemperatureAndHumidityAreAllowed) {
  EXPECT_EQ(reading_problem({101325.0, kNaN, kNaN}), "");
  EXPECT_EQ(reading_problem({101325.0, 20.0, kNaN}), "");
}

TEST(BaroReading, NonFiniteValuesAreRefused) {
  EXPECT_EQ(reading_problem({kNaN, 20.0, kNaN}), "pressure is not a finite number");
  EXPECT_EQ(reading_problem({kInf, 20.0, kNaN}), "pressure is not a finite number");
  EXPECT_EQ(reading_problem({-kInf, 20.0, kNaN}), "pressure is not a finite number");
  EXPECT_EQ(reading_problem({101325.0, kInf, kNaN}), "temperature is not a finite number");
  EXPECT_EQ(reading_problem({101325.0, 20.0, kInf}), "humidity inf % is outside 0..100 %");
}

TEST(BaroReading, PressureTemperatureAndHumidityRanges) {
  EXPECT_EQ(reading_problem({0.0, 20.0, kNaN}), "pressure 0 Pa is not positive");
  EXPECT_EQ(reading_problem({124999.5, -40.0, 100.0}), "");
  EXPECT_EQ(reading_problem({125000.5, 20.0, kNaN}),
            "pressure 125000.5 Pa is outside 30..125 kPa, the measuring range of the supported "
            "sensors");
  EXPECT_EQ(reading_problem({101325.0, -40.5, kNaN}),
            "temperature -40.5 degC is outside -40..85 degC, the sensors' operating range");
  EXPECT_EQ(reading_problem({101325.0, 20.0, 100.25}), "humidity 100.25 % is outside 0..100 %");
}

TEST(BaroReading, FormatsNumbersWithTheirDigits) {
  EXPECT_EQ(format_number(101325.12), "101325.12");
  EXPECT_EQ(format_number(-12.5), "-12.5");
  EXPECT_EQ(format_number(0.001), "0.001");
}

TEST(BaroReading, ATagSampleHasNoReferenceHeight) {
  const baro_t m = to_message({101325.12, 21.43, kNaN}, 1'700'000'000'123'456, "ips-baro:/dev/x",
                              "T1", std::nullopt);
  EXPECT_EQ(m.utime, 1'700'000'000'123'456);
  EXPECT_EQ(m.source, "ips-baro:/dev/x");
  EXPECT_EQ(m.sensor_id, "T1");
  EXPECT_EQ(m.pressure_pa, 101325.12);
  EXPECT_EQ(m.temperature_c, 21.43);
  EXPECT_TRUE(std::isnan(m.humidity_pct));
  EXPECT_FALSE(m.is_reference);
  EXPECT_TRUE(std::isnan(m.known_height_m));
}

TEST(BaroReading, AReferenceSampleCarriesItsHeight) {
  const baro_t m = to_message({100000.0, 20.0, 45.2}, 1, "s", "B1", 2.4);
  EXPECT_TRUE(m.is_reference);
  EXPECT_EQ(m.known_height_m, 2.4);
  EXPECT_EQ(m.humidity_pct, 45.2);
  // A reference station at the site origin is still a reference.
  EXPECT_TRUE(to_message({100000.0, 20.0, kNaN}, 1, "s", "B1", 0.0).is_reference);
}

}  // namespace
}  // namespace ips::baro
