#pragma once
// The message timeline's "now" on a live bus: the newest message time an estimator took, advanced
// by the host's monotonic clock since it was taken. ips-aoa and ips-fuse close a BLE epoch by it
// when the bus has been quiet; a step of the wall clock (NTP, by hand) moves neither part, so it
// closes no epoch early (issue 26's soak: +5 s closed them and their angles were dropped as late).
#include "core/time.hpp"

namespace ips {

class MessageClock {
 public:
  // The estimator's newest message time after taking a message (unchanged when it took none).
  void saw(utime_t newest) {
    if (newest == newest_) return;
    newest_ = newest;
    taken_at_ = monotonic_utime_now();
  }
  // 0 before the first message.
  utime_t now() const { return newest_ == 0 ? 0 : newest_ + (monotonic_utime_now() - taken_at_); }

 private:
  utime_t newest_ = 0;
  utime_t taken_at_ = 0;
};

}  // namespace ips
