#pragma once
// Logging set-up shared by every program (spdlog on stderr), and a rate limiter so that a
// flood of bad input cannot flood the terminal.
#include <cstdint>
#include <string>

namespace ips {

// Sets the global level from a name (trace, debug, info, warn, error, off). Returns false for an
// unknown name.
bool set_log_level(const std::string& level);

// Allows at most `burst` events per `period_us` of the caller's clock; counts what it suppressed.
class RateLimiter {
 public:
  RateLimiter(int64_t period_us = 1'000'000, int burst = 5) : period_us_(period_us), burst_(burst) {}
  // True when the event at time `now_us` may be logged.
  bool allow(int64_t now_us);
  // Events refused so far.
  int64_t suppressed() const { return suppressed_; }

 private:
  int64_t period_us_;
  int burst_;
  int64_t window_start_us_ = INT64_MIN;
  int in_window_ = 0;
  int64_t suppressed_ = 0;
};

}  // namespace ips
