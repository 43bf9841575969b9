#pragma once
// Opening an LCM instance with a clear error instead of liblcm's own stderr chatter.
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <stdexcept>
#include <string>

namespace ips {

struct LcmOpenError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The URL in effect: `url` if not empty, else LCM_DEFAULT_URL, else LCM's default.
std::string effective_lcm_url(const std::string& url);

// Opens LCM on `url` (empty: default). Throws LcmOpenError with one line saying which URL failed
// and why (liblcm's own messages folded in), and what to try.
std::unique_ptr<lcm::LCM> open_lcm(const std::string& url);

}  // namespace ips
