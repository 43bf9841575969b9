// Multilateration (Levenberg-Marquardt, Gauss-Newton, Foy) on exact and noisy geometry.
#include "core/multilateration.hpp"

#include <gtest/gtest.h>

#include <random>
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

// The start fix of ips-uwb-twr and ips-fuse: one NLOS range of 1.3 m among four anchors in 2D
// (one range to spare) leaves a small RMS over all four but fails per degree of freedom, and no
// three can check each other: no start (wait). A fifth anchor lets the NLOS one be left out. A
// set with nothing to spare is returned as solved (the callers widen its sigma).
TEST(Multilateration, DroppingOneLeavesOutAnNlosRangeOnlyWhereTheRestCanBeChecked) {
  MultilaterationOptions o;
  o.fixed_height = true;
  o.height_m = 1.2;
  const Eigen::Vector3d p(3.0, 5.5, 1.2);
  auto four = ranges_to(p, 1.3);
  const auto all = multilaterate(four, o, MultilaterationSolver::kLevenbergMarquardt);
  ASSERT_TRUE(all.ok);
  EXPECT_LT(all.residual_rms_m, 0.5);  // over all ranges it would pass a 0.5 m check
  EXPECT_FALSE(
      multilaterate_dropping_one(four, o, MultilaterationSolver::kLevenbergMarquardt, 0.5).ok);
  auto five = four;
  five.push_back({Eigen::Vector3d(5, -3, 2.4), (p - Eigen::Vector3d(5, -3, 2.4)).norm()});
  const auto r =
      multilaterate_dropping_one(five, o, MultilaterationSolver::kLevenbergMarquardt, 0.5);
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_NEAR((r.position - p).norm(), 0.0, 1e-4);
  const auto clean = multilaterate_dropping_one(ranges_to(p), o,
                                                MultilaterationSolver::kLevenbergMarquardt, 0.5);
  ASSERT_TRUE(clean.ok);
  EXPECT_NEAR((clean.position - p).norm(), 0.0, 1e-6);
  four.pop_back();  // three: nothing to spare, solved as given (wrong by the NLOS range)
  const auto three =
      multilaterate_dropping_one(four, o, MultilaterationSolver::kLevenbergMarquardt, 0.5);
  ASSERT_TRUE(three.ok);
  EXPECT_GT((three.position - p).norm(), 0.5);
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

constexpr MultilaterationSolver kAllSolvers[] = {MultilaterationSolver::kLevenbergMarquardt,
                                                 MultilaterationSolver::kGaussNewton,
                                                 MultilaterationSolver::kFoy};

TEST(Multilateration, EverySolverRecoversExactPositions2DAnd3D) {
  for (MultilaterationSolver solver : kAllSolvers) {
    for (const Eigen::Vector3d& truth :
         {Eigen::Vector3d(7.3, 2.1, 1.2), Eigen::Vector3d(0.5, 7.5, 1.2),
          Eigen::Vector3d(12.0, -3.0, 1.2)}) {  // the last outside the anchors' hull
      MultilaterationOptions o;
      o.fixed_height = true;
      o.height_m = 1.2;
      auto r = multilaterate(ranges_to(truth), o, solver);
      ASSERT_TRUE(r.ok) << multilateration_solver_name(solver) << ": " << r.failure;
      // Foy stops at a 0.03 m step; the step after a 0.03 m one is quadratically smaller.
      EXPECT_NEAR(r.position.x(), truth.x(), 1e-3) << multilateration_solver_name(solver);
      EXPECT_NEAR(r.position.y(), truth.y(), 1e-3) << multilateration_solver_name(solver);
    }
    MultilaterationOptions o3;
    auto r = multilaterate(ranges_to({2.5, 6.0, 0.9}), o3, solver);
    ASSERT_TRUE(r.ok) << multilateration_solver_name(solver) << ": " << r.failure;
    EXPECT_NEAR(r.position.z(), 0.9, 2e-3) << multilateration_solver_name(solver);
  }
}

// On noisy ranges all three minimise the same cost: they agree to the convergence threshold, and
// their unit covariances (the geometry) are the same.
TEST(Multilateration, SolversAgreeOnNoisyRanges) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.45);  // 001 Tab. 4.1's simulated ranging sigma
  MultilaterationOptions o;
  o.fixed_height = true;
  o.height_m = 1.2;
  for (int k = 0; k < 50; ++k) {
    auto obs = ranges_to({1.0 + 0.15 * k, 1.0 + 0.12 * k, 1.2});
    for (auto& ob : obs) ob.range_m += noise(rng);
    auto lm = multilaterate(obs, o, MultilaterationSolver::kLevenbergMarquardt);
    auto gn = multilaterate(obs, o, MultilaterationSolver::kGaussNewton);
    auto foy = multilaterate(obs, o, MultilaterationSolver::kFoy);
    ASSERT_TRUE(lm.ok && gn.ok && foy.ok) << k;
    EXPECT_LT((lm.position - gn.position).norm(), 0.01) << k;
    EXPECT_LT((foy.position - gn.position).norm(), 0.01) << k;
    EXPECT_NEAR(gn.residual_rms_m, lm.residual_rms_m, 1e-3) << k;
    EXPECT_TRUE(gn.covariance_unit.isApprox(foy.covariance_unit, 1e-2)) << k;
  }
}

TEST(Multilateration, GaussNewtonStartsAnywhereNearby) {
  MultilaterationOptions o;
  o.fixed_height = true;
  o.height_m = 1.2;
  auto r = multilaterate_gauss_newton(ranges_to({7.3, 2.1, 1.2}), o, {30.0, 40.0, 1.2});
  ASSERT_TRUE(r.ok) << r.failure;
  EXPECT_NEAR(r.position.x(), 7.3, 1e-6);
  EXPECT_NEAR(r.position.y(), 2.1, 1e-6);
}

TEST(Multilateration, FoyAndGaussNewtonReportDegenerateGeometry) {
  std::vector<RangeObservation> obs = {
      {{0, 0, 0}, 5}, {{5, 0, 0}, 5}, {{10, 0, 0}, 5}, {{15, 0, 0}, 5}};
  MultilaterationOptions o;
  EXPECT_FALSE(multilaterate_foy(obs, o).ok);
  EXPECT_FALSE(multilaterate_gauss_newton(obs, o).ok);
  auto few = ranges_to({5, 4, 1.2});
  few.resize(2);
  o.fixed_height = true;
  o.height_m = 1.2;
  EXPECT_EQ(multilaterate_foy(few, o).failure, "need at least 3 ranges, got 2");
}

TEST(Multilateration, SolverNamesRoundTrip) {
  for (MultilaterationSolver solver : kAllSolvers)
    EXPECT_EQ(parse_multilateration_solver(multilateration_solver_name(solver)), solver);
  EXPECT_FALSE(parse_multilateration_solver("newton").has_value());
}

}  // namespace
}  // namespace ips
