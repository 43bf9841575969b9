#pragma once
// Readings of every phone to imu_t: per device (its id: --device-id, the JSON deviceId or the
// sender's address) a clock offset (clock_offset.hpp) and an assembler (imu_assembler.hpp).
// Each batch (one datagram, one POST body, one file line) first feeds the offset with every
// reading's (reception time, phone time), then is assembled, and every message gets
// utime = phone time + offset (or + a fixed offset for files), device_utime = phone time.
// At most max_devices phones are tracked: a new one beyond that replaces the one heard from
// least recently, so a sender inventing ids cannot grow memory. Pure: the caller gives the time.
#include <cstdint>
#include <functional>
#include <ips/imu_t.hpp>
#include <list>
#include <optional>
#include <string>
#include <vector>

#include "drivers/phone_imu/clock_offset.hpp"
#include "drivers/phone_imu/imu_assembler.hpp"
#include "drivers/phone_imu/sensor_sample.hpp"

namespace ips::phone_imu {

struct PhoneStreamsConfig {
  std::string source = "ips-phone-imu";
  AssemblerConfig assembler;
  ClockOffsetConfig clock;
  std::optional<int64_t> fixed_offset_us;  // files: utime = phone time + this, no estimate
  size_t max_devices = 16;
};

struct BatchResult {
  int64_t published = 0;
  int64_t dropped = 0;      // readings not published (not newer, utime not plausible)
  bool clock_reset = false;  // the offset estimate of this device was reset (a clock jump)
  int64_t offset_us = 0;     // the offset used
};

class PhoneStreams {
 public:
  PhoneStreams(PhoneStreamsConfig config, std::function<void(const imu_t&)> publish)
      : config_(std::move(config)), publish_(std::move(publish)) {}

  BatchResult on_batch(const std::string& device_id, int64_t host_us,
                       std::vector<SensorSample>& batch);
  size_t devices() const { return devices_.size(); }

 private:
  struct Device {
    std::string id;
    ClockOffset clock;
    ImuAssembler assembler;
  };
  Device& device(const std::string& id);

  PhoneStreamsConfig config_;
  std::function<void(const imu_t&)> publish_;
  std::list<Device> devices_;  // most recently heard first
  imu_t msg_;
};

}  // namespace ips::phone_imu
