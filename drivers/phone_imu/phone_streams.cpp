#include "drivers/phone_imu/phone_streams.hpp"

#include "core/time.hpp"

namespace ips::phone_imu {

PhoneStreams::Device& PhoneStreams::device(const std::string& id) {
  for (auto it = devices_.begin(); it != devices_.end(); ++it) {
    if (it->id == id) {
      devices_.splice(devices_.begin(), devices_, it);
      return devices_.front();
    }
  }
  if (devices_.size() >= config_.max_devices) devices_.pop_back();
  devices_.push_front(Device{id, ClockOffset(config_.clock), ImuAssembler(config_.assembler)});
  return devices_.front();
}

BatchResult PhoneStreams::on_batch(const std::string& device_id, int64_t host_us,
                                   std::vector<SensorSample>& batch) {
  BatchResult r;
  if (batch.empty()) return r;
  Device& dev = device(device_id);
  if (config_.fixed_offset_us) {
    r.offset_us = *config_.fixed_offset_us;
  } else {
    for (const SensorSample& s : batch)
      if (dev.clock.add(host_us, s.device_us)) {
        r.clock_reset = true;
        dev.assembler.reset();  // readings before the jump are on another time line
      }
    r.offset_us = dev.clock.offset_us();
  }
  msg_.source = config_.source;
  msg_.device_id = device_id;
  const int64_t not_newer = dev.assembler.add_batch(batch, [&](const AssembledImu& a) {
    // No overflow: phone times are below 4e18 us (csv_row.hpp), offsets their differences.
    const int64_t utime = a.device_us + r.offset_us;
    if (!plausible_utime(utime)) {
      ++r.dropped;
      return;
    }
    msg_.utime = utime;
    msg_.device_utime = a.device_us;
    for (size_t i = 0; i < 3; ++i) {
      msg_.accel[i] = a.accel[i];
      msg_.gyro[i] = a.gyro[i];
      msg_.mag_ut[i] = a.mag[i];
    }
    publish_(msg_);
    ++r.published;
  });
  r.dropped += not_newer;
  return r;
}

}  // namespace ips::phone_imu
