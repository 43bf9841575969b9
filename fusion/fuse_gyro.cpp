// The tag's gyro (IMU): its turn about the vertical (gyro_heading.hpp) turns the constant-velocity
// motion between displacements (predict(), fuse_displacements.cpp).
#include "fusion/fuse_estimator.hpp"

#include "fusion/fuse_inputs.hpp"

namespace ips::fusion {

void FuseEstimator::on_imu(const imu_t& m) {
  if (!params_.gyro_turns) return;
  Track* t = track_for(m.device_id, m.utime, [this, m] { on_imu(m); });
  if (!t) return;
  const Eigen::Vector3d gyro(m.gyro[0], m.gyro[1], m.gyro[2]);
  const Eigen::Vector3d accel(m.accel[0], m.accel[1], m.accel[2]);
  // A sample at or before the previous one is a duplicate or reordered on the way (a lossy LAN
  // repeats and reorders datagrams), not invalid. Within the reorder tolerance the next
  // sample's interval has covered it (a 100 Hz turn integrated over 20 ms instead of 10): no
  // fault. The soak's switch reorders 0.2 % of datagrams, and those counted as late kept
  // ips-fuse degraded.
  if (const utime_t newest = t->gyro.newest(); newest != 0 && m.utime <= newest) {
    count_out_of_turn(m.utime, newest, s_to_utime(params_.max_delay_s), stats_.dropped_imu_repeated,
                      stats_.dropped_imu_reordered, stats_.dropped_imu_late);
    return;
  }
  if (!t->gyro.add(m.utime, gyro, accel)) {
    ++stats_.dropped_invalid;
    return;
  }
  ++stats_.imu_used;
}

}  // namespace ips::fusion
