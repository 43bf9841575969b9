#pragma once
// One reading of one phone sensor as the apps send it, in SI units after conversion (m/s^2 specific
// force, rad/s, microtesla), stamped with the phone's own clock. The parsers of every wire format
// (csv_row.hpp, sensor_logger_json.hpp) produce these; the assembler (imu_assembler.hpp) turns
// them into imu_t. Pure.
#include <array>
#include <cstdint>
#include <string_view>

namespace ips::phone_imu {

enum class SensorKind : uint8_t { kAccel, kGyro, kMag };

struct SensorSample {
  SensorKind kind = SensorKind::kAccel;
  int64_t device_us = 0;  // the phone's clock, us (epoch or since boot: whatever the app sends)
  std::array<double, 3> xyz{};
};

// Units the apps use where they differ; the parsers multiply by these to reach SI.
inline constexpr double kStandardGravity = 9.80665;  // m/s^2 per g (Sensor Logger's UNITS.md)
inline constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;

struct UnitScales {
  double accel = 1.0;  // to m/s^2: 1 (m/s^2) or kStandardGravity (g)
  double gyro = 1.0;   // to rad/s: 1 (rad/s) or kRadPerDeg (deg/s)
  double mag = 1.0;    // to microtesla: 1 (uT) or 0.1 (mG, 1 mG = 0.1 uT)
};

// "m/s2" | "g"; "rad/s" | "deg/s"; "uT" | "mG". False for another name.
bool accel_scale_from_name(std::string_view name, double& scale);
bool gyro_scale_from_name(std::string_view name, double& scale);
bool mag_scale_from_name(std::string_view name, double& scale);

}  // namespace ips::phone_imu
