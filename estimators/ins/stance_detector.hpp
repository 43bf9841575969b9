#pragma once
// Stance (zero-velocity) detection for a foot-mounted IMU: the SHOE detector (Skog et al., the
// OpenShoe detector that 001 section 2 "ZUPT (3.2.1)" prints, with the gravity removal that the
// printed formula lacks):
//   T_n = 1/W sum_{k in window} ( |a_k - g a_bar/|a_bar||^2 / sigma_a^2 + |w_k|^2 / sigma_g^2 )
// over the last W samples (causal), a_bar the window's mean specific force. The foot is in
// stance while T_n < threshold. 001's W = 3 at 200 Hz; OpenShoe's sigma_a = 0.01 m/s^2,
// sigma_g = 0.1 deg/s, threshold 3e4: a still foot scores ~|noise|^2/sigma^2 (a few units), a
// swing ~1e5 and more.
#include <Eigen/Core>
#include <array>

namespace ips::ins {

struct StanceDetectorParams {
  int window_samples = 3;
  double accel_sigma_mps2 = 0.01;
  double gyro_sigma_rps = 0.1 * 3.14159265358979323846 / 180.0;
  double threshold = 3e4;
  double gravity_mps2 = 9.81;
};

class StanceDetector {
 public:
  static constexpr int kMaxWindow = 64;

  explicit StanceDetector(const StanceDetectorParams& p = {}) : p_(p) {}

  void reset() {
    count_ = 0;
    head_ = 0;
    statistic_ = 0;
  }
  // Adds a sample (specific force, angular rate with the known bias removed); true when the
  // window is full and its statistic is below the threshold.
  bool add(const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro) {
    const int w = p_.window_samples;
    accel_[head_] = accel;
    gyro_[head_] = gyro;
    head_ = (head_ + 1) % w;
    if (count_ < w) ++count_;
    if (count_ < w) {
      statistic_ = 0;
      return false;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int k = 0; k < w; ++k) mean += accel_[k];
    mean /= w;
    const double norm = mean.norm();
    if (!(norm > 0)) {
      statistic_ = 0;
      return false;
    }
    const Eigen::Vector3d gravity = p_.gravity_mps2 * mean / norm;
    const double ia = 1.0 / (p_.accel_sigma_mps2 * p_.accel_sigma_mps2);
    const double ig = 1.0 / (p_.gyro_sigma_rps * p_.gyro_sigma_rps);
    double t = 0;
    for (int k = 0; k < w; ++k)
      t += (accel_[k] - gravity).squaredNorm() * ia + gyro_[k].squaredNorm() * ig;
    statistic_ = t / w;
    return statistic_ < p_.threshold;
  }
  // T_n of the last sample (0 until the window is full).
  double statistic() const { return statistic_; }

 private:
  StanceDetectorParams p_;
  std::array<Eigen::Vector3d, kMaxWindow> accel_{};
  std::array<Eigen::Vector3d, kMaxWindow> gyro_{};
  int count_ = 0;
  int head_ = 0;
  double statistic_ = 0;
};

}  // namespace ips::ins
