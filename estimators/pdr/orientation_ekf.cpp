#include "estimators/pdr/orientation_ekf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/geometry.hpp"

namespace ips::pdr {

Eigen::Vector3d EarthField::world() const {
  const double inc = deg_to_rad(inclination_deg), dec = deg_to_rad(declination_deg);
  return magnitude_ut *
         Eigen::Vector3d(std::sin(dec) * std::cos(inc), std::cos(dec) * std::cos(inc),
                         -std::sin(inc));
}

QuasiStaticField check_quasi_static(const std::vector<Eigen::Vector3d>& segment_means,
                                    double max_heading_rad, double max_norm_ut,
                                    double max_dip_rad) {
  QuasiStaticField q;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (segment_means.size() < 2) {
    q.heading_spread_rad = q.norm_spread_ut = q.dip_spread_rad = nan;
    return q;
  }
  for (const Eigen::Vector3d& m : segment_means) q.mean += m;
  q.mean /= static_cast<double>(segment_means.size());
  const double ref = std::atan2(q.mean.y(), q.mean.x());
  double h_lo = 0, h_hi = 0;
  double n_lo = HUGE_VAL, n_hi = -HUGE_VAL, d_lo = HUGE_VAL, d_hi = -HUGE_VAL;
  for (const Eigen::Vector3d& m : segment_means) {
    if (!m.allFinite()) {
      q.heading_spread_rad = q.norm_spread_ut = q.dip_spread_rad = nan;
      return q;
    }
    const double h = wrap_angle(std::atan2(m.y(), m.x()) - ref);  // about the mean's heading
    const double d = std::atan2(-m.z(), std::hypot(m.x(), m.y()));
    h_lo = std::min(h_lo, h);
    h_hi = std::max(h_hi, h);
    n_lo = std::min(n_lo, m.norm());
    n_hi = std::max(n_hi, m.norm());
    d_lo = std::min(d_lo, d);
    d_hi = std::max(d_hi, d);
  }
  q.heading_spread_rad = h_hi - h_lo;
  q.norm_spread_ut = n_hi - n_lo;
  q.dip_spread_rad = d_hi - d_lo;
  q.ok = q.heading_spread_rad <= max_heading_rad && q.norm_spread_ut <= max_norm_ut &&
         q.dip_spread_rad <= max_dip_rad;
  return q;
}

void OrientationEkf::initialise(const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
                                const Eigen::Vector3d& mag, const EarthField& field,
                                double yaw_rad, double initial_bias_sigma_rad_s) {
  const Eigen::Vector3d up_b = accel.normalized();
  Eigen::Matrix3d R;  // body -> world
  const Eigen::Vector3d m_w = field.world();
  const Eigen::Vector3d e_b = up_b.cross(mag);
  if (mag.allFinite() && e_b.norm() > 1e-6 * mag.norm()) {
    // TRIAD on (up, east): both frames' triads from gravity and the field.
    Eigen::Matrix3d body, world;
    body.col(0) = up_b;
    body.col(1) = e_b.normalized();
    body.col(2) = body.col(0).cross(body.col(1));
    world.col(0) = Eigen::Vector3d::UnitZ();
    world.col(1) = Eigen::Vector3d::UnitZ().cross(m_w).normalized();
    world.col(2) = world.col(0).cross(world.col(1));
    R = world * body.transpose();
  } else {
    // Tilt only (the rotation taking up_b to z), then the yaw of the body x axis.
    const Eigen::Quaterniond tilt = Eigen::Quaterniond::FromTwoVectors(up_b, Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d x_w = tilt * Eigen::Vector3d::UnitX();
    const double yaw_now = std::atan2(x_w.y(), x_w.x());
    R = (Eigen::AngleAxisd(yaw_rad - yaw_now, Eigen::Vector3d::UnitZ()) * tilt).toRotationMatrix();
  }
  q_ = Eigen::Quaterniond(R).normalized();
  b_ = gyro;
  P_.setZero();
  P_.diagonal() << 1e-4, 1e-4, deg_to_rad(5) * deg_to_rad(5), Eigen::Vector3d::Constant(
                       initial_bias_sigma_rad_s * initial_bias_sigma_rad_s);
}

void OrientationEkf::predict(const Eigen::Vector3d& gyro, double dt, const OrientationNoise& n) {
  if (!(dt > 0)) return;
  const Eigen::Matrix3d R = q_.toRotationMatrix();
  q_ = (q_ * rotation_exp((gyro - b_) * dt)).normalized();
  Mat<6> F = Mat<6>::Identity();
  F.topRightCorner<3, 3>() = -R * dt;
  P_ = F * P_ * F.transpose();
  P_.diagonal().head<3>().array() += n.gyro_noise_rad_s * n.gyro_noise_rad_s * dt;
  P_.diagonal().tail<3>().array() += n.bias_walk_rad_s2 * n.bias_walk_rad_s2 * dt;
  symmetrize<6>(P_);
}

void OrientationEkf::apply(const Vec<6>& dx) {
  q_ = (rotation_exp(dx.head<3>()) * q_).normalized();
  b_ += dx.tail<3>();
}

void OrientationEkf::update_gravity(const Eigen::Vector3d& accel, double sigma) {
  const double norm = accel.norm();
  if (!(norm > 1e-3) || !accel.allFinite()) return;
  const Eigen::Matrix3d Rt = q_.toRotationMatrix().transpose();
  const Eigen::Vector3d h = Rt * Eigen::Vector3d::UnitZ();
  Mat<3, 6> H = Mat<3, 6>::Zero();
  H.leftCols<3>() = Rt * skew(Eigen::Vector3d::UnitZ());
  Vec<6> dx = Vec<6>::Zero();
  const Vec<3> y = accel / norm - h;
  if (vector_update<6, 3>(dx, P_, H, y, Mat<3>::Identity() * sigma * sigma).accepted) apply(dx);
}

bool OrientationEkf::update_mag_heading(const Eigen::Vector3d& mag, const EarthField& field,
                                        double norm_tolerance, double dip_tolerance_rad,
                                        double sigma_rad) {
  if (!mag.allFinite()) return false;
  return update_mag_heading_world(q_ * mag, field, norm_tolerance, dip_tolerance_rad, sigma_rad)
      .field_ok;
}

MagUpdate OrientationEkf::update_mag_heading_world(const Eigen::Vector3d& m_w,
                                                   const EarthField& field, double norm_tolerance,
                                                   double dip_tolerance_rad, double sigma_rad,
                                                   double gate_chi2, bool check_only) {
  MagUpdate u;
  if (!m_w.allFinite()) return u;
  const double norm = m_w.norm();
  if (std::abs(norm - field.magnitude_ut) > norm_tolerance * field.magnitude_ut) return u;
  const double dip = std::atan2(-m_w.z(), std::hypot(m_w.x(), m_w.y()));
  if (std::abs(dip - deg_to_rad(field.inclination_deg)) > dip_tolerance_rad) return u;
  u.field_ok = true;
  // A heading error dpsi (world z) turns the measured field by -dpsi about z.
  const Eigen::Vector3d ref = field.world();
  u.innovation = wrap_angle(std::atan2(ref.y(), ref.x()) - std::atan2(m_w.y(), m_w.x()));
  u.hph = P_(2, 2);
  u.r = sigma_rad * sigma_rad;
  Mat<1, 6> H = Mat<1, 6>::Zero();
  H(0, 2) = 1.0;
  if (check_only) return u;
  Vec<6> dx = Vec<6>::Zero();
  u.accepted = scalar_update<6>(dx, P_, H, u.innovation, u.r, gate_chi2).accepted;
  if (u.accepted) apply(dx);
  return u;
}

void OrientationEkf::update_zero_rate(const Eigen::Vector3d& gyro, double sigma) {
  Mat<3, 6> H = Mat<3, 6>::Zero();
  H.rightCols<3>() = Mat<3>::Identity();
  Vec<6> dx = Vec<6>::Zero();
  const Vec<3> y = gyro - b_;
  if (vector_update<6, 3>(dx, P_, H, y, Mat<3>::Identity() * sigma * sigma).accepted) apply(dx);
}

double OrientationEkf::heading_of(const Eigen::Vector3d& body_axis) const {
  const Eigen::Vector3d w = q_ * body_axis;
  return std::atan2(w.y(), w.x());
}

}  // namespace ips::pdr
