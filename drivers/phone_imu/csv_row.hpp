#pragma once
// Rows of text with a timestamp and sensor triples: the UDP datagrams of the Android streaming apps
// and the lines of recorded files. Which column holds what is a RowFormat, read from a column
// mapping (--columns, --file-columns):
//
//   tagged   IMU+GPS-Stream / Wireless IMU (Axel Lorenz, de.lorenz_fenster.sensorstreamgps): a
//            timestamp, then for each sensor its id and its values, e.g.
//              890.71558, 3, 0.076, 9.809, 0.565, 4, -0.559, 0.032, -0.134, 5, -21.660,-36.960,-28.140
//            ids 3 accelerometer (m/s^2), 4 gyroscope (rad/s), 5 magnetometer (uT) are read; the
//            app's other ids are skipped with their value counts (1 GPS and 81 orientation,
//            82 linear acceleration, 83 gravity, 84 rotation vector: 3 values; 85 pressure,
//            86 battery temperature: 1 value); any other id is an error. Timestamp in seconds.
//   t,ax,ay,az,gx,gy,gz,mx,my,mz   positional: one name per column, in order. `t` the time;
//            ax..az, gx..gz, mx..mz the axes (each sensor all three or none); `-` a column to
//            ignore. Columns after the last named one are ignored (HyperIMU appends orientation,
//            light, GPS). A sensor whose three fields are all empty is absent from that row.
//
// Fields may carry spaces around them (the apps pad with %7.3f). Numbers are decimal with an
// optional sign, fraction and exponent (Java's Float.toString writes 1.0E-5); nan and inf are
// refused. The time must be >= 0 and fit in us. Pure: no I/O, never throws.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/phone_imu/sensor_sample.hpp"

namespace ips::phone_imu {

enum class TimeUnit : uint8_t { kS, kMs, kUs, kNs };
// "s" | "ms" | "us" | "ns".
std::optional<TimeUnit> time_unit_from_name(std::string_view name);

struct RowFormat {
  char separator = ',';
  bool tagged = true;
  TimeUnit time_unit = TimeUnit::kS;
  UnitScales units;
  // Positional: the column of the time, and of each sensor's x (y, z follow their own columns).
  int time_column = 0;
  std::array<std::array<int, 3>, 3> axis_column{{{-1, -1, -1}, {-1, -1, -1}, {-1, -1, -1}}};
  int columns_needed = 1;  // fields a positional row must have at least
};

// Reads a column mapping ("tagged" or positional names as above); the reason when it is not one.
std::string parse_column_mapping(std::string_view spec, RowFormat& format);

inline constexpr size_t kMaxRowFields = 256;

struct RowParse {
  bool ok = false;
  std::string reason;  // when !ok: printable ASCII
  int64_t device_us = 0;
  std::array<SensorSample, 3> samples{};
  int count = 0;  // samples in this row (0 when a row holds none of the three sensors)
};

RowParse parse_row(std::string_view row, const RowFormat& format);

// A number field (spaces around allowed) as above; false for anything else.
bool parse_number(std::string_view field, double& value);
// A time field in `unit` -> us (integers exactly, fractions rounded); false when not a number,
// negative, or beyond +-4e18 us.
bool parse_time_us(std::string_view field, TimeUnit unit, int64_t& us);

}  // namespace ips::phone_imu
