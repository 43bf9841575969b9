// Error statistics against interpolated truth, a time window, a dwell-point reference, ALTITUDE
// and its floors, rows pooled per channel, the natural order of tags, 2D estimates.
#include "loggers/eval/evaluation.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "loggers/eval/time_window.hpp"
#include "tests/loggers/eval/pose_samples.hpp"

namespace ips::eval {
namespace {

using testing::altitude;
using testing::kT0;
using testing::planar_pose;
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

TEST(NaturalOrder, DigitRunsCompareAsNumbers) {
  EXPECT_TRUE(natural_less("T1", "T1-2"));
  EXPECT_TRUE(natural_less("T1-2", "T1-10"));
  EXPECT_FALSE(natural_less("T1-10", "T1-2"));
  EXPECT_TRUE(natural_less("T1-10", "T2"));
  EXPECT_TRUE(natural_less("T9", "T10"));
  EXPECT_TRUE(natural_less("A", "B"));
  EXPECT_FALSE(natural_less("T1", "T1"));
  // Equal as numbers: byte order decides, so the order is still strict and total.
  EXPECT_TRUE(natural_less("T01", "T1"));
  EXPECT_FALSE(natural_less("T1", "T01"));
  // A run longer than any integer type.
  EXPECT_TRUE(natural_less("T99999999999999999999999", "T100000000000000000000000"));
}

TEST(Evaluator, RowsAndSeriesAreInNaturalOrderOfTags) {
  Evaluator ev;
  for (const char* tag : {"T1-10", "T2", "T1-2", "T1"}) {
    ev.add_truth(pose(0, tag, 0, 0, 0));
    ev.add_truth(pose(1'000'000, tag, 0, 0, 0));
    ev.add_estimate("POSE_UWB", pose(500'000, tag, 1, 0, 0));
    ev.add_estimate("POSE_AOA", pose(500'000, tag, 1, 0, 0));
  }
  const std::vector<std::string> want = {"T1", "T1-2", "T1-10", "T2"};
  const auto rows = ev.rows();
  const auto series = ev.estimate_series();
  ASSERT_EQ(rows.size(), 8u);
  ASSERT_EQ(series.size(), 8u);
  for (size_t i = 0; i < 8; ++i) {
    EXPECT_EQ(rows[i].channel, i < 4 ? "POSE_AOA" : "POSE_UWB");
    EXPECT_EQ(rows[i].tag, want[i % 4]);
    EXPECT_EQ(series[i].channel, rows[i].channel);
    EXPECT_EQ(series[i].tag, rows[i].tag);
  }
}

TEST(Evaluator, ByChannelPoolsTheErrorsOfAllTags) {
  Evaluator ev;
  for (int i = 0; i <= 2; ++i) {
    ev.add_truth(pose(i * 1'000'000, "A", 0, 0, 0));
    ev.add_truth(pose(i * 1'000'000, "B", 10, 0, 0));
  }
  ev.add_estimate("P1", pose(1'000'000, "A", 1, 0, 0));   // error 1
  ev.add_estimate("P1", pose(1'000'000, "B", 10, 2, 0));  // error 2
  ev.add_estimate("P1", pose(1'500'000, "B", 13, 4, 0));  // error 5
  ev.add_estimate("P2", pose(1'000'000, "A", 0, 3, 0));   // error 3
  const auto rows = ev.rows_by_channel();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].channel, "P1");
  EXPECT_EQ(rows[0].tag, kAllTags);
  EXPECT_EQ(rows[0].tags, 2u);
  EXPECT_EQ(rows[0].count, 3u);
  EXPECT_NEAR(rows[0].mean_h, (1 + 2 + 5) / 3.0, 1e-12);
  EXPECT_NEAR(rows[0].rmse_h, std::sqrt((1 + 4 + 25) / 3.0), 1e-12);
  EXPECT_NEAR(rows[0].median_h, 2, 1e-12);
  EXPECT_NEAR(rows[0].max_h, 5, 1e-12);
  EXPECT_EQ(rows[1].channel, "P2");
  EXPECT_EQ(rows[1].tags, 1u);
  EXPECT_NEAR(rows[1].rmse_h, 3, 1e-12);
}

TEST(Evaluator, TwoDimensionalEstimatesHaveNoVerticalError) {
  Evaluator ev;
  ev.add_truth(pose(0, "T", 0, 0, 1.5));
  ev.add_truth(pose(1'000'000, "T", 0, 0, 1.5));
  // A 2D estimator publishes the site's fixed tag height (here 1.5 m, equal to truth): that is
  // not a measured 0.000 m vertical error.
  ev.add_estimate("POSE_2D", planar_pose(300'000, "T", 0.3, 0, 1.5));
  ev.add_estimate("POSE_2D", planar_pose(600'000, "T", 0.4, 0, 1.5));
  ev.add_estimate("POSE_MIX", planar_pose(300'000, "T", 0, 0, 1.5));
  ev.add_estimate("POSE_MIX", pose(600'000, "T", 0, 0, 1.9));  // 3D: |dz| 0.4
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].count, 2u);
  EXPECT_NEAR(rows[0].rmse_h, std::sqrt((0.09 + 0.16) / 2), 1e-12);
  EXPECT_EQ(rows[0].count_v, 0u);
  EXPECT_TRUE(std::isnan(rows[0].rmse_v));
  EXPECT_TRUE(std::isnan(rows[0].mean_v));
  EXPECT_TRUE(std::isnan(rows[0].max_v));
  EXPECT_EQ(rows[1].count, 2u);
  EXPECT_EQ(rows[1].count_v, 1u);
  EXPECT_NEAR(rows[1].rmse_v, 0.4, 1e-12);
}

TEST(Evaluator, SeriesWithAFixedHeightHasNoVerticalError) {
  // The sim's INS module (drivers/sim/models/ins_module.cpp) on the lab's level walk keeps its
  // start height: every pose at z 1.5 without STATUS_2D. A constant z is not an estimate.
  Evaluator ev;
  ev.add_truth(pose(0, "T", 0, 0, 1.5));
  ev.add_truth(pose(1'000'000, "T", 0, 0, 1.7));
  ev.add_estimate("INS_MODULE", pose(250'000, "T", 0.3, 0, 1.5));
  ev.add_estimate("INS_MODULE", pose(500'000, "T", 0.3, 0, 1.5));
  ev.add_estimate("INS_MODULE", pose(750'000, "T", 0.3, 0, 1.5));
  // One estimate alone is not "never changes": scored (|dz| 0.1 at truth z 1.6).
  ev.add_estimate("POSE_ONE", pose(500'000, "T", 0, 0, 1.5));
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].channel, "INS_MODULE");
  EXPECT_EQ(rows[0].count, 3u);
  EXPECT_NEAR(rows[0].rmse_h, 0.3, 1e-12);
  EXPECT_EQ(rows[0].count_v, 0u);
  EXPECT_TRUE(std::isnan(rows[0].rmse_v));
  EXPECT_EQ(rows[1].count_v, 1u);
  EXPECT_NEAR(rows[1].rmse_v, 0.1, 1e-12);
  // A height that moves is scored, even when it comes back to the same value.
  Evaluator moving;
  moving.add_truth(pose(0, "T", 0, 0, 1.5));
  moving.add_truth(pose(1'000'000, "T", 0, 0, 1.5));
  for (double z : {1.5, 1.6, 1.5}) moving.add_estimate("POSE_3D", pose(500'000, "T", 0, 0, z));
  EXPECT_EQ(moving.rows().at(0).count_v, 3u);
  EXPECT_NEAR(moving.rows().at(0).rmse_v, std::sqrt(0.01 / 3), 1e-12);
}

TEST(Evaluator, WindowScoresOnlyEstimatesInsideIt) {
  Evaluator ev;
  // Truth along x at 1 m/s for 10 s; one estimate per second, each 0.1 m * i off in y.
  ev.set_window(kT0 + 2'000'000, kT0 + 5'500'000);
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T", i, 0, 0));
  for (int i = 0; i < 10; ++i)
    ev.add_estimate("P", pose(i * 1'000'000 + 500'000, "T", i + 0.5, 0.1 * i, 0));
  ev.add_altitude("ALTITUDE", altitude(1'000'000, "T", 0));  // before: outside too
  // Inside [2, 5.5] s: the estimates at 2.5, 3.5, 4.5, 5.5 s (errors 0.2 to 0.5 m), interpolated
  // across truth at 2 to 6 s; the 6 others and the altitude are outside.
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].count, 4u);
  EXPECT_NEAR(rows[0].mean_h, (0.2 + 0.3 + 0.4 + 0.5) / 4, 1e-12);
  EXPECT_NEAR(rows[0].max_h, 0.5, 1e-12);
  EXPECT_EQ(ev.outside_window(), 7u);
  EXPECT_EQ(ev.unmatched(), 0u);
  // Truth more than the 1 s gap outside the window is dropped: samples at 1 to 6 s are kept.
  EXPECT_EQ(ev.truth_tracks().at("T").size(), 6u);
  EXPECT_EQ(ev.truth_tracks().at("T").front().utime, kT0 + 1'000'000);
}

TEST(TimeBound, SecondsFromStartUnixTimeOrIso8601) {
  std::string error;
  auto rel = parse_time_bound("12.5", error);
  ASSERT_TRUE(rel);
  EXPECT_FALSE(rel->absolute);
  EXPECT_EQ(rel->resolve(kT0), kT0 + 12'500'000);
  // Larger than 1e9: Unix time in s. 2024-12-18T05:58:05Z is 1734501485 s (date -d).
  auto unix_s = parse_time_bound("1734501485.25", error);
  ASSERT_TRUE(unix_s);
  EXPECT_TRUE(unix_s->absolute);
  EXPECT_EQ(unix_s->resolve(kT0), 1734501485'250000);
  auto iso = parse_time_bound("2024-12-18T05:58:05Z", error);
  ASSERT_TRUE(iso);
  EXPECT_TRUE(iso->absolute);
  EXPECT_EQ(iso->resolve(kT0), 1734501485'000000);
  EXPECT_EQ(iso8601_utc(1734501485'250000), "2024-12-18T05:58:05.250Z");
  EXPECT_TRUE(parse_time_bound("0", error));
  EXPECT_FALSE(parse_time_bound("-3", error));
  EXPECT_NE(error.find("-3"), std::string::npos);
  EXPECT_FALSE(parse_time_bound("noon", error));
  EXPECT_FALSE(parse_time_bound("", error));
  EXPECT_FALSE(parse_time_bound("1e300", error));
}

TEST(Evaluator, AltitudeBiasRmseP95MaxAgainstInterpolatedTruth) {
  Evaluator ev;
  // Truth climbs 1 m/s from z 1 m (a stair); heights 0.1 above, 0.3 below, 0.2 and 0.4 above.
  for (int i = 0; i <= 4; ++i) ev.add_truth(pose(i * 1'000'000, "T", 0, 0, 1.0 + i));
  ev.add_altitude("ALTITUDE", altitude(500'000, "T", 1.5 + 0.1));
  ev.add_altitude("ALTITUDE", altitude(1'500'000, "T", 2.5 - 0.3));
  ev.add_altitude("ALTITUDE", altitude(2'500'000, "T", 3.5 + 0.2));
  ev.add_altitude("ALTITUDE", altitude(3'500'000, "T", 4.5 + 0.4));
  ev.add_altitude("ALTITUDE", altitude(9'000'000, "T", 0));    // after truth: not scored
  ev.add_altitude("ALTITUDE", altitude(600'000, "T", NAN));  // counted, not scored
  const auto rows = ev.altitude_rows();
  ASSERT_EQ(rows.size(), 1u);
  const AltitudeRow& r = rows[0];
  EXPECT_EQ(r.channel, "ALTITUDE");
  EXPECT_EQ(r.tag, "T");
  EXPECT_EQ(r.count, 4u);
  EXPECT_EQ(r.non_finite, 1u);
  EXPECT_NEAR(r.bias, (0.1 - 0.3 + 0.2 + 0.4) / 4, 1e-12);
  EXPECT_NEAR(r.rmse, std::sqrt((0.01 + 0.09 + 0.04 + 0.16) / 4), 1e-12);
  EXPECT_NEAR(r.p95, 0.3 + 0.85 * 0.1, 1e-12);  // numpy.percentile([.1,.2,.3,.4], 95)
  EXPECT_NEAR(r.max, 0.4, 1e-12);
  EXPECT_TRUE(std::isnan(r.floor_share()));  // no floors in the site
  EXPECT_EQ(ev.altitudes_unmatched(), 1u);
  EXPECT_EQ(ev.altitudes(), 6u);
  EXPECT_EQ(ev.unmatched(), 0u);  // poses only
  EXPECT_TRUE(ev.rows().empty());
}

TEST(Evaluator, AltitudeFloorShareUsesTheSiteFloors) {
  Evaluator ev;
  // docs/site-file.md's example: floors at 0, 3.5 and 7 m, a tag carried 1 m above the floor.
  altitude::FloorParams floors;
  floors.heights_m = {0.0, 3.5, 7.0};
  floors.carry_height_m = 1.0;
  ev.set_floors(floors);
  ev.add_truth(pose(0, "T", 0, 0, 1.0));  // floor 0
  ev.add_truth(pose(1'000'000, "T", 0, 0, 1.0));
  ev.add_truth(pose(2'000'000, "T", 0, 0, 4.5));  // floor 1 (and a climb in between)
  ev.add_truth(pose(3'000'000, "T", 0, 0, 4.5));
  ev.add_altitude("ALTITUDE", altitude(200'000, "T", 1.1, 0, true));   // right
  ev.add_altitude("ALTITUDE", altitude(400'000, "T", 1.2, 1, true));   // wrong
  ev.add_altitude("ALTITUDE", altitude(600'000, "T", 1.0, 0, false));  // no floor: not counted
  ev.add_altitude("ALTITUDE", altitude(2'500'000, "T", 4.4, 1, true));  // right
  const auto r = ev.altitude_rows().at(0);
  EXPECT_EQ(r.count, 4u);
  EXPECT_EQ(r.floor_count, 3u);
  EXPECT_EQ(r.floor_right, 2u);
  EXPECT_NEAR(r.floor_share(), 2.0 / 3.0, 1e-12);
  // Pooled over tags: the same numbers for one tag.
  const auto pooled = ev.altitude_rows_by_channel().at(0);
  EXPECT_EQ(pooled.tag, kAllTags);
  EXPECT_EQ(pooled.floor_right, 2u);
  EXPECT_NEAR(pooled.rmse, r.rmse, 1e-12);
}

TEST(Evaluator, DwellIntervalsAreTheReferenceWithoutTruth) {
  Evaluator ev;
  // Two known points, as the BLE dataset's static runs (gt_static_*.csv): 120,120 cm for 0 to
  // 10 s; then 240,120 cm for 20 to 30 s, given for tag T2 only, with a height.
  ev.set_dwell_intervals({{kT0 + 20'000'000, kT0 + 30'000'000, 2.4, 1.2, 1.0, "T2"},
                          {kT0, kT0 + 10'000'000, 1.2, 1.2, NAN, ""}});
  ev.add_estimate("POSE_AOA", pose(5'000'000, "T1", 1.2 + 0.3, 1.2 + 0.4, 7));  // 0.5
  ev.add_estimate("POSE_AOA", pose(10'000'000, "T1", 1.2, 1.2 - 1.5, 7));       // 1.5, at end
  ev.add_estimate("POSE_AOA", pose(15'000'000, "T1", 0, 0, 0));   // between: not scored
  ev.add_estimate("POSE_AOA", pose(25'000'000, "T1", 0, 0, 0));   // T2's interval: not scored
  ev.add_estimate("POSE_AOA", pose(25'000'000, "T2", 2.4, 1.2 + 0.2, 1.3));  // 0.2, dz 0.3
  ev.add_altitude("ALTITUDE", altitude(25'000'000, "T2", 1.1));
  ev.add_altitude("ALTITUDE", altitude(5'000'000, "T1", 1.1));  // no height known: not scored
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].tag, "T1");
  EXPECT_EQ(rows[0].count, 2u);
  EXPECT_NEAR(rows[0].mean_h, 1.0, 1e-12);
  EXPECT_NEAR(rows[0].max_h, 1.5, 1e-12);
  EXPECT_TRUE(std::isnan(rows[0].rmse_v));  // the interval has no height
  EXPECT_EQ(rows[1].tag, "T2");
  EXPECT_EQ(rows[1].count, 1u);
  EXPECT_NEAR(rows[1].max_h, 0.2, 1e-12);
  EXPECT_NEAR(rows[1].rmse_v, 0.3, 1e-12);
  EXPECT_EQ(ev.unmatched(), 2u);
  EXPECT_TRUE(ev.dwell_mode());
  const auto alt = ev.altitude_rows();
  ASSERT_EQ(alt.size(), 2u);
  EXPECT_EQ(alt[0].count, 0u);
  EXPECT_EQ(alt[1].count, 1u);
  EXPECT_NEAR(alt[1].bias, 0.1, 1e-12);
  EXPECT_EQ(ev.altitudes_unmatched(), 1u);
}

}  // namespace
}  // namespace ips::eval
