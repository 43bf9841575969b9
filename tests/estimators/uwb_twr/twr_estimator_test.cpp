// The TWR tracker on the simulated lab (in-process: simulator -> estimator -> evaluator), and on
// exact geometry.
#include "estimators/uwb_twr/twr_estimator.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <random>
#include <vector>

#include "drivers/sim/simulator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::uwb_twr {
namespace {

struct RunResult {
  eval::ErrorRow row;
  TwrStats stats;
};

RunResult run_lab(uint64_t seed, double duration_s, const std::string& scenario = "lab") {
  sim::Scenario sc = sim::load_scenario(scenario);
  sc.duration_s = duration_s;
  eval::Evaluator ev;
  TwrEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_UWB", p); });
  test::run_simulated(sc, seed,
                      {.site = [&](const site_t& m) {
                         if (!est.has_site()) est.set_site(site_from_msg(m));
                       },
                       .truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_range = [&](const uwb_range_t& m) { est.on_range(m); }});
  auto rows = ev.rows();
  EXPECT_EQ(rows.size(), 1u);
  return {rows.empty() ? eval::ErrorRow{} : rows[0], est.stats()};
}

// Issue 6's bound: lab, 60 s: RMSE <= 0.12 m (issue 2's was 0.15 m), 95th percentile <= 0.30 m.
TEST(TwrEstimatorLab, Seed1SixtySecondsMeetsAccuracyBound) {
  RunResult r = run_lab(1, 60);
  std::printf("lab seed 1 60 s: count %zu rmse_h %.3f p95_h %.3f max_h %.3f; used %lld gated %lld\n",
              r.row.count, r.row.rmse_h, r.row.p95_h, r.row.max_h,
              static_cast<long long>(r.stats.ranges_used), static_cast<long long>(r.stats.rejected_gate));
  EXPECT_GT(r.row.count, 550u);  // ~10 Hz for 60 s
  EXPECT_LE(r.row.rmse_h, 0.12);
  EXPECT_LE(r.row.p95_h, 0.30);
  // 2D (STATUS_2D) at the site's tag height: ips-eval scores no vertical error for it.
  EXPECT_TRUE(std::isnan(r.row.rmse_v)) << r.row.rmse_v;
}

TEST(TwrEstimatorLab, AccuracyHoldsOverSeveralSeeds) {
  for (uint64_t seed : {2, 3, 4, 5, 6}) {
    RunResult r = run_lab(seed, 60);
    std::printf("lab seed %d 60 s: rmse_h %.3f p95_h %.3f\n", static_cast<int>(seed), r.row.rmse_h,
                r.row.p95_h);
    EXPECT_LE(r.row.rmse_h, 0.12) << "seed " << seed;
    EXPECT_LE(r.row.p95_h, 0.30) << "seed " << seed;
  }
}

// Ten tags walking the lab at once (each its own ranging slots): every tag is tracked on its own
// and meets the single-tag bound.
TEST(TwrEstimatorLab, TenTagsAtOnceEachMeetTheBound) {
  sim::Scenario sc = sim::load_scenario("lab");
  sc.duration_s = 30;
  sim::replicate_walkers(sc, 10);
  eval::Evaluator ev;
  TwrEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_UWB", p); });
  est.set_site(sc.site);
  test::run_simulated(sc, 1,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_range = [&](const uwb_range_t& m) { est.on_range(m); }});
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 10u);
  double worst = 0;
  for (const auto& row : rows) {
    EXPECT_GT(row.count, 200u) << row.tag;
    EXPECT_LE(row.rmse_h, 0.12) << row.tag;
    worst = std::max(worst, row.rmse_h);
  }
  std::printf("lab, 10 tags, 30 s: worst tag rmse_h %.3f\n", worst);
}

TEST(TwrEstimatorLab, GateRejectsMostNlosOutliers) {
  RunResult r = run_lab(1, 60);
  // 5 % of ~2400 ranges are NLOS (+0.3..1.5 m); most should be gated, few clean ones.
  const double nlos = 0.05 * static_cast<double>(r.stats.ranges_in);
  EXPECT_GT(static_cast<double>(r.stats.rejected_gate), 0.5 * nlos);
  EXPECT_LT(static_cast<double>(r.stats.rejected_gate), 3.0 * nlos);
}

Site square_site(double tag_height) {
  std::string yaml =
      "name: t\nanchors:\n"
      "  - {id: A1, position: [0, 0, 2.4]}\n"
      "  - {id: A2, position: [10, 0, 2.4]}\n"
      "  - {id: A3, position: [10, 8, 2.4]}\n"
      "  - {id: A4, position: [0, 8, 2.4]}\n"
      "tags:\n  - {id: T1" +
      (std::isnan(tag_height) ? std::string("}") : ", height_m: " + std::to_string(tag_height) + "}") +
      "\nestimators:\n  uwb_twr: {publish_period_s: 0.05}\n";
  return parse_site_text(yaml, "test");
}

uwb_range_t range_msg(utime_t t, const std::string& anchor, double r) {
  uwb_range_t m;
  m.utime = t;
  m.source = "test";
  m.tag_id = "T1";
  m.anchor_id = anchor;
  m.range_m = r;
  m.rx_power_dbm = m.fp_power_dbm = m.quality = NAN;
  m.seq = -1;
  return m;
}

// Noise-free ranges from a static tag to every anchor in turn, 25 ms apart.
void feed_exact_ranges(TwrEstimator& est, const Site& site, const Eigen::Vector3d& truth,
                       utime_t t0, int epochs) {
  utime_t t = t0;
  for (int e = 0; e < epochs; ++e)
    for (const auto& a : site.anchors) {
      est.on_range(range_msg(t, a.id, (truth - a.position).norm()));
      t += 25'000;
    }
}

TEST(TwrEstimator, ExactRangesToStaticTagGiveExactPosition) {
  const Site site = square_site(1.2);
  std::vector<pose_t> out;
  TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
  est.set_site(site);
  const Eigen::Vector3d truth(3.0, 5.0, 1.2);
  feed_exact_ranges(est, site, truth, 1'000'000, 50);
  ASSERT_FALSE(out.empty());
  const pose_t& last = out.back();
  EXPECT_NEAR(last.position[0], 3.0, 1e-3);
  EXPECT_NEAR(last.position[1], 5.0, 1e-3);
  EXPECT_DOUBLE_EQ(last.position[2], 1.2);
  EXPECT_TRUE(last.status & pose_t::STATUS_2D);
  // Covariance is published, positive, and small after many exact ranges.
  EXPECT_GT(last.position_cov[0], 0.0);
  EXPECT_LT(last.position_cov[0], 0.01);
}

TEST(TwrEstimator, ThreeDimensionalWhenTagHeightUnknown) {
  const Site site = square_site(NAN);
  std::vector<pose_t> out;
  TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
  est.set_site(site);
  const Eigen::Vector3d truth(6.0, 2.0, 0.8);
  feed_exact_ranges(est, site, truth, 1'000'000, 100);
  ASSERT_FALSE(out.empty());
  EXPECT_FALSE(out.back().status & pose_t::STATUS_2D);
  EXPECT_NEAR(out.back().position[0], 6.0, 0.01);
  EXPECT_NEAR(out.back().position[1], 2.0, 0.01);
  EXPECT_NEAR(out.back().position[2], 0.8, 0.05);
}

TEST(TwrEstimator, BadRangesAreCountedNotUsed) {
  const Site site = square_site(1.2);
  int published = 0;
  TwrEstimator est([&](const pose_t&) { ++published; });
  est.set_site(site);
  est.on_range(range_msg(1'000'000, "A1", NAN));
  est.on_range(range_msg(1'000'000, "A1", -1.0));
  est.on_range(range_msg(1'000'000, "A1", 1e9));
  est.on_range(range_msg(1'000'000, "NOPE", 3.0));
  EXPECT_EQ(est.stats().dropped_invalid, 3);
  EXPECT_EQ(est.stats().dropped_unknown_anchor, 1);
  EXPECT_EQ(published, 0);
}

TEST(TwrEstimator, LateRangesBeyondToleranceAreDropped) {
  const Site site = square_site(1.2);
  TwrEstimator est([](const pose_t&) {});
  est.set_site(site);
  const Eigen::Vector3d truth(3.0, 5.0, 1.2);
  est.on_range(range_msg(2'000'000, "A1", (truth - site.anchors[0].position).norm()));
  est.on_range(range_msg(1'000'000, "A2", (truth - site.anchors[1].position).norm()));
  EXPECT_EQ(est.stats().dropped_late, 1);
}

// A LAN repeats datagrams: a copy of a range is a duplicate (routine), not a second range fused.
// The same stamp and anchor with another sequence number or value is another range.
TEST(TwrEstimator, ACopiedRangeIsADuplicateNotASecondRange) {
  const Site site = square_site(1.2);
  std::vector<pose_t> once_out, twice_out;
  TwrEstimator once([&](const pose_t& p) { once_out.push_back(p); });
  TwrEstimator twice([&](const pose_t& p) { twice_out.push_back(p); });
  once.set_site(site);
  twice.set_site(site);
  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  const Eigen::Vector3d truth(3.0, 5.0, 1.2);
  utime_t t = 1'000'000;
  int copies = 0;
  for (int e = 0; e < 40; ++e)
    for (const auto& a : site.anchors) {
      uwb_range_t m = range_msg(t, a.id, (truth - a.position).norm() + noise(rng));
      m.seq = copies;
      once.on_range(m);
      twice.on_range(m);
      twice.on_range(m);
      ++copies;
      t += 25'000;
    }
  EXPECT_EQ(twice.stats().dropped_duplicate, copies);
  EXPECT_EQ(twice.drop_reasons().count(DropReason::kDuplicate), copies);
  EXPECT_TRUE(drop_reason_is_routine(DropReason::kDuplicate));
  EXPECT_EQ(twice.stats().ranges_used, once.stats().ranges_used);
  ASSERT_FALSE(once_out.empty());
  ASSERT_EQ(twice_out.size(), once_out.size());
  for (size_t k = 0; k < once_out.size(); ++k)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(twice_out[k].position[c], once_out[k].position[c]) << k;

  uwb_range_t m = range_msg(t, "A1", 4.0);
  m.seq = 1000;
  once.on_range(m);
  m.seq = 1001;
  once.on_range(m);
  m.range_m = 4.01;
  once.on_range(m);
  EXPECT_EQ(once.stats().dropped_duplicate, 0);
  once.on_range(m);
  EXPECT_EQ(once.stats().dropped_duplicate, 1);
}

TEST(TwrEstimator, ABogusStampCostsNothingAndAClockStepBackRestartsTheTrack) {
  const Site site = square_site(1.2);
  std::vector<pose_t> out;
  TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
  est.set_site(site);
  const Eigen::Vector3d truth(3.0, 5.0, 1.2);
  feed_exact_ranges(est, site, truth, 1'000'000'000, 20);
  // One range stamped an hour ahead (a bogus stamp), then the clock carries on as before: the
  // bogus one is held by the time guard and dropped, nothing else is lost.
  est.on_range(range_msg(1'000'000'000 + 3'600'000'000LL, "A1", 1.0));
  feed_exact_ranges(est, site, truth, 1'002'100'000, 20);
  std::vector<pose_t> clean_out;
  TwrEstimator clean([&](const pose_t& p) { clean_out.push_back(p); });
  clean.set_site(site);
  feed_exact_ranges(clean, site, truth, 1'000'000'000, 20);
  feed_exact_ranges(clean, site, truth, 1'002'100'000, 20);
  EXPECT_EQ(est.stats().time_resets, 0);
  EXPECT_EQ(est.drop_reasons().count(DropReason::kTimeJump), 1);
  EXPECT_EQ(out.size(), clean_out.size());
  size_t before = out.size();
  // The clock really steps back 100 s (a driver restarted on another host): confirmed by the
  // stamps that follow, the track starts afresh on the new timeline.
  before = out.size();
  feed_exact_ranges(est, site, truth, 1'000'000'000 - 100'000'000, 20);
  EXPECT_EQ(est.time_stats().reanchors_back, 1);
  ASSERT_GT(out.size(), before + 5);
  EXPECT_LT(out.back().utime, 1'000'000'000);
  EXPECT_NEAR(out.back().position[0], 3.0, 1e-3);
  EXPECT_NEAR(out.back().position[1], 5.0, 1e-3);
}

TEST(TwrEstimator, ImplausibleTimestampsAreInvalid) {
  const Site site = square_site(1.2);
  TwrEstimator est([](const pose_t&) {});
  est.set_site(site);
  est.on_range(range_msg(0, "A1", 3.0));
  est.on_range(range_msg(-5, "A1", 3.0));
  est.on_range(range_msg(INT64_MAX, "A1", 3.0));
  EXPECT_EQ(est.stats().dropped_invalid, 3);
}

TEST(TwrEstimator, LateRangesCannotCreepBackwards) {
  const Site site = square_site(1.2);
  TwrEstimator est([](const pose_t&) {});
  est.set_site(site);
  // Each range 40 ms older than the previous: within the 50 ms tolerance of its predecessor, but
  // from the third on more than 50 ms behind the newest.
  for (int i = 0; i < 5; ++i) est.on_range(range_msg(10'000'000 - i * 40'000, "A1", 5.0));
  EXPECT_EQ(est.stats().dropped_late, 3);
}

TEST(TwrEstimator, TagIdsOffTheBusCannotExhaustMemory) {
  Site site = parse_site_text(
      "anchors:\n  - {id: A1, position: [0, 0, 2.4]}\nestimators:\n  uwb_twr: {max_tags: 3}\n", "s");
  TwrEstimator est([](const pose_t&) {});
  est.set_site(site);
  for (int i = 0; i < 10; ++i) {
    uwb_range_t m = range_msg(1'000'000 + i, "A1", 3.0);
    m.tag_id = "tag" + std::to_string(i);
    est.on_range(m);
  }
  EXPECT_EQ(est.stats().dropped_too_many_tags, 7);
  // Much later the silent tracks are evicted and a new id gets a track.
  uwb_range_t later = range_msg(1'000'000 + 60'000'000, "A1", 3.0);
  later.tag_id = "new";
  est.on_range(later);
  EXPECT_EQ(est.stats().dropped_too_many_tags, 7);
  uwb_range_t empty = later;
  empty.tag_id = "";
  est.on_range(empty);
  EXPECT_EQ(est.stats().dropped_invalid, 1);
}

TEST(TwrEstimator, NoSiteNoOutput) {
  int published = 0;
  TwrEstimator est([&](const pose_t&) { ++published; });
  est.on_range(range_msg(1'000'000, "A1", 3.0));
  EXPECT_EQ(published, 0);
  EXPECT_EQ(est.stats().ranges_in, 1);
}

TEST(TwrParams, BadValueNamesTheField) {
  Site site = parse_site_text(
      "anchors:\n  - {id: A1, position: [0, 0, 0]}\nestimators:\n  uwb_twr:\n    range_sigma_m: -1\n",
      "site.yaml");
  TwrEstimator est([](const pose_t&) {});
  try {
    est.set_site(site);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "site.yaml:5: estimators.uwb_twr.range_sigma_m: must be in (0, 1e6]");
  }
}

// The NLOS ramp's foot must lie below its top (issue 27), named where it is set.
TEST(TwrParams, NlosPowerRampOutOfOrderIsRefused) {
  try {
    parse_twr_params(parse_site_text(
        "anchors: []\nestimators:\n  uwb_twr: {nlos_power_db: 8, nlos_power_los_db: 9}\n", "site.yaml")
                         .estimator_params("uwb_twr"));
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("nlos_power_los_db: must be below nlos_power_db"),
              std::string::npos)
        << e.what();
  }
  // Off (nlos_power_db 0): the foot does not matter.
  EXPECT_NO_THROW(parse_twr_params(
      parse_site_text("anchors: []\nestimators:\n  uwb_twr: {nlos_power_db: 0}\n", "s").estimator_params(
          "uwb_twr")));
}

TEST(TwrEstimator, EveryInitialisationSolverStartsTheTrack) {
  for (const char* solver : {"lm", "gauss_newton", "foy"}) {
    Site site = parse_site_text(
        "anchors:\n  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
        "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
        "tags:\n  - {id: T1, height_m: 1.2}\nestimators:\n  uwb_twr: {init_solver: " +
            std::string(solver) + "}\n",
        "test");
    std::vector<pose_t> out;
    TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
    est.set_site(site);
    EXPECT_EQ(multilateration_solver_name(est.params().init_solver), std::string(solver));
    feed_exact_ranges(est, site, {7.0, 2.5, 1.2}, 1'000'000, 2);
    ASSERT_FALSE(out.empty()) << solver;
    EXPECT_EQ(est.stats().initialisations, 1) << solver;
    EXPECT_NEAR(out.front().position[0], 7.0, 0.01) << solver;
    EXPECT_NEAR(out.front().position[1], 2.5, 0.01) << solver;
  }
}

TEST(TwrEstimator, AnchorToAnchorRangesAreCountedNotTracked) {
  const Site site = square_site(1.2);
  int published = 0;
  TwrEstimator est([&](const pose_t&) { ++published; });
  est.set_site(site);
  for (int i = 0; i < 20; ++i) {
    uwb_range_t m = range_msg(1'000'000 + i * 25'000, "A2", 10.0);
    m.tag_id = "A1";
    est.on_range(m);
  }
  EXPECT_EQ(est.stats().anchor_pair_ranges, 20);
  EXPECT_EQ(est.stats().initialisations, 0);
  EXPECT_EQ(published, 0);
}

// A long range inside the gate moves the estimate less with down-weighting than without.
TEST(TwrEstimator, LongRangesAreDownWeighted) {
  auto pull = [](double downweight_sigma, int64_t* downweighted) {
    Site site = parse_site_text(
        "anchors:\n  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
        "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
        "tags:\n  - {id: T1, height_m: 1.2}\nestimators:\n  uwb_twr: {nlos_gate_sigma: 100, "
        "nlos_downweight_sigma: " +
            std::to_string(downweight_sigma) + "}\n",
        "test");
    std::vector<pose_t> out;
    TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
    est.set_site(site);
    const Eigen::Vector3d truth(4.0, 3.0, 1.2);
    feed_exact_ranges(est, site, truth, 1'000'000, 20);
    utime_t t = 1'000'000 + 80 * 25'000 + 100'000;
    est.on_range(range_msg(t, "A1", (truth - site.anchors[0].position).norm() + 1.0));
    est.on_range(range_msg(t + 100'000, "A2", (truth - site.anchors[1].position).norm()));
    *downweighted = est.stats().downweighted;
    return std::hypot(out.back().position[0] - 4.0, out.back().position[1] - 3.0);
  };
  int64_t dw_on = 0, dw_off = 0;
  const double on = pull(1.5, &dw_on), off = pull(1000.0, &dw_off);
  EXPECT_EQ(dw_on, 1);
  EXPECT_EQ(dw_off, 0);
  EXPECT_GT(off, 0.02);
  EXPECT_LT(on, 0.5 * off);
}

// The receiver's NLOS indicator (issues 22, 27): a range whose rx - first-path power exceeds
// nlos_power_db (Decawave APS006: > 10 dB likely NLOS) gets nlos_power_var_scale times the
// variance and is counted; one between nlos_power_los_db (6 dB) and 10 dB a part of it, rising
// with the difference; a range without powers, or under 6 dB, is not; 0 turns the indicator off. The range is 0.2 m long, inside the gates and below the Huber threshold, so
// only the indicator weighs it.
TEST(TwrEstimator, RangesWithALargeRxMinusFirstPathPowerGetLessWeightAndAreCounted) {
  auto pull = [](const std::string& settings, double rx, double fp, int64_t* flagged) {
    Site site = parse_site_text(
        "anchors:\n  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
        "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
        "tags:\n  - {id: T1, height_m: 1.2}\nestimators:\n  uwb_twr: {nlos_gate_sigma: 100, "
        "nlos_downweight_sigma: 1000, learn_noise: false" + settings + "}\n",
        "test");
    std::vector<pose_t> out;
    TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
    est.set_site(site);
    const Eigen::Vector3d truth(4.0, 3.0, 1.2);
    feed_exact_ranges(est, site, truth, 1'000'000, 20);
    utime_t t = 1'000'000 + 80 * 25'000 + 100'000;
    uwb_range_t m = range_msg(t, "A1", (truth - site.anchors[0].position).norm() + 0.2);
    m.rx_power_dbm = static_cast<float>(rx);
    m.fp_power_dbm = static_cast<float>(fp);
    est.on_range(m);
    est.on_range(range_msg(t + 100'000, "A2", (truth - site.anchors[1].position).norm()));
    *flagged = est.stats().nlos_power;
    return std::hypot(out.back().position[0] - 4.0, out.back().position[1] - 3.0);
  };
  int64_t n_nlos = 0, n_los = 0, n_none = 0, n_off = 0, n_fp_nan = 0, n_mid = 0, n_mid_step = 0;
  const double nlos = pull("", -80.0, -95.0, &n_nlos);         // 15 dB: likely NLOS
  const double mid = pull("", -80.0, -89.0, &n_mid);           // 9 dB: likelihood 0.75
  // With the ramp's foot at 8.9 dB the same range is hardly weighed down (likelihood 0.09).
  const double mid_step = pull(", nlos_power_los_db: 8.9", -80.0, -89.0, &n_mid_step);
  const double los = pull("", -80.0, -83.0, &n_los);           // 3 dB: LOS
  const double none = pull("", NAN, NAN, &n_none);             // no powers
  const double fp_nan = pull("", -80.0, NAN, &n_fp_nan);       // one power only
  const double off = pull(", nlos_power_db: 0", -80.0, -95.0, &n_off);
  EXPECT_EQ(n_nlos, 1);
  EXPECT_EQ(n_los, 0);
  EXPECT_EQ(n_none, 0);
  EXPECT_EQ(n_fp_nan, 0);
  EXPECT_EQ(n_off, 0);
  EXPECT_GT(los, 0.02);
  EXPECT_DOUBLE_EQ(los, none);
  EXPECT_DOUBLE_EQ(los, fp_nan);
  EXPECT_DOUBLE_EQ(los, off);
  EXPECT_LT(nlos, 0.4 * los);  // 10x the variance: a fraction of the pull
  EXPECT_EQ(n_mid, 1);         // more likely NLOS than not
  EXPECT_EQ(n_mid_step, 0);
  EXPECT_GT(mid, nlos);        // 7.75x the variance: between the two
  EXPECT_LT(mid, 0.5 * los);
  EXPECT_GT(mid_step, 0.7 * los);  // 1.8x the variance
  const NlosPower model;  // the defaults: 6 and 10 dB, 10x
  EXPECT_DOUBLE_EQ(model.likelihood(-80.0, -91.0), 1.0);
  EXPECT_DOUBLE_EQ(model.likelihood(-80.0, -88.0), 0.5);
  EXPECT_DOUBLE_EQ(model.likelihood(-80.0, -85.0), 0.0);
  EXPECT_DOUBLE_EQ(model.likelihood(-80.0, NAN), 0.0);
  EXPECT_DOUBLE_EQ(model.variance_scale(0.5), 5.5);
  EXPECT_DOUBLE_EQ((NlosPower{6.0, 0.0, 10.0}).likelihood(-80.0, -95.0), 0.0);  // off
}

// range_bias_m and range_bias_per_m are taken off every range: ranges 0.1 m + 1 % long give the
// true position with the matching correction, and an offset one without it.
TEST(TwrEstimator, RangeBiasIsRemovedWhenConfigured) {
  auto error = [](const std::string& settings) {
    Site site = parse_site_text(
        "anchors:\n  - {id: A1, position: [0, 0, 2.4]}\n  - {id: A2, position: [10, 0, 2.4]}\n"
        "  - {id: A3, position: [10, 8, 2.4]}\n  - {id: A4, position: [0, 8, 2.4]}\n"
        "tags:\n  - {id: T1, height_m: 1.2}\nestimators:\n  uwb_twr: {learn_noise: false" +
            settings + "}\n",
        "test");
    std::vector<pose_t> out;
    TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
    est.set_site(site);
    const Eigen::Vector3d truth(3.0, 2.0, 1.2);
    utime_t t = 1'000'000;
    for (int e = 0; e < 40; ++e)
      for (const auto& a : site.anchors) {
        // measured = true + 0.1 + 0.01 * measured: the model's inverse.
        est.on_range(range_msg(t, a.id, ((truth - a.position).norm() + 0.1) / 0.99));
        t += 25'000;
      }
    EXPECT_FALSE(out.empty());
    return out.empty() ? 1e9 : std::hypot(out.back().position[0] - 3.0, out.back().position[1] - 2.0);
  };
  EXPECT_LT(error(", range_bias_m: 0.1, range_bias_per_m: 0.01"), 0.005);
  EXPECT_GT(error(", learn_bias: false"), 0.05);
  // Learned online (the default), the offset costs less than left in (a static tag: only what
  // its one geometry observes is learned).
  EXPECT_LT(error(""), 0.6 * error(", learn_bias: false"));
  // Per pair (range_scales, range_offsets_m; ips-uwb-calibrate --scale): divided by 1 + s, then
  // the offset off. Here measured = 1.0101 (true + 0.1), so s = 0.0101..., offset 0.1.
  EXPECT_LT(error(", learn_bias: false, range_scales: {A1: 0.01010101, A2: 0.01010101, "
                  "A3: 0.01010101, T1/A4: 0.01010101}, range_offsets_m: {A1: 0.1, A2: 0.1, "
                  "A3: 0.1, A4: 0.1}"),
            0.005);
  EXPECT_GT(error(", learn_bias: false, range_offsets_m: {A1: 0.1, A2: 0.1, A3: 0.1, A4: 0.1}"),
            0.01);
  EXPECT_THROW(parse_twr_params(parse_site_text(
                                    "anchors: []\nestimators:\n  uwb_twr: {range_scales: {A1: 0.2}}\n",
                                    "test")
                                    .estimator_params("uwb_twr")),
               ConfigError);
  EXPECT_THROW(parse_twr_params(parse_site_text("estimators:\n  uwb_twr: {range_bias_per_m: 0.5}\n",
                                                "test")
                                    .estimator_params("uwb_twr")),
               ConfigError);
}

// The tag walks a circle while anchors drop out: 4, then 2 (A1, A2), then 1 (A1), then 4 again.
// With 1 or 2 the published covariance grows and keeps covering the error (no overconfident
// jump); no estimate moves from the one before by more than the tag's walk plus the gate
// (gate_sigma 4 times the previous estimate's sigma); when the other anchors come back their
// ranges pass the gate and the error shrinks to what it was before, without a re-initialisation.
TEST(TwrEstimator, FewAnchorsGrowTheCovarianceAndReacquisitionIsSmooth) {
  const Site site = square_site(1.2);
  std::vector<pose_t> out;
  TwrEstimator est([&](const pose_t& p) { out.push_back(p); });
  est.set_site(site);
  auto truth_at = [](utime_t t) {
    const double a = utime_to_s(t - 1'000'000) / 3.0;  // 1 m/s on a 3 m radius
    return Eigen::Vector3d(5.0 + 3.0 * std::cos(a), 4.0 + 3.0 * std::sin(a), 1.2);
  };
  struct Phase {
    double end_s;
    std::vector<size_t> anchors;
  };
  const Phase phases[] = {{10, {0, 1, 2, 3}}, {20, {0, 1}}, {28, {0}}, {40, {0, 1, 2, 3}}};
  utime_t t = 1'000'000;
  int64_t gated_before_return = 0, inits_before_return = 0;
  double max_step_ratio = 0, max_sigma_1 = 0, max_sigma_4 = 0, error_before = 0;
  int inside = 0, total = 0;
  for (const Phase& ph : phases) {
    if (ph.end_s == 40) {
      gated_before_return = est.stats().rejected_gate;
      inits_before_return = est.stats().initialisations;
    }
    const size_t first = out.size();
    while (utime_to_s(t - 1'000'000) < ph.end_s)
      for (size_t i : ph.anchors) {
        const auto& a = site.anchors[i];
        est.on_range(range_msg(t, a.id, (truth_at(t) - a.position).norm()));
        t += 25'000;
      }
    for (size_t k = std::max<size_t>(first, 1); k < out.size(); ++k) {
      const pose_t& p = out[k];
      const double step = std::hypot(p.position[0] - out[k - 1].position[0],
                                     p.position[1] - out[k - 1].position[1]);
      const double prev_sigma = std::sqrt(out[k - 1].position_cov[0] + out[k - 1].position_cov[4]);
      max_step_ratio = std::max(
          max_step_ratio, step / (1.0 * utime_to_s(p.utime - out[k - 1].utime) + 4 * prev_sigma));
      Eigen::Matrix2d P;
      P << p.position_cov[0], p.position_cov[1], p.position_cov[3], p.position_cov[4];
      const double sigma = std::sqrt(P.trace());
      if (ph.anchors.size() == 4 && ph.end_s == 10 && k > first + 20)
        max_sigma_4 = std::max(max_sigma_4, sigma);
      const Eigen::Vector3d tr = truth_at(p.utime);
      const Eigen::Vector2d e(p.position[0] - tr.x(), p.position[1] - tr.y());
      if (ph.end_s == 10) error_before = e.norm();
      if (ph.anchors.size() == 4) continue;
      if (ph.anchors.size() == 1) max_sigma_1 = std::max(max_sigma_1, sigma);
      inside += e.dot(P.inverse() * e) <= 13.8;  // chi-square, 2 dof, 99.9 %
      ++total;
    }
  }
  ASSERT_GT(total, 100);
  const pose_t& last = out.back();
  const Eigen::Vector3d tr = truth_at(last.utime);
  const double final_error = std::hypot(last.position[0] - tr.x(), last.position[1] - tr.y());
  std::printf("sigma %.3f m with 4 anchors, up to %.2f m with 1; %d/%d of the 1- and 2-anchor "
              "estimates inside their 99.9 %% ellipse; largest step %.2f of walk + gate; error "
              "%.3f m before, %.3f m at the end\n",
              max_sigma_4, max_sigma_1, inside, total, max_step_ratio, error_before, final_error);
  EXPECT_GT(max_sigma_1, 5 * max_sigma_4);          // it grew
  EXPECT_GE(inside, total * 95 / 100);              // and kept covering the error
  EXPECT_LT(max_step_ratio, 1.0);                   // no jump beyond the gate
  EXPECT_EQ(est.stats().initialisations, inits_before_return);  // no restart on return
  EXPECT_LE(est.stats().rejected_gate - gated_before_return, 2);
  EXPECT_LT(final_error, 1.5 * error_before + 0.01);
}

TEST(TwrParams, UnknownSolverIsNamed) {
  Site site = parse_site_text(
      "anchors:\n  - {id: A1, position: [0, 0, 0]}\nestimators:\n  uwb_twr:\n    init_solver: newton\n",
      "site.yaml");
  TwrEstimator est([](const pose_t&) {});
  try {
    est.set_site(site);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "site.yaml:5: estimators.uwb_twr.init_solver: expected lm, gauss_newton or foy");
  }
}

}  // namespace
}  // namespace ips::uwb_twr

namespace ips::uwb_twr {
namespace {

// Issue 22: a range_sigma_m 10x too small (0.01 m against the simulator's 0.10 m) is named, by
// anchor and setting, within 10 s of data. Learning (the default) then uses the anchors' own
// noise, so the track keeps its accuracy and the process is not degraded; without learning it is.
// The right setting raises nothing.
TEST(TwrEstimatorConsistency, ARangeSigmaTenTimesTooSmallIsNamedWithinTenSeconds) {
  struct Case {
    const char* sigma;
    const char* learn;
  };
  for (const Case c : {Case{"0.01", "true"}, Case{"0.01", "false"}, Case{"0.1", "true"}}) {
    SCOPED_TRACE(std::string("range_sigma_m ") + c.sigma + ", learn_noise " + c.learn);
    sim::Scenario sc = sim::load_scenario("lab");
    sc.duration_s = 10;
    eval::Evaluator ev;
    TwrEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_UWB", p); });
    test::run_simulated(
        sc, 1,
        {.site = [&](const site_t& m) {
           if (!est.has_site())
             est.set_site(test::site_with_settings(
                 m, "uwb_twr", {{"range_sigma_m", c.sigma}, {"learn_noise", c.learn}}));
         },
         .truth = [&](const pose_t& m) { ev.add_truth(m); },
         .uwb_range = [&](const uwb_range_t& m) { est.on_range(m); }});
    const std::string problems = est.consistency().problems();
    const bool wrong = std::string(c.sigma) == "0.01";
    if (!wrong) {
      EXPECT_EQ(problems, "");
      EXPECT_FALSE(est.consistency().degraded());
      continue;
    }
    for (const char* anchor : {"A1", "A2", "A3", "A4"})
      EXPECT_NE(problems.find(std::string("RANGE ") + anchor + ": innovations "), std::string::npos)
          << problems;
    EXPECT_NE(problems.find("range_sigma_m 0.01 looks too small for this anchor"),
              std::string::npos)
        << problems;
    const bool learn = std::string(c.learn) == "true";
    EXPECT_EQ(est.consistency().degraded(), !learn) << problems;
    if (learn) {
      const auto rows = ev.rows();
      ASSERT_EQ(rows.size(), 1u);
      EXPECT_LE(rows[0].rmse_h, 0.15);
    }
  }
}

}  // namespace
}  // namespace ips::uwb_twr
