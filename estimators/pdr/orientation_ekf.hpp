#pragma once
// Attitude of a phone from its IMU: a multiplicative quaternion EKF (source 002 section 2.6,
// written in error-state form: the quaternion is kept normalised and the 3-vector attitude error,
// in the site/world frame, is what the filter estimates, with the gyro bias).
//   - prediction: q <- q (x) Exp((omega - b) dt); error dynamics d(dtheta)/dt = -R(q) db;
//   - accelerometer correction: a/|a| against R(q)' e_z (gravity, world z up), trusted when the
//     phone is still and weakly while it moves (walking accelerations average out);
//   - magnetometer correction of the heading only, when the field looks undisturbed: its norm
//     within a tolerance of the Earth's field and its dip within a tolerance of the site's
//     inclination (002 section 4: "gate on |m| and on dip angle"); the reference is the Earth
//     field in ENU, [sin D cos I, cos D cos I, -sin I] (002's printed reference confuses
//     declination with dip);
//   - gyro bias learned in still periods: a zero-rate update (omega - b = 0) while still.
// Frames: body = the Android device frame; world = the site frame, x East, y North, z up.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "core/ekf.hpp"

namespace ips::pdr {

struct EarthField {
  double magnitude_ut = 50.0;      // Prague (002 sections 2.4, 2.6)
  double inclination_deg = 66.0;   // dip, positive down
  double declination_deg = 4.82;   // east of true north
  Eigen::Vector3d world() const;   // the field in ENU, microtesla
};

struct OrientationNoise {
  double gyro_noise_rad_s = 0.003;    // white noise density, rad/s/sqrt(Hz)
  double bias_walk_rad_s2 = 1e-4;     // gyro bias random walk, rad/s^2/sqrt(Hz)
  double gravity_sigma_still = 0.02;  // unit-vector noise of a/|a| when still
  double gravity_sigma_moving = 0.5;  // ... while walking
  double mag_heading_sigma_rad = 0.2;
  double zero_rate_sigma_rad_s = 0.01;
};

// One magnetometer heading update: whether the field passed the norm and dip checks, whether
// the update was made (not gated), and its innovation with the prediction's and the assumed
// measurement variance (rad^2), for the consistency monitor.
struct MagUpdate {
  bool field_ok = false;
  bool accepted = false;
  double innovation = 0, hph = 0, r = 0;
};

// Quasi-static field check (Afzal et al. 2011, "Use of earth's magnetic field for mitigating
// gyroscope errors regardless of magnetic perturbation"): the world-frame field, i.e. each
// magnetometer reading turned by the gyro-propagated attitude, stays the same while the walker
// moves through an undisturbed field, however the phone turns; a disturbance that varies in
// space shows as a change along the way. `segment_means` are the world-frame field's means over
// consecutive stretches (one per step) of a window of a few metres; the field is quasi-static
// when, over the window, its horizontal heading varies by at most max_heading_rad (the
// magnetometer's heading change agrees with the gyro's), its norm by at most max_norm_ut and
// its dip by at most max_dip_rad (max - min over the segments). Fewer than two segments: not
// checked (ok false, spreads NaN).
struct QuasiStaticField {
  bool ok = false;
  double heading_spread_rad = 0, norm_spread_ut = 0, dip_spread_rad = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();  // the segments' mean field
};
QuasiStaticField check_quasi_static(const std::vector<Eigen::Vector3d>& segment_means,
                                    double max_heading_rad, double max_norm_ut,
                                    double max_dip_rad);

class OrientationEkf {
 public:
  // Still phone: tilt from the mean specific force; heading from the mean field (TRIAD) when
  // `mag` is finite, else `yaw_rad` for the device x axis; gyro bias = the mean rate.
  void initialise(const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
                  const Eigen::Vector3d& mag, const EarthField& field, double yaw_rad,
                  double initial_bias_sigma_rad_s);
  void predict(const Eigen::Vector3d& gyro, double dt, const OrientationNoise& n);
  void update_gravity(const Eigen::Vector3d& accel, double sigma);
  // False (nothing changed) when the field fails the norm or dip check.
  bool update_mag_heading(const Eigen::Vector3d& mag, const EarthField& field,
                          double norm_tolerance, double dip_tolerance_rad, double sigma_rad);
  // The same with the field already in the world frame (e.g. a mean of q m over a period, in
  // which the walk's tilt oscillation and the sensor noise average out); innovations beyond
  // gate_chi2 are refused. check_only: the innovation only, nothing changed.
  MagUpdate update_mag_heading_world(const Eigen::Vector3d& m_w, const EarthField& field,
                                     double norm_tolerance, double dip_tolerance_rad,
                                     double sigma_rad, double gate_chi2 = kNoGate,
                                     bool check_only = false);
  void update_zero_rate(const Eigen::Vector3d& gyro, double sigma);

  const Eigen::Quaterniond& q() const { return q_; }  // body -> world
  const Eigen::Vector3d& bias() const { return b_; }
  const Mat<6>& P() const { return P_; }
  // Heading (from +x, CCW) of a body axis projected on the horizontal plane.
  double heading_of(const Eigen::Vector3d& body_axis) const;
  double yaw_variance() const { return P_(2, 2); }

 private:
  void apply(const Vec<6>& dx);
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d b_ = Eigen::Vector3d::Zero();
  Vec<6> x_ = Vec<6>::Zero();  // the error state, always zero between updates
  Mat<6> P_ = Mat<6>::Identity();
};

// Skew-symmetric cross-product matrix: skew(a) b = a x b.
inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

// Exp of a rotation vector as a quaternion.
inline Eigen::Quaterniond rotation_exp(const Eigen::Vector3d& v) {
  const double angle = v.norm();
  if (angle < 1e-12) return Eigen::Quaterniond(1, 0.5 * v.x(), 0.5 * v.y(), 0.5 * v.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle));
}

}  // namespace ips::pdr
