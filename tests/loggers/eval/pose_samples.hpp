#pragma once
// pose_t samples for the ips-eval tests: times are offsets from a plausible epoch (utimes <= 0
// are invalid input).
#include <ips/altitude_t.hpp>
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

// A 2D estimator's pose: z is the site's fixed tag height (STATUS_2D).
inline pose_t planar_pose(utime_t t, const std::string& tag, double x, double y, double z) {
  pose_t p = pose(t, tag, x, y, z);
  p.status = int32_t{pose_t::STATUS_OK} | pose_t::STATUS_2D;
  return p;
}

inline altitude_t altitude(utime_t t, const std::string& tag, double height_m, int floor = 0,
                           bool floor_valid = false) {
  altitude_t a{};
  a.utime = kT0 + t;
  a.tag_id = tag;
  a.height_m = height_m;
  a.floor = floor;
  a.floor_valid = floor_valid;
  return a;
}

}  // namespace ips::eval::testing
