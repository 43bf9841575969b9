#pragma once
// Phone sensors report at their own instants (accelerometer and gyroscope at 100..400 Hz, not
// together; magnetometer slower). imu_t carries all three, so readings are assembled:
//
//   accel-driven (default): one imu_t per accelerometer reading, at its time, with the latest
//     gyroscope and magnetometer readings taken at most `window_us` before or at it (NaN when
//     there is none that recent). This is the stream a PDR or INS at the accelerometer's rate
//     wants: every message has the specific force, and the rate of the others rides along.
//     Readings of one batch are handled in time order, a gyroscope or magnetometer reading
//     before an accelerometer reading of the same time (the UDP apps send all three together).
//     An accelerometer reading not newer than the last one published (a resent batch, a
//     duplicate) is dropped and counted.
//   per-sample: one imu_t per reading of any sensor, the other two NaN.
//
// Pure: no clock, no I/O.
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <vector>

#include "drivers/phone_imu/sensor_sample.hpp"

namespace ips::phone_imu {

struct AssembledImu {
  int64_t device_us = 0;
  std::array<double, 3> accel, gyro, mag;
};

struct AssemblerConfig {
  bool per_sample = false;
  int64_t window_us = 50'000;
};

class ImuAssembler {
 public:
  explicit ImuAssembler(AssemblerConfig config = {}) : config_(config) {}
  // Sorts `batch` in place and emits what it completes; returns the readings dropped.
  int64_t add_batch(std::vector<SensorSample>& batch,
                    const std::function<void(const AssembledImu&)>& emit);
  void reset();

 private:
  AssemblerConfig config_;
  bool have_[3] = {false, false, false};
  SensorSample latest_[3];
  bool have_accel_out_ = false;
  int64_t last_accel_us_ = 0;
};

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace ips::phone_imu
