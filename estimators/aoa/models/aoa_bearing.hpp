#pragma once
// Measurement model: the angles at which a BLE AoA anchor (u-blox XPLR-AOA, +UUDF) sees a tag.
//
// Anchor frame (docs/scenarios/aoa-hall.md, the simulator's ble_aoa model): x = antenna normal,
// y = the anchor's left, z = its up; site_from_anchor = Rz(yaw) Ry(pitch) Rx(roll) of the site's
// orientation_deg. With b = R' (p - a) the tag in that frame:
//   azimuth   theta = atan2(-b_y, b_x)           (0 on the normal, positive to the right)
//   elevation phi   = atan2(b_z, hypot(b_x, b_y))
// For a level anchor theta is the source's (3.1)/(7.2): alpha = yaw - theta is the site bearing
// atan2(dy, dx) of the anchor->tag line (000 section 3: the printed atan2(dx, dy) is a typo; the
// Jacobian [-dy/d^2, dx/d^2] the thesis prints belongs to atan2(dy, dx)).
// The Jacobians are with respect to the tag's site position; innovations are wrapped to (-pi, pi].
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "core/ekf.hpp"
#include "core/geometry.hpp"
#include "core/site.hpp"

namespace ips::aoa {

struct AnchorFrame {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Matrix3d site_from_anchor = Eigen::Matrix3d::Identity();
};

inline AnchorFrame anchor_frame(const Anchor& a) {
  const Eigen::Vector3d& o = a.orientation_rad;  // roll, pitch, yaw
  AnchorFrame f;
  f.position = a.position;
  f.site_from_anchor = (Eigen::AngleAxisd(o.z(), Eigen::Vector3d::UnitZ()) *
                        Eigen::AngleAxisd(o.y(), Eigen::Vector3d::UnitY()) *
                        Eigen::AngleAxisd(o.x(), Eigen::Vector3d::UnitX()))
                           .toRotationMatrix();
  return f;
}

enum class AngleKind { kAzimuth, kElevation };

struct AnglePrediction {
  double angle_rad = 0;
  Eigen::RowVector3d jacobian = Eigen::RowVector3d::Zero();  // d angle / d p (site frame)
  bool valid = false;  // false on the anchor's axis (the angle is undefined there)
};

inline AnglePrediction predict_angle(const AnchorFrame& f, const Eigen::Vector3d& p,
                                     AngleKind kind) {
  const Eigen::Vector3d b = f.site_from_anchor.transpose() * (p - f.position);
  const double h2 = b.x() * b.x() + b.y() * b.y();
  AnglePrediction out;
  if (!(h2 > 1e-12)) return out;
  Eigen::RowVector3d d_db;
  if (kind == AngleKind::kAzimuth) {
    out.angle_rad = std::atan2(-b.y(), b.x());
    d_db << b.y() / h2, -b.x() / h2, 0.0;
  } else {
    const double h = std::sqrt(h2);
    const double r2 = h2 + b.z() * b.z();
    out.angle_rad = std::atan2(b.z(), h);
    d_db << -b.z() * b.x() / (h * r2), -b.z() * b.y() / (h * r2), h / r2;
  }
  out.jacobian = d_db * f.site_from_anchor.transpose();
  out.valid = true;
  return out;
}

// The position the filter or solver works on: D = 2 holds the tag at height_m.
template <int D>
Eigen::Vector3d site_point(const Vec<D>& xy_or_xyz, double height_m) {
  if constexpr (D == 2) {
    return {xy_or_xyz(0), xy_or_xyz(1), height_m};
  } else {
    return xy_or_xyz;
  }
}

struct AngleUpdate {
  bool accepted = false;
  bool valid = false;
  double innovation_rad = 0;  // wrapped z - h(x) before the update
  double normalised = 0;      // innovation / sqrt(H P H' + r)
  double hph = 0;             // the prediction's variance H P H' (rad^2)
};

// EKF update of a filter whose state starts with the D position coordinates (a constant-velocity
// or a random-walk filter) with one measured angle, sigma_rad its standard deviation, gated at
// gate_sigma standard deviations of the innovation.
template <int D, int N>
AngleUpdate angle_update(Vec<N>& x, Mat<N>& P, const AnchorFrame& f, double height_m,
                         AngleKind kind, double measured_rad, double sigma_rad,
                         double gate_sigma) {
  const Vec<D> pos = x.template head<D>();
  const AnglePrediction pred = predict_angle(f, site_point<D>(pos, height_m), kind);
  AngleUpdate out;
  if (!pred.valid || !std::isfinite(measured_rad)) return out;
  out.valid = true;
  Mat<1, N> H = Mat<1, N>::Zero();
  H.template head<D>() = pred.jacobian.template head<D>();
  out.innovation_rad = wrap_angle(measured_rad - pred.angle_rad);
  const double r = sigma_rad * sigma_rad;
  out.hph = (H * P * H.transpose())(0, 0);
  const double S = out.hph + r;
  if (!(S > 0)) return out;
  out.normalised = out.innovation_rad / std::sqrt(S);
  out.accepted =
      scalar_update<N>(x, P, H, out.innovation_rad, r, gate_sigma * gate_sigma).accepted;
  return out;
}

}  // namespace ips::aoa
