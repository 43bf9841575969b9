#include "core/logging.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace ips {

bool set_log_level(const std::string& level) {
  auto lvl = spdlog::level::from_str(level);
  // from_str maps unknown names to "off"; only accept "off" when asked for it.
  if (lvl == spdlog::level::off && level != "off") return false;
  static bool configured = false;
  if (!configured) {
    auto logger = spdlog::stderr_color_mt("ips");
    logger->set_pattern("%Y-%m-%d %H:%M:%S.%e %^%l%$ %v");
    spdlog::set_default_logger(logger);
    configured = true;
  }
  spdlog::set_level(lvl);
  return true;
}

bool RateLimiter::allow(int64_t now_us) {
  if (window_start_us_ == INT64_MIN || now_us - window_start_us_ >= period_us_ ||
      now_us < window_start_us_) {
    window_start_us_ = now_us;
    in_window_ = 0;
  }
  if (in_window_ < burst_) {
    ++in_window_;
    return true;
  }
  ++suppressed_;
  return false;
}

}  // namespace ips
