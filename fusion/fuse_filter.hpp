#pragma once
// ips-fuse's per-tag state and motion models: position p (3), velocity v (3), and the heading
// bias psi of the tag's dead-reckoning source (the rotation, about z, from the frame its
// displacements are reported in to the site's: a foot-INS module's initial heading error, 001
// chapter 4, and its drift). Two ways to move the state to a later time:
//  - by a reported displacement d over dt (foot INS, PDR steps): p += R(psi) d,
//    v = R(psi) d / dt, with noise growing with the distance (001's INS as the motion model);
//  - without one, constant velocity with white-noise acceleration (UWB alone), the horizontal
//    velocity turned by what a gyro carried by the tag measured about the vertical meanwhile
//    (constant speed, the heading from the gyro): a 2 Hz displacement source leaves gaps in
//    which the walker may turn a corner.
// psi follows a random walk either way. In 2D (the tag's height from the site) z and vz stay put.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "core/ekf.hpp"

namespace ips::fusion {

inline constexpr int kStateSize = 7;
inline constexpr int kVel = 3;
inline constexpr int kPsi = 6;
using State = Vec<kStateSize>;
using Covariance = Mat<kStateSize>;

struct FuseFilter {
  State x = State::Zero();
  Covariance P = Covariance::Identity();
  bool planar = false;  // z and vz fixed
  // The dead-reckoning frame's rotation psi, measured at its start (FuseEstimator::predict,
  // fuse_displacements.cpp): until `frame_aligned`, a track moving on absolute measurements holds
  // the frame's displacements back (`frame_window`), summing them (`frame_dr`) while its position
  // moves on from `frame_from` (covariance `frame_from_cov`): the two paths' directions give
  // psi. A new frame (a track's start, a source's restart) is not aligned.
  bool frame_aligned = false;
  bool frame_window = false;
  int frame_tries = 0;  // windows whose path was no rotation of the displacements'
  int64_t frame_began = 0;  // utime: the start of the frame's first displacement (0: none yet)
  int64_t frame_open_after = 0;  // utime: no window opens before (a corrected track settling)
  // A rotation measured far off the prior, waiting for the next window to confirm it.
  bool frame_pending = false;
  double frame_pending_psi = 0.0;
  double frame_pending_var = 0.0;
  Eigen::Vector2d frame_from = Eigen::Vector2d::Zero();
  Eigen::Matrix2d frame_from_cov = Eigen::Matrix2d::Zero();
  Eigen::Vector2d frame_dr = Eigen::Vector2d::Zero();

  // A new frame's wait, or the next one, starting from here.
  void open_frame_window() {
    frame_window = true;
    frame_from = x.head<2>();
    frame_from_cov = P.block<2, 2>(0, 0);
    frame_dr.setZero();
  }

  // The heading bias psi, known to var and uncorrelated with the rest.
  void set_heading_bias(double psi, double var) {
    x(kPsi) = psi;
    P.row(kPsi).setZero();
    P.col(kPsi).setZero();
    P(kPsi, kPsi) = var;
  }

  // turn_mid_rad, turn_end_rad: how far the velocity has turned by the middle and the end of
  // the step (the gyro's).
  void predict_cv(double dt, double accel_psd, double psi_walk_var_per_s, double turn_mid_rad = 0,
                  double turn_end_rad = 0) {
    if (dt <= 0) return;
    const int d = planar ? 2 : 3;
    if (turn_mid_rad != 0 || turn_end_rad != 0) {
      Covariance F = Covariance::Identity();
      for (int i = 0; i < d; ++i) F(i, kVel + i) = dt;
      // Midpoint rule: the position moves along the velocity as turned by the middle.
      const Eigen::Matrix2d half = Eigen::Rotation2Dd(turn_mid_rad).toRotationMatrix();
      const Eigen::Matrix2d full = Eigen::Rotation2Dd(turn_end_rad).toRotationMatrix();
      F.block<2, 2>(0, kVel) = dt * half;
      F.block<2, 2>(kVel, kVel) = full;
      const Eigen::Vector2d v = x.segment<2>(kVel);
      x.head<2>() += dt * half * v;
      x.segment<2>(kVel) = full * v;
      if (d == 3) x(2) += dt * x(kVel + 2);
      P = F * P * F.transpose();
    } else {
      for (int i = 0; i < d; ++i) x(i) += dt * x(kVel + i);
      // P = F P F^T with F = I + dt on (i, kVel + i): every entry of F P and of (F P) F^T is at
      // most two nonzero terms, so these are the full product's numbers without its zeros.
      for (int i = 0; i < d; ++i) P.row(i) += dt * P.row(kVel + i);
      for (int j = 0; j < d; ++j) P.col(j) += dt * P.col(kVel + j);
    }
    const double dt2 = dt * dt;
    for (int i = 0; i < d; ++i) {
      P(i, i) += accel_psd * dt2 * dt / 3.0;
      P(i, kVel + i) += accel_psd * dt2 / 2.0;
      P(kVel + i, i) += accel_psd * dt2 / 2.0;
      P(kVel + i, kVel + i) += accel_psd * dt;
    }
    P(kPsi, kPsi) += psi_walk_var_per_s * dt;
    symmetrize<kStateSize>(P);
  }

  // d: the displacement in the source's frame over dt seconds (dt > 0); sigma_m: its noise per
  // axis.
  void predict_displacement(const Eigen::Vector3d& d, double dt, double sigma_m,
                            double psi_walk_var_per_s) {
    const Eigen::Vector3d dmoved = move_by(d, dt);
    // P = F P F^T with F = I but for column kPsi: dmoved in rows 0-2, dmoved / dt in rows
    // kVel..kVel+2 (whose own diagonal is 0). Every entry of F P and of (F P) F^T is at most two
    // nonzero terms, so these are the full product's numbers without its zeros (+ 0.0: a sum of
    // zeros is +0, as the full product's is).
    const Eigen::Vector3d dv = dmoved / dt;
    for (int i = 0; i < 3; ++i) P.row(i) += dmoved(i) * P.row(kPsi);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < kStateSize; ++j) P(kVel + i, j) = dv(i) * P(kPsi, j) + 0.0;
    for (int j = 0; j < 3; ++j) P.col(j) += dmoved(j) * P.col(kPsi);
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < kStateSize; ++i) P(i, kVel + j) = P(i, kPsi) * dv(j) + 0.0;
    add_displacement_noise(dt, sigma_m);
    P(kPsi, kPsi) += psi_walk_var_per_s * dt;
    symmetrize<kStateSize>(P);
  }

  // A displacement of a frame whose rotation waits to be measured: turned by psi as it stands,
  // the rotation's uncertainty added to the position across the displacement, not tied to psi.
  // The measurements that correct the track meanwhile then leave psi alone (tied, they drove a
  // new frame's psi 2.3 rad from the truth while a jumped tag was re-acquired: the soak's fault
  // 131), and the track still moves as the displacements say.
  void predict_displacement_untied(const Eigen::Vector3d& d, double dt, double sigma_m) {
    const Eigen::Vector3d dmoved = move_by(d, dt);
    const Eigen::Matrix3d turn = dmoved * dmoved.transpose() * P(kPsi, kPsi);
    // The velocity is this displacement's average: known as well as the displacement.
    P.middleRows<3>(kVel).setZero();
    P.middleCols<3>(kVel).setZero();
    P.topLeftCorner<3, 3>() += turn;
    P.block<3, 3>(kVel, kVel) = turn / (dt * dt);
    add_displacement_noise(dt, sigma_m);
    symmetrize<kStateSize>(P);
  }

 private:
  // Moves the track by a displacement d of the source's frame, turned by psi, and sets the
  // velocity to its average over dt. Returns d(moved)/d(psi).
  Eigen::Vector3d move_by(const Eigen::Vector3d& d, double dt) {
    const double c = std::cos(x(kPsi)), s = std::sin(x(kPsi));
    const Eigen::Vector3d moved(c * d.x() - s * d.y(), s * d.x() + c * d.y(), planar ? 0.0 : d.z());
    x.head<3>() += moved;
    x.segment<3>(kVel) = moved / dt;
    return {-s * d.x() - c * d.y(), c * d.x() - s * d.y(), 0.0};
  }
  // The displacement's own noise (sigma_m per axis) on the position, and on the velocity as its
  // average over dt.
  void add_displacement_noise(double dt, double sigma_m) {
    const double var = sigma_m * sigma_m;
    const int n = planar ? 2 : 3;
    for (int i = 0; i < n; ++i) {
      P(i, i) += var;
      P(kVel + i, kVel + i) += var / (dt * dt);
    }
  }
};

}  // namespace ips::fusion
