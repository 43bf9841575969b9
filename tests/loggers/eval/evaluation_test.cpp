// Error statistics against interpolated truth.
#include "loggers/eval/evaluation.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/loggers/eval/pose_samples.hpp"

namespace ips::eval {
namespace {

using testing::kT0;
using testing::pose;

TEST(Percentile, LinearInterpolationLikeNumpy) {
  std::vector<double> v = {4, 1, 3, 2};
  EXPECT_DOUBLE_EQ(percentile(v, 50), 2.5);
  EXPECT_DOUBLE_EQ(percentile(v, 95), 3.85);  // numpy.percentile([1,2,3,4], 95)
  EXPECT_DOUBLE_EQ(percentile(v, 0), 1);
  EXPECT_DOUBLE_EQ(percentile(v, 100), 4);
  std::vector<double> empty;
  EXPECT_TRUE(std::isnan(percentile(empty, 50)));
}

TEST(Evaluator, InterpolatesTruthAndComputesStatistics) {
  Evaluator ev;
  // Truth walks along x at 1 m/s from t = 0 to 10 s, sampled at 1 Hz.
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T", i, 0, 1));
  // Estimates at half seconds, 3-4-5 triangles: horizontal errors 0.5 (x 4), and vertical 0.2.
  ev.add_estimate("POSE_A", pose(500'000, "T", 0.5 + 0.3, 0.4, 1.2));
  ev.add_estimate("POSE_A", pose(1'500'000, "T", 1.5 - 0.3, -0.4, 0.8));
  ev.add_estimate("POSE_A", pose(2'500'000, "T", 2.5, 0.5, 1.2));
  ev.add_estimate("POSE_A", pose(3'500'000, "T", 3.5 + 1.5, 2.0, 1.2));  // error 2.5
  ev.add_estimate("POSE_A", pose(20'000'000, "T", 0, 0, 0));              // after truth: unmatched
  auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 1u);
  const ErrorRow& r = rows[0];
  EXPECT_EQ(r.channel, "POSE_A");
  EXPECT_EQ(r.tag, "T");
  EXPECT_EQ(r.count, 4u);
  EXPECT_NEAR(r.mean_h, (0.5 * 3 + 2.5) / 4, 1e-12);
  EXPECT_NEAR(r.rmse_h, std::sqrt((0.25 * 3 + 6.25) / 4), 1e-12);
  EXPECT_NEAR(r.median_h, 0.5, 1e-12);
  EXPECT_NEAR(r.p95_h, 0.5 + 0.85 * 2.0, 1e-12);
  EXPECT_NEAR(r.max_h, 2.5, 1e-12);
  EXPECT_NEAR(r.rmse_v, 0.2, 1e-12);
  EXPECT_EQ(ev.unmatched(), 1u);
}

TEST(Evaluator, SeparatesChannelsAndTagsAndIgnoresOtherTagsTruth) {
  Evaluator ev;
  for (int i = 0; i <= 2; ++i) {
    ev.add_truth(pose(i * 1'000'000, "A", 0, 0, 0));
    ev.add_truth(pose(i * 1'000'000, "B", 10, 0, 0));
  }
  ev.add_estimate("P1", pose(1'000'000, "A", 1, 0, 0));
  ev.add_estimate("P1", pose(1'000'000, "B", 10, 2, 0));
  ev.add_estimate("P2", pose(1'000'000, "A", 0, 3, 0));
  ev.add_estimate("P2", pose(1'000'000, "C", 0, 3, 0));  // no truth for C
  auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_DOUBLE_EQ(rows[0].rmse_h, 1.0);  // P1 A
  EXPECT_DOUBLE_EQ(rows[1].rmse_h, 2.0);  // P1 B
  EXPECT_DOUBLE_EQ(rows[2].rmse_h, 3.0);  // P2 A
  EXPECT_EQ(rows[3].count, 0u);           // P2 C
}

TEST(Evaluator, DoesNotInterpolateAcrossTruthGaps) {
  Evaluator ev(1.0);
  ev.add_truth(pose(0, "T", 0, 0, 0));
  ev.add_truth(pose(5'000'000, "T", 5, 0, 0));
  ev.add_estimate("P", pose(2'500'000, "T", 2.5, 0, 0));
  EXPECT_EQ(ev.rows()[0].count, 0u);
  EXPECT_EQ(ev.unmatched(), 1u);
}

TEST(Evaluator, VerticalErrorLeavesOutEstimatesWithoutHeight) {
  Evaluator ev;
  ev.add_truth(pose(0, "T", 0, 0, 1));
  ev.add_truth(pose(1'000'000, "T", 0, 0, 1));
  ev.add_estimate("P", pose(500'000, "T", 0, 0, 1.3));
  ev.add_estimate("P", pose(600'000, "T", 0, 0, NAN));
  auto r = ev.rows()[0];
  EXPECT_EQ(r.count, 2u);
  EXPECT_NEAR(r.rmse_v, 0.3, 1e-12);
}

TEST(Evaluator, NonFiniteEstimatesAreCountedNotHidden) {
  Evaluator ev;
  ev.add_truth(pose(0, "T", 0, 0, 0));
  ev.add_truth(pose(1'000'000, "T", 0, 0, 0));
  ev.add_truth(pose(2'000'000, "T", NAN, 0, 0));  // ignored, counted
  ev.add_estimate("P", pose(500'000, "T", 1, 0, 0));
  ev.add_estimate("P", pose(600'000, "T", NAN, 0, 0));
  auto r = ev.rows()[0];
  EXPECT_EQ(r.count, 1u);
  EXPECT_EQ(r.non_finite, 1u);
  EXPECT_EQ(ev.bad_truth(), 1u);
}

TEST(Evaluator, VerticalStatisticsAndCepAliases) {
  Evaluator ev;
  ev.add_truth(pose(0, "T", 0, 0, 1));
  ev.add_truth(pose(1'000'000, "T", 0, 0, 1));
  ev.add_estimate("P", pose(100'000, "T", 0, 0, 1.1));
  ev.add_estimate("P", pose(200'000, "T", 0, 0, 0.7));
  ev.add_estimate("P", pose(300'000, "T", 0, 0, 1.2));
  auto r = ev.rows()[0];
  EXPECT_NEAR(r.mean_v, (0.1 + 0.3 + 0.2) / 3, 1e-12);
  EXPECT_NEAR(r.median_v, 0.2, 1e-12);
  EXPECT_NEAR(r.max_v, 0.3, 1e-12);
  EXPECT_NEAR(r.p95_v, 0.2 + 0.9 * 0.1, 1e-12);
  EXPECT_EQ(r.cep50(), r.median_h);
  EXPECT_EQ(r.cep95(), r.p95_h);
}

TEST(Evaluator, StaticPointModeScoresAgainstTheKnownPoint) {
  Evaluator ev;
  ev.set_static_point({2.186, 3.369, 0}, false);  // aoa-hall point T1, no height
  ev.add_estimate("POSE_AOA", pose(0, "T", 2.186 + 0.3, 3.369 + 0.4, 5.0));
  ev.add_estimate("POSE_AOA", pose(1'000'000, "T", 2.186, 3.369 - 1.0, 5.0));
  auto r = ev.rows()[0];
  EXPECT_EQ(r.count, 2u);
  EXPECT_NEAR(r.max_h, 1.0, 1e-12);
  EXPECT_NEAR(r.mean_h, 0.75, 1e-12);
  EXPECT_TRUE(std::isnan(r.rmse_v));  // no height given: not scored
  EXPECT_EQ(ev.unmatched(), 0u);
}

TEST(Evaluator, OutOfOrderTruthIsSorted) {
  Evaluator ev;
  ev.add_truth(pose(1'000'000, "T", 1, 0, 0));
  ev.add_truth(pose(0, "T", 0, 0, 0));
  ev.add_estimate("P", pose(500'000, "T", 0.5, 0, 0));
  EXPECT_DOUBLE_EQ(ev.rows()[0].max_h, 0.0);
}

}  // namespace
}  // namespace ips::eval
