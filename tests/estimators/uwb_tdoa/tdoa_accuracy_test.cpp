// The TDoA tracker on simulated scenarios, in-process (simulator -> estimator -> evaluator):
// tdoa-hall (L-shaped room, 6 anchors, master A4, drifting clocks with a rate random walk, 2 %
// loss) and lab (D1..D4, master D1). Clock estimates are checked against the simulator's clock
// truth (drivers/sim/models/uwb_tdoa.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <ips/clock_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <map>

#include "drivers/sim/models/uwb_tdoa.hpp"
#include "drivers/sim/simulator.hpp"
#include "estimators/uwb_tdoa/counter_wrap.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::uwb_tdoa {
namespace {

constexpr utime_t kStart = test::kSimStart;
constexpr double kHz = 63.8976e9;
constexpr double kWrapS = static_cast<double>(kCounterModulus) / kHz;

// Errors of one anchor's published clock estimates against the truth, after `after_s`.
struct ClockErrors {
  int count = 0;
  double max_rate_err_ppb = 0;
  double max_offset_err_ns = 0;
  double sum_sq_offset_ns = 0;
  double rms_offset_ns() const { return count ? std::sqrt(sum_sq_offset_ns / count) : NAN; }
};

struct RunResult {
  eval::ErrorRow row;
  TdoaStats stats;
  ClockSyncStats clock_stats;
  std::map<std::string, ClockErrors> clocks;  // per non-master anchor
  std::map<std::string, int> clock_msgs;      // per anchor, every status
  std::string master;
};

// Runs `scenario` (built-in or parsed) with `seed` for `duration_s`; `params` (YAML map text)
// become the site's estimators.uwb_tdoa.
RunResult run(const sim::Scenario& scenario, uint64_t seed, double duration_s,
              const std::string& params = "", double clock_after_s = 10.0) {
  sim::Scenario sc = scenario;
  sc.duration_s = duration_s;
  const sim::SensorSection* tdoa = sc.sensor("uwb_tdoa");
  EXPECT_NE(tdoa, nullptr);
  const sim::SimWorld world{sc.site, sc.trajectories, seed};
  const double latency_s = tdoa->section.get_double("report_latency_s", 0.002);
  const std::string master = tdoa->section.get_string("master", "");

  RunResult r;
  eval::Evaluator ev;
  TdoaEstimator est(
      [&](const pose_t& p) { ev.add_estimate("POSE_TDOA", p); },
      [&](const clock_t& c) {
        ++r.clock_msgs[c.anchor_id];
        if (c.anchor_id == c.master_id || c.status != 0) return;
        // The sync was sent report_latency_s before its report's utime.
        const double t = utime_to_s(c.utime - kStart) - latency_s;
        if (t < clock_after_s) return;
        const auto ta = sim::uwb_tdoa_clock_truth(tdoa->section, world, c.anchor_id, t);
        const auto tm = sim::uwb_tdoa_clock_truth(tdoa->section, world, c.master_id, t);
        const double true_rate = ((1 + ta.rate_ppb * 1e-9) / (1 + tm.rate_ppb * 1e-9) - 1) * 1e9;
        double off = std::fmod(c.offset_s - (ta.offset_s - tm.offset_s), kWrapS);
        if (off > kWrapS / 2) off -= kWrapS;
        if (off < -kWrapS / 2) off += kWrapS;
        ClockErrors& e = r.clocks[c.anchor_id];
        ++e.count;
        e.max_rate_err_ppb = std::max(e.max_rate_err_ppb, std::abs(c.rate_ppb - true_rate));
        e.max_offset_err_ns = std::max(e.max_offset_err_ns, std::abs(off) * 1e9);
        e.sum_sq_offset_ns += off * 1e18 * off;
      });
  Site site = sc.site;
  if (!params.empty()) site.estimators = parse_yaml_text("uwb_tdoa: " + params, "params");
  est.set_site(site);
  test::run_simulated(sc, seed,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_rx = [&](const uwb_rx_t& m) { est.on_rx(m); }});
  est.flush();
  auto rows = ev.rows();
  EXPECT_EQ(rows.size(), 1u);
  if (!rows.empty()) r.row = rows[0];
  r.stats = est.stats();
  r.clock_stats = est.clock_stats();
  r.master = est.master_id();
  EXPECT_EQ(r.master, master);
  return r;
}

void print(const char* what, const RunResult& r) {
  std::printf(
      "%s: count %zu rmse_h %.3f p95_h %.3f max_h %.3f; tdoa used %lld gated %lld "
      "geometry %lld no-clock %lld inits %lld; syncs used %lld gated %lld\n",
      what, r.row.count, r.row.rmse_h, r.row.p95_h, r.row.max_h,
      static_cast<long long>(r.stats.tdoa_used), static_cast<long long>(r.stats.rejected_gate),
      static_cast<long long>(r.stats.rejected_geometry),
      static_cast<long long>(r.stats.rx_no_clock), static_cast<long long>(r.stats.initialisations),
      static_cast<long long>(r.clock_stats.syncs_used),
      static_cast<long long>(r.clock_stats.rejected_gate));
  for (const auto& [id, e] : r.clocks)
    std::printf(
        "  clock %s: %d estimates after 10 s, max |rate err| %.3f ppb, offset err rms "
        "%.3f ns max %.3f ns\n",
        id.c_str(), e.count, e.max_rate_err_ppb, e.rms_offset_ns(), e.max_offset_err_ns);
}

const sim::Scenario& hall() {
  static const sim::Scenario sc = sim::load_scenario("tdoa-hall");
  return sc;
}

// The brief's bounds on tdoa-hall (120 s, drifting clocks): horizontal RMSE <= 0.20 m; every
// anchor's rate within 5 ppb of the truth after 10 s. Offsets: the sync timestamps have
// sigma 0.17 ns, so a filtered offset within 1 ns (6 sigma of one raw sync) is tracking.
TEST(TdoaAccuracy, TdoaHallSeed1MeetsPositionAndClockBounds) {
  const RunResult r = run(hall(), 1, 120);
  print("tdoa-hall seed 1 120 s", r);
  EXPECT_GT(r.row.count, 1000u);  // 10 Hz for 120 s, less the clocks' acquisition
  EXPECT_LE(r.row.rmse_h, 0.20);
  // 2D (STATUS_2D) at the site's tag height: ips-eval scores no vertical error for it.
  EXPECT_TRUE(std::isnan(r.row.rmse_v)) << r.row.rmse_v;
  ASSERT_EQ(r.clocks.size(), 5u);        // A1..A6 but the master A4
  for (const auto& [id, e] : r.clocks) {
    EXPECT_GE(e.count, 45) << id;  // one per sync from 10 s to 120 s, less the lost ones
    EXPECT_LE(e.max_rate_err_ppb, 5.0) << id;
    EXPECT_LE(e.max_offset_err_ns, 1.0) << id;
  }
  // Every anchor, the master included, publishes its clock.
  EXPECT_EQ(r.clock_msgs.size(), 6u);
}

TEST(TdoaAccuracy, TdoaHallAccuracyHoldsOverSeeds) {
  for (uint64_t seed : {2, 3, 4, 5}) {
    const RunResult r = run(hall(), seed, 120);
    char what[64];
    std::snprintf(what, sizeof what, "tdoa-hall seed %llu 120 s",
                  static_cast<unsigned long long>(seed));
    print(what, r);
    EXPECT_LE(r.row.rmse_h, 0.20) << "seed " << seed;
    for (const auto& [id, e] : r.clocks) {
      EXPECT_LE(e.max_rate_err_ppb, 5.0) << "seed " << seed << " " << id;
      EXPECT_LE(e.max_offset_err_ns, 1.0) << "seed " << seed << " " << id;
    }
  }
}

}  // namespace
}  // namespace ips::uwb_tdoa

namespace ips::uwb_tdoa {
namespace {

const sim::Scenario& lab() {
  static const sim::Scenario sc = sim::load_scenario("lab");
  return sc;
}

// tdoa-hall with pieces of its text replaced.
sim::Scenario hall_variant(const std::vector<std::pair<std::string, std::string>>& edits,
                           const std::string& origin) {
  std::string text = sim::builtin_scenario_text("tdoa-hall");
  for (const auto& [from, to] : edits) {
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
  }
  return sim::parse_scenario_text(text, origin);
}

// lab (10 x 8 m, D1..D4 in the corners at 2.6 m, master D1, drifting clocks without a random
// walk, 2 % loss), 60 s. Measured: horizontal RMSE 0.060 to 0.062 m and 95th percentile 0.100 to
// 0.108 m over seeds 1 to 3; the bounds leave a margin of about 60 %.
TEST(TdoaAccuracy, LabMeetsMeasuredBound) {
  for (uint64_t seed : {1, 2, 3}) {
    const RunResult r = run(lab(), seed, 60);
    char what[64];
    std::snprintf(what, sizeof what, "lab seed %llu 60 s", static_cast<unsigned long long>(seed));
    print(what, r);
    EXPECT_GT(r.row.count, 540u) << "seed " << seed;  // 10 Hz from about 4 s on
    EXPECT_LE(r.row.rmse_h, 0.10) << "seed " << seed;
    EXPECT_LE(r.row.p95_h, 0.18) << "seed " << seed;
    ASSERT_EQ(r.clocks.size(), 3u);
    for (const auto& [id, e] : r.clocks) {
      EXPECT_LE(e.max_rate_err_ppb, 5.0) << id;
      EXPECT_LE(e.max_offset_err_ns, 1.0) << id;
    }
  }
}

// The other update and reference choices meet the tdoa-hall bound too (the vector update with
// the full covariance does not depend on the reference; sequential updates are a little worse).
TEST(TdoaAccuracy, TdoaHallOtherChoicesMeetTheBound) {
  for (const char* params :
       {"{update: sequential}", "{reference: master}", "{reference: A1}", "{master: A4}"}) {
    const RunResult r = run(hall(), 1, 120, params);
    print(params, r);
    EXPECT_LE(r.row.rmse_h, 0.20) << params;
    EXPECT_GT(r.row.count, 1000u) << params;
  }
}

// 30 % of all receptions lost, syncs included: clocks are predicted across missed syncs (up to
// several in a row) and epochs are often one or two anchors short.
TEST(TdoaAccuracy, TdoaHallWithHeavyLoss) {
  const sim::Scenario sc =
      hall_variant({{"loss_probability: 0.02", "loss_probability: 0.3"}}, "tdoa-hall-lossy.yaml");
  const RunResult r = run(sc, 1, 120);
  print("tdoa-hall 30 % loss seed 1", r);
  EXPECT_LE(r.row.rmse_h, 0.20);
  EXPECT_GT(r.row.count, 900u);
  for (const auto& [id, e] : r.clocks) EXPECT_LE(e.max_rate_err_ppb, 5.0) << id;
}

// Several tags at once: tdoa-hall's walker three times, started a third of a lap apart.
TEST(TdoaAccuracy, TdoaHallThreeTags) {
  sim::Scenario sc = hall();
  sim::replicate_walkers(sc, 3);
  sc.duration_s = 60;
  eval::Evaluator ev;
  TdoaEstimator est([&](const pose_t& p) { ev.add_estimate("POSE_TDOA", p); },
                    [](const clock_t&) {});
  est.set_site(sc.site);
  test::run_simulated(sc, 1,
                      {.truth = [&](const pose_t& m) { ev.add_truth(m); },
                       .uwb_rx = [&](const uwb_rx_t& m) { est.on_rx(m); }});
  const auto rows = ev.rows();
  ASSERT_EQ(rows.size(), 3u);
  for (const auto& row : rows) {
    std::printf("tdoa-hall 3 tags seed 1 60 s: %s count %zu rmse_h %.3f p95_h %.3f\n",
                row.tag.c_str(), row.count, row.rmse_h, row.p95_h);
    EXPECT_GT(row.count, 500u) << row.tag;
    EXPECT_LE(row.rmse_h, 0.20) << row.tag;
  }
}

// 3D: tdoa-hall with the anchors alternately at 0.5 m and 2.5 m and the tag's height left out
// of the site, so that the tracker estimates it.
TEST(TdoaAccuracy, TdoaHallThreeDimensional) {
  const sim::Scenario sc = hall_variant({{"[11.7, 0.3, 2.5]", "[11.7, 0.3, 0.5]"},
                                         {"[5.8, 3.8, 2.5]", "[5.8, 3.8, 0.5]"},
                                         {"[0.3, 7.7, 2.5]", "[0.3, 7.7, 0.5]"},
                                         {"    - {id: T1, height_m: 1.2}\n", "    - {id: T1}\n"}},
                                        "tdoa-hall-3d.yaml");
  const RunResult r = run(sc, 1, 120);
  print("tdoa-hall 3D seed 1", r);
  std::printf("  rmse_v %.3f\n", r.row.rmse_v);
  EXPECT_LE(r.row.rmse_h, 0.20);
  EXPECT_LE(r.row.rmse_v, 0.30);
  EXPECT_GT(r.row.count, 1000u);
}

}  // namespace
}  // namespace ips::uwb_tdoa

namespace ips::uwb_tdoa {
namespace {

// Issue 22: a sync_sigma_ns 10x too small (0.017 ns against the simulator's 0.17 ns) shows
// within 10 s of data in the range differences, which name both settings they depend on, and
// by 30 s (syncs come every 2 s) in each anchor's sync innovations; the right setting raises
// nothing.
TEST(TdoaConsistency, ASyncSigmaTenTimesTooSmallIsNamedWithinTenSeconds) {
  for (const char* sigma : {"0.017", "0.17"}) {
    SCOPED_TRACE(std::string("sync_sigma_ns ") + sigma);
    sim::Scenario sc = sim::load_scenario("tdoa-hall");
    sc.duration_s = 30;
    Site site = sc.site;
    site.estimators = parse_yaml_text(std::string("uwb_tdoa: {sync_sigma_ns: ") + sigma + "}", "params");
    TdoaEstimator est([](const pose_t&) {}, [](const clock_t&) {});
    est.set_site(site);
    std::string at_10s;
    bool seen_10s = false;
    test::run_simulated(sc, 1, {.uwb_rx = [&](const uwb_rx_t& m) {
                                  est.on_rx(m);
                                  if (!seen_10s && m.utime >= test::kSimStart + s_to_utime(10.0)) {
                                    seen_10s = true;
                                    at_10s = est.consistency().problems();
                                  }
                                }});
    const std::string problems = est.consistency().problems();
    if (std::string(sigma) == "0.17") {
      EXPECT_EQ(problems, "");
      EXPECT_EQ(at_10s, "");
      EXPECT_NE(est.consistency().summary().find("SYNC "), std::string::npos);
      continue;
    }
    EXPECT_NE(at_10s.find("TDOA "), std::string::npos) << at_10s;
    EXPECT_NE(at_10s.find("or sync_sigma_ns 0.017 looks too small for this input"),
              std::string::npos)
        << at_10s;
    EXPECT_NE(problems.find("SYNC "), std::string::npos) << problems;
    EXPECT_NE(problems.find(": innovations "), std::string::npos) << problems;
  }
}

}  // namespace
}  // namespace ips::uwb_tdoa
