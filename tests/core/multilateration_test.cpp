// Levenberg-Marquardt multilateration on exact and noisy geometry.
#include "core/multilateration.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace ips {
namespace {

std::vector<RangeObservation> ranges_to(const Eigen::Vector3d& p, double bias_on_first = 0) {
  const Eigen::Vector3d anchors[] = {{0, 0, 2.4}, {10, 0, 2.4}, {10, 8, 2.4}, {0, 8, 2.4}};
  std::vector<RangeObservation> obs;
  for (const auto& a : anchors) obs.push_back({a, (p - a).norm()});
  obs[0].range_m += bias_on_first;
  return obs;
}

TEST(Multilateration, ExactRangesGiveExactPosition2D) {
  MultilaterationOptions o;
  o.fixed_height = true;
  o.height_m = 1.2;
  auto r = multilaterate_lm(ranges_to({7.3, 2.1, 1.2}), o);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_NEAR(r.position.x(), 7.3, 1e-6);
  EXPECT_NEAR(r.position.y(), 2.1, 1e-6);
  EXPECT_DOUBLE_EQ(r.position.z(), 1.2);
  EXPECT_LT(r.residual_rms_m, 1e-6);
}

TEST(Multilateration, ExactRangesGiveExactPosition3DBelowCoplanarAnchors) {
  MultilaterationOptions o;
  auto r = multilaterate_lm(ranges_to({2.5, 6.0, 0.9}), o);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_NEAR(r.position.x(), 2.5, 1e-5);
  EXPECT_NEAR(r.position.y(), 6.0, 1e-5);
  EXPECT_NEAR(r.position.z(), 0.9, 1e-4);
}

TEST(Multilateration, BiasedRangeShowsInResidual) {
  MultilaterationOptions o;
  o.fixed_height = true;
  o.height_m = 1.2;
  auto r = multilaterate_lm(ranges_to({5, 4, 1.2}, 1.0), o);
  ASSERT_TRUE(r.ok);
  EXPECT_GT(r.residual_rms_m, 0.2);
}

TEST(Multilateration, TooFewRangesFailWithReason) {
  MultilaterationOptions o;
  auto obs = ranges_to({5, 4, 1.2});
  obs.resize(3);
  auto r = multilaterate_lm(obs, o);
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.failure, "need at least 4 ranges, got 3");
}

TEST(Multilateration, CollinearAnchorsAreDegenerate) {
  std::vector<RangeObservation> obs = {
      {{0, 0, 0}, 5}, {{5, 0, 0}, 5}, {{10, 0, 0}, 5}, {{15, 0, 0}, 5}};
  MultilaterationOptions o;
  auto r = multilaterate_lm(obs, o);
  EXPECT_FALSE(r.ok);
}

}  // namespace
}  // namespace ips
