#pragma once
// Site-frame geometry: x east, y north, z up, metres; angles in radians from +x,
// counter-clockwise.
#include <Eigen/Core>
#include <cmath>

namespace ips {

inline double horizontal_distance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::hypot(a.x() - b.x(), a.y() - b.y());
}

// Wraps an angle to (-pi, pi].
inline double wrap_angle(double a) {
  a = std::remainder(a, 2.0 * M_PI);
  return a <= -M_PI ? a + 2.0 * M_PI : a;
}

inline constexpr double deg_to_rad(double d) { return d * M_PI / 180.0; }
inline constexpr double rad_to_deg(double r) { return r * 180.0 / M_PI; }

}  // namespace ips
