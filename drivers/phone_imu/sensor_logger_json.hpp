#pragma once
// The JSON batches that Sensor Logger (Kelvin Choi, tszheichoi/awesome-sensor-logger, PUSHING.md)
// POSTs during a recording with HTTP Push on:
//
//   {"messageId": 12, "sessionId": "…", "deviceId": "…",
//    "payload": [{"name": "totalacceleration", "time": 1698501144401773000,
//                 "values": {"x": 0.06, "y": 9.79, "z": 0.1}}, …]}
//
// `time` is UTC epoch nanoseconds of the phone's clock (a number, or a string of digits as in the
// app's JSON export). Units (UNITS.md): accelerometer m/s^2, gyroscope rad/s, magnetometer uT. On
// Android `accelerometer` is acceleration without gravity and `totalacceleration` the raw reading
// with gravity (specific force, what imu_t carries), so the accelerometer entry read is
// `totalacceleration` unless told otherwise; `gyroscope` and `magnetometer` are the calibrated
// ones (`gyroscopeuncalibrated`, `magnetometeruncalibrated`, `accelerometeruncalibrated` on
// request). Entries of other sensors (location, gravity, orientation, …) are skipped.
//
// A body that is not such an object is refused with a reason; an entry of a wanted sensor with a
// missing or malformed field is skipped and counted, the rest of the batch is kept. Our own
// parser: strict JSON (RFC 8259) nesting at most 32 deep, strings captured up to 256 bytes.
// Pure: no I/O, never throws.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/phone_imu/sensor_sample.hpp"

namespace ips::phone_imu {

struct JsonSensorNames {
  std::string accel = "totalacceleration";
  std::string gyro = "gyroscope";
  std::string mag = "magnetometer";
  UnitScales units;
};

struct JsonBatch {
  bool ok = false;
  std::string reason;     // when !ok: printable ASCII
  std::string device_id;  // the deviceId, as sent (empty when absent)
  std::vector<SensorSample> samples;
  int64_t other_entries = 0;  // entries of sensors not read
  int64_t bad_entries = 0;    // entries of a read sensor that were malformed
  std::string first_bad;      // the reason of the first of them
};

JsonBatch parse_sensor_logger_batch(std::string_view body, const JsonSensorNames& names);

}  // namespace ips::phone_imu
