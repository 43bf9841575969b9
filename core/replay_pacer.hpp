#pragma once
// Paces recorded frames by their timestamps (ips-uwb-can's candump lines; ips-uwb-tdoa-anchors'
// records at --rate, record k stamped k seconds and paced at speed = rate; core/paced_input.hpp):
// a frame stamped t is handed on at wall0 + (t - t0) / speed. When handing on falls behind by more than kMaxLag (a stall, or a live
// stream whose lines arrive later than their timestamps say) or the timestamps go backwards, the
// schedule restarts at that frame, so frames are never caught up in a burst, which would overflow
// the receive buffers of LCM subscribers. speed <= 0: no pacing. Pure: the caller gives the time.
#include <chrono>
#include <cstdint>

#include "core/time.hpp"

namespace ips {

class ReplayPacer {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::milliseconds kMaxLag{100};

  explicit ReplayPacer(double speed) : speed_(speed) {}

  // Milliseconds to wait before the frame stamped `t` is due at `now` (0: hand it on now).
  int64_t wait_ms(utime_t t, Clock::time_point now) {
    if (speed_ <= 0) return 0;
    if (!started_ || t < t0_) return restart(t, now);
    const auto due =
        wall0_ +
        std::chrono::duration_cast<Clock::duration>(
            std::chrono::duration<double, std::micro>(static_cast<double>(t - t0_) / speed_));
    if (due <= now) return now - due > kMaxLag ? restart(t, now) : 0;
    return std::chrono::ceil<std::chrono::milliseconds>(due - now).count();
  }

 private:
  int64_t restart(utime_t t, Clock::time_point now) {
    started_ = true;
    t0_ = t;
    wall0_ = now;
    return 0;
  }

  double speed_;
  bool started_ = false;
  utime_t t0_ = 0;
  Clock::time_point wall0_;
};

}  // namespace ips
