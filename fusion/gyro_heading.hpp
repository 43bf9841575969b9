#pragma once
// The turn of a tag about the vertical from the gyro it carries (the phone's IMU): the angular
// rate projected on the up direction, which is the accelerometer's specific force low-passed
// (walking accelerations average out over a second; level or tilted, the phone's own up does
// not matter). Integrated into a heading series over the last few seconds, so that ips-fuse can
// ask how far the tag turned between two times, also for times it fuses again after a late
// message. Pure: samples in, turns out.
#include <Eigen/Core>
#include <cmath>
#include <deque>
#include <optional>

#include "core/time.hpp"

namespace ips::fusion {

class GyroHeading {
 public:
  // The time of the newest sample taken, 0 before the first.
  utime_t newest() const { return series_.empty() ? 0 : series_.back().t; }
  // Returns false (sample not used) when it is not after the previous one, not finite, or beyond
  // any MEMS IMU's range (2000 deg/s, 16 g).
  bool add(utime_t t, const Eigen::Vector3d& gyro_rad_s, const Eigen::Vector3d& accel_mps2) {
    if (!gyro_rad_s.allFinite() || !accel_mps2.allFinite() ||
        gyro_rad_s.cwiseAbs().maxCoeff() > kMaxRateRadS ||
        accel_mps2.cwiseAbs().maxCoeff() > kMaxAccelMps2)
      return false;
    if (!series_.empty() && t <= series_.back().t) return false;
    if (series_.empty()) {
      up_ = accel_mps2;
      series_.push_back({t, 0.0});
      return true;
    }
    const double dt = utime_to_s(t - series_.back().t);
    if (dt > kMaxGapS) {  // a gap in the IMU stream: start a new series
      series_.clear();
      up_ = accel_mps2;
      series_.push_back({t, 0.0});
      return true;
    }
    const double a = dt / (kGravityTauS + dt);
    up_ += a * (accel_mps2 - up_);
    const double norm = up_.norm();
    const double rate = norm > 1.0 ? gyro_rad_s.dot(up_) / norm : 0.0;
    series_.push_back({t, series_.back().yaw + rate * dt});
    while (series_.size() > 2 && series_.front().t < t - s_to_utime(kKeepS)) series_.pop_front();
    return true;
  }

  // The turn (rad, counter-clockwise seen from above) from a to b, or nullopt when the series
  // does not cover both.
  std::optional<double> turn(utime_t a, utime_t b) const {
    const auto ya = yaw_at(a), yb = yaw_at(b);
    if (!ya || !yb) return std::nullopt;
    return *yb - *ya;
  }

 private:
  static constexpr double kMaxRateRadS = 35.0;
  static constexpr double kMaxAccelMps2 = 160.0;
  static constexpr double kGravityTauS = 1.0;
  static constexpr double kMaxGapS = 0.5;
  static constexpr double kKeepS = 5.0;
  // A time this far after the newest sample is still answered with it (IMU samples arrive
  // interleaved with the other messages, a few ms apart).
  static constexpr double kReachS = 0.05;
  struct Sample {
    utime_t t;
    double yaw;
  };

  std::optional<double> yaw_at(utime_t t) const {
    if (series_.size() < 2 || t < series_.front().t ||
        t > series_.back().t + s_to_utime(kReachS))
      return std::nullopt;
    if (t >= series_.back().t) return series_.back().yaw;
    // Binary search, then linear interpolation.
    size_t lo = 0, hi = series_.size() - 1;
    while (hi - lo > 1) {
      const size_t mid = (lo + hi) / 2;
      (series_[mid].t <= t ? lo : hi) = mid;
    }
    const Sample& s0 = series_[lo];
    const Sample& s1 = series_[hi];
    const double f = static_cast<double>(t - s0.t) / static_cast<double>(s1.t - s0.t);
    return s0.yaw + f * (s1.yaw - s0.yaw);
  }

  Eigen::Vector3d up_ = Eigen::Vector3d::Zero();
  std::deque<Sample> series_;
};

}  // namespace ips::fusion
