#include "drivers/phone_imu/imu_assembler.hpp"

#include <algorithm>

namespace ips::phone_imu {

namespace {
// Gyroscope and magnetometer before an accelerometer reading of the same time.
int rank(SensorKind k) { return k == SensorKind::kAccel ? 2 : k == SensorKind::kGyro ? 0 : 1; }
constexpr std::array<double, 3> kAbsent{kNaN, kNaN, kNaN};
}  // namespace

void ImuAssembler::reset() {
  have_[0] = have_[1] = have_[2] = false;
  have_accel_out_ = false;
}

int64_t ImuAssembler::add_batch(std::vector<SensorSample>& batch,
                                const std::function<void(const AssembledImu&)>& emit) {
  std::stable_sort(batch.begin(), batch.end(), [](const SensorSample& a, const SensorSample& b) {
    return a.device_us != b.device_us ? a.device_us < b.device_us : rank(a.kind) < rank(b.kind);
  });
  int64_t dropped = 0;
  for (const SensorSample& s : batch) {
    const auto k = static_cast<size_t>(s.kind);
    if (config_.per_sample) {
      AssembledImu m{s.device_us, kAbsent, kAbsent, kAbsent};
      (k == 0 ? m.accel : k == 1 ? m.gyro : m.mag) = s.xyz;
      emit(m);
      continue;
    }
    if (s.kind != SensorKind::kAccel) {
      if (!have_[k] || s.device_us >= latest_[k].device_us) {
        latest_[k] = s;
        have_[k] = true;
      }
      continue;
    }
    if (have_accel_out_ && s.device_us <= last_accel_us_) {
      ++dropped;
      continue;
    }
    AssembledImu m{s.device_us, s.xyz, kAbsent, kAbsent};
    for (size_t o = 1; o < 3; ++o) {
      if (!have_[o]) continue;
      const int64_t age = s.device_us - latest_[o].device_us;
      if (age >= 0 && age <= config_.window_us) (o == 1 ? m.gyro : m.mag) = latest_[o].xyz;
    }
    have_accel_out_ = true;
    last_accel_us_ = s.device_us;
    emit(m);
  }
  return dropped;
}

}  // namespace ips::phone_imu
