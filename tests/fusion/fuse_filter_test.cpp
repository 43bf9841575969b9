// FuseFilter's predictions apply F P F^T by the structure of F: the same numbers, bit for bit, as
// the full 7x7 product (its extra terms are exact zeros), on covariances with exact zeros in
// them too (a planar track's z rows).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "fusion/fuse_filter.hpp"

namespace ips::fusion {
namespace {

Covariance random_covariance(std::mt19937_64& rng, int round) {
  std::uniform_real_distribution<double> u(-1, 1);
  std::uniform_int_distribution<int> decade(-5, 4);
  Covariance m;
  for (int i = 0; i < kStateSize * kStateSize; ++i) m(i) = u(rng) * std::pow(10.0, decade(rng));
  Covariance p = m * m.transpose();
  if (round % 3 == 0)  // z uncorrelated, as a planar track's
    for (int k = 0; k < kStateSize; ++k)
      if (k != 2) p(2, k) = p(k, 2) = 0.0;
  if (round % 5 == 0)
    for (int k = 0; k < kStateSize; ++k)
      if (k != 5) p(5, k) = p(k, 5) = 0.0;
  return p;
}

bool same_bits(const Covariance& a, const Covariance& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * kStateSize * kStateSize) == 0;
}

TEST(FuseFilterProducts, ConstantVelocityIsTheFullProductBitForBit) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  for (int round = 0; round < 20000; ++round) {
    FuseFilter f;
    f.planar = round % 2 == 0;
    f.P = random_covariance(rng, round);
    const double dt = u(rng) * (round % 4 < 2 ? 0.05 : 2.0) + 1e-6;
    Covariance F = Covariance::Identity();
    for (int i = 0; i < (f.planar ? 2 : 3); ++i) F(i, kVel + i) = dt;
    Covariance want = F * f.P * F.transpose();
    f.predict_cv(dt, 0.0, 0.0);  // no noise added: P is F P F^T, symmetrised
    symmetrize<kStateSize>(want);
    ASSERT_TRUE(same_bits(f.P, want)) << "round " << round;
  }
}

TEST(FuseFilterProducts, DisplacementIsTheFullProductBitForBit) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int round = 0; round < 20000; ++round) {
    FuseFilter f;
    f.planar = round % 2 == 0;
    f.P = random_covariance(rng, round);
    f.x(kPsi) = u(rng) * 3;
    const Eigen::Vector3d d(u(rng), u(rng), f.planar ? 0.0 : u(rng));
    const double dt = std::abs(u(rng)) + 1e-3;
    const double c = std::cos(f.x(kPsi)), s = std::sin(f.x(kPsi));
    const Eigen::Vector3d dmoved(-s * d.x() - c * d.y(), c * d.x() - s * d.y(), 0.0);
    Covariance F = Covariance::Identity();
    F.block<3, 1>(0, kPsi) = dmoved;
    F.block<3, 3>(kVel, kVel).setZero();
    F.block<3, 1>(kVel, kPsi) = dmoved / dt;
    Covariance want = F * f.P * F.transpose();
    // sigma 0 and no heading walk: only F P F^T, symmetrised.
    f.predict_displacement(d, dt, 0.0, 0.0);
    symmetrize<kStateSize>(want);
    ASSERT_TRUE(same_bits(f.P, want)) << "round " << round;
  }
}

}  // namespace
}  // namespace ips::fusion
