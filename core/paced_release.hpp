#pragma once
// Putting recorded messages (a capture file, a phone's recording) back on the bus at their own
// pace: message k goes out (utime_k - utime_0) / speed after the first, while the node keeps
// serving its loop (HEALTH, signals) in the meantime. speed <= 0: as fast as possible. A time
// earlier than one already released goes out at once.
#include <algorithm>
#include <chrono>

#include "core/node.hpp"
#include "core/time.hpp"

namespace ips {

class PacedRelease {
 public:
  PacedRelease(Node& node, double speed) : node_(node), speed_(speed) {}

  // Waits until the message stamped `utime` is due; false when the node was asked to stop.
  bool wait(utime_t utime) {
    if (first_) {
      first_ = false;
      utime0_ = utime;
      wall0_ = std::chrono::steady_clock::now();
    }
    if (speed_ > 0) {
      const auto due = wall0_ + std::chrono::microseconds(static_cast<int64_t>(
                                    static_cast<double>(utime - utime0_) / speed_));
      for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                              due - std::chrono::steady_clock::now())
                              .count();
        if (left <= 0) break;
        if (!node_.spin_once(static_cast<int>(std::min<int64_t>(left, 100)))) return false;
      }
    }
    return node_.spin_once(0);
  }

 private:
  Node& node_;
  double speed_;
  bool first_ = true;
  utime_t utime0_ = 0;
  std::chrono::steady_clock::time_point wall0_;
};

}  // namespace ips
