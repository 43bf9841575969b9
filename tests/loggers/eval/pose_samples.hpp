#pragma once
// pose_t samples for the ips-eval tests: times are offsets from a plausible epoch (utimes <= 0
// are invalid input).
#include <ips/pose_t.hpp>
#include <string>

#include "core/time.hpp"

namespace ips::eval::testing {

constexpr utime_t kT0 = 1767225600000000;  // 2026-01-01 00:00:00 UTC

inline pose_t pose(utime_t t, const std::string& tag, double x, double y, double z) {
  pose_t p{};
  p.utime = kT0 + t;
  p.tag_id = tag;
  p.position[0] = x;
  p.position[1] = y;
  p.position[2] = z;
  return p;
}

}  // namespace ips::eval::testing
