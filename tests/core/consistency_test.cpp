// core/consistency.hpp: the windowed innovation check and the learned noise.
#include "core/consistency.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace ips {
namespace {

// Feeds `n` scalar innovations at `rate_hz` whose true variance is `true_var` (prediction
// variance hph, so r ~ N(0, hph + true_var)), the estimator assuming `cfg_var`.
void feed(ConsistencyMonitor& m, const std::string& source, int n, double rate_hz, double hph,
          double true_var, double cfg_var, std::mt19937& rng, double t0 = 0.0,
          double gate_sigma = 3.0) {
  std::normal_distribution<double> noise(0.0, std::sqrt(hph + true_var));
  for (int i = 0; i < n; ++i) {
    const double used = m.variance("BARO", source, cfg_var);
    const double r = noise(rng);
    const bool gated = r * r > gate_sigma * gate_sigma * (hph + used);
    m.add_scalar("BARO", source, t0 + i / rate_hz, r, hph, cfg_var, gated, "pressure_sigma_pa 0.5");
  }
}

TEST(ChiSquareMedian, TableAndApproximation) {
  EXPECT_NEAR(chi2_median(1), 0.455, 1e-3);
  EXPECT_NEAR(chi2_median(2), 2.0 * std::log(2.0), 1e-4);
  EXPECT_NEAR(chi2_median(10), 9.342, 0.01);
}

TEST(ConsistencyMonitor, ConsistentDataIsOkAndLearnsTheTrueVariance) {
  std::mt19937 rng(1);
  ConsistencyMonitor m;
  feed(m, "B1", 200, 10.0, 0.1, 1.0, 1.0, rng);
  const auto v = m.verdicts();
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].state, ConsistencyMonitor::State::kOk);
  EXPECT_NEAR(v[0].ratio, 1.0, 0.35);
  EXPECT_EQ(m.problems(), "");
  EXPECT_FALSE(m.degraded());
  EXPECT_NEAR(m.variance("BARO", "B1", 1.0), 1.0, 0.4);
  EXPECT_NE(m.summary().find("BARO B1 "), std::string::npos);
}

// A setting 10x too small (variance 100x): named within 10 s of data at 1.7 Hz, even while the
// estimator gates nearly everything; learning brings the variance to the truth.
TEST(ConsistencyMonitor, TenTimesTooSmallSigmaIsNamedWithinTenSeconds) {
  for (bool learn : {true, false}) {
    std::mt19937 rng(2);
    ConsistencyOptions o;
    o.learn = learn;
    ConsistencyMonitor m(o);
    feed(m, "B1", 17, 1.7, 0.0001, 0.25, 0.0025, rng);  // 10 s
    const std::string p = m.problems();
    EXPECT_NE(p.find("BARO B1: innovations "), std::string::npos) << p;
    EXPECT_NE(p.find("x their assumed variance; pressure_sigma_pa 0.5 looks too small for this "
                     "sensor"),
              std::string::npos)
        << p;
    const auto v = m.verdicts();
    ASSERT_EQ(v.size(), 1u);
    EXPECT_EQ(v[0].state, ConsistencyMonitor::State::kNoisy);
    EXPECT_GT(v[0].ratio, 30.0);
    if (learn) {
      // Learned within bounds (400x is the bound: sigma 20x): compensated, not degraded.
      EXPECT_NEAR(m.variance("BARO", "B1", 0.0025), 0.25, 0.15);
      EXPECT_NE(p.find("learned sigma"), std::string::npos) << p;
    } else {
      // Named at the first check (10 samples); degraded when the second (20) agrees.
      EXPECT_FALSE(m.degraded());
      feed(m, "B1", 3, 1.7, 0.0001, 0.25, 0.0025, rng, 10.0);
      EXPECT_TRUE(m.degraded());
      EXPECT_DOUBLE_EQ(m.variance("BARO", "B1", 0.0025), 0.0025);
    }
  }
}

// One noisy check among consistent ones (a filter's first second, ten unlucky samples) names
// the channel but does not degrade the process; the same again at the next check does.
TEST(ConsistencyMonitor, OneNoisyCheckNamesTheChannelTwoInARowDegrade) {
  ConsistencyOptions o;
  o.learn = false;
  ConsistencyMonitor m(o);
  auto add = [&](int n, double r, double t0) {
    for (int i = 0; i < n; ++i) m.add_nis("ANGLE", "B1", t0 + 0.1 * i, r, 1, false);
  };
  add(10, 4.0, 0.0);  // NIS 4: 8.8x the chi-square(1) median
  EXPECT_NE(m.problems().find("ANGLE B1: innovations "), std::string::npos) << m.problems();
  EXPECT_FALSE(m.degraded());
  add(10, 0.3, 1.0);  // consistent: the window's median falls, the run of noisy checks ends
  EXPECT_FALSE(m.degraded());
  EXPECT_EQ(m.problems(), "");
  add(30, 4.0, 2.0);
  EXPECT_TRUE(m.degraded()) << m.problems();
}

// The learned sigma is said in the setting's own units, whatever the innovations' units: a
// heading in radians against mag_heading_sigma_deg 2, the data's noise 20 deg (10x).
TEST(Consistency, LearnedSigmaIsSaidInTheSettingsUnits) {
  for (const bool one_setting : {true, false}) {
    ConsistencyMonitor m;
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 20.0 * std::numbers::pi / 180.0);
    const double cfg = 2.0 * std::numbers::pi / 180.0;
    const std::string setting = one_setting ? setting_text("mag_heading_sigma_deg", 2.0)
                                            : "rx_sigma_ns 1 or sync_sigma_ns 2";
    for (int i = 0; i < 200; ++i)
      m.add_scalar("MAG", "P1", 0.05 * i, noise(rng), 0.0, cfg * cfg, false, setting);
    const std::string p = m.problems();
    const size_t at = p.find("(learned sigma ");
    ASSERT_NE(at, std::string::npos) << p;
    const std::string said = p.substr(at + 15);
    if (one_setting) {
      EXPECT_NEAR(std::stod(said), 20.0, 3.0) << p;  // degrees, not 0.35 (radians)
    } else {
      EXPECT_NEAR(std::stod(said), 10.0, 1.5) << p;
      EXPECT_NE(said.find("x the configured)"), std::string::npos) << p;
    }
  }
}

TEST(ConsistencyMonitor, BeyondTheLearningBoundDegrades) {
  std::mt19937 rng(3);
  ConsistencyMonitor m;
  feed(m, "B1", 60, 10.0, 0.0, 1.0, 0.0001, rng);  // variance 10000x: beyond the 400x bound
  EXPECT_TRUE(m.degraded());
  EXPECT_DOUBLE_EQ(m.variance("BARO", "B1", 0.0001), 0.04);
  EXPECT_NE(m.problems().find("at its bound"), std::string::npos) << m.problems();
}

TEST(ConsistencyMonitor, OutliersDoNotMakeAChannelNoisy) {
  std::mt19937 rng(4);
  ConsistencyMonitor m;
  std::normal_distribution<double> n01(0.0, 1.0);
  for (int i = 0; i < 100; ++i) {
    const double r = i % 5 == 0 ? 50.0 : n01(rng);  // 20 % gross outliers, all gated
    m.add_scalar("RANGE", "A1", i * 0.1, r, 0.0, 1.0, i % 5 == 0, "range_sigma_m 1");
  }
  const auto v = m.verdicts();
  EXPECT_EQ(v[0].state, ConsistencyMonitor::State::kOk) << m.problems();
  EXPECT_NEAR(v[0].gated_share, 0.2, 0.02);
  EXPECT_EQ(m.problems(), "");  // 20 % gated is below the 30 % said
}

// Too quiet is shown in the summary, not said as a problem (it also comes of time-correlated
// noise), and never lowers the variance below the configured one; mostly gated is said.
TEST(ConsistencyMonitor, TooQuietIsShownNotSaidAndMostlyGatedIsSaid) {
  ConsistencyMonitor m;
  for (int i = 0; i < 30; ++i) m.add_nis("ANGLE", "A2", i * 0.1, 0.02, 2, i % 2 == 0);
  for (int i = 0; i < 30; ++i) m.add_scalar("RANGE", "A1", i * 0.1, 0.01, 0.0, 1.0, false);
  EXPECT_EQ(m.verdicts()[0].state, ConsistencyMonitor::State::kQuiet);
  const std::string p = m.problems();
  EXPECT_EQ(p, "ANGLE A2: 50% of its measurements gated");
  EXPECT_NE(m.summary().find("ANGLE A2 0.0x 50% gated"), std::string::npos) << m.summary();
  EXPECT_FALSE(m.degraded());
  EXPECT_DOUBLE_EQ(m.variance("RANGE", "A1", 1.0), 1.0);
}

TEST(ConsistencyMonitor, WindowForgetsAndTimeBackRestarts) {
  std::mt19937 rng(5);
  ConsistencyMonitor m;
  feed(m, "B1", 50, 10.0, 0.0, 100.0, 1.0, rng);  // noisy for 5 s
  EXPECT_EQ(m.verdicts()[0].state, ConsistencyMonitor::State::kNoisy);
  feed(m, "B1", 250, 10.0, 0.0, 1.0, 1.0, rng, 5.0);  // then 25 s of good data: 20 s window
  EXPECT_EQ(m.verdicts()[0].state, ConsistencyMonitor::State::kOk) << m.problems();
  feed(m, "B1", 5, 10.0, 0.0, 1.0, 1.0, rng, -100.0);  // a clock back: a fresh window
  EXPECT_EQ(m.verdicts()[0].n, 5u);
  EXPECT_EQ(m.verdicts()[0].state, ConsistencyMonitor::State::kTooFew);
}

// The window's median, kept in order as samples enter and leave (by count, by age, a sample
// entering as another leaves), is the median of the samples inside it: against a sort of the
// same samples, with ties, a heavy tail and gaps in time that empty most of the window.
TEST(ConsistencyMonitor, WindowMedianIsTheMedianOfTheWindowsSamples) {
  std::mt19937 rng(11);
  ConsistencyOptions o;
  o.max_samples = 37;
  o.window_s = 5.0;
  o.min_samples = 1;
  ConsistencyMonitor m(o);
  std::vector<std::pair<double, double>> kept;  // (t, nis)
  std::uniform_int_distribution<int> small(0, 6);
  std::exponential_distribution<double> tail(0.5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double t = 0.0;
  for (int i = 0; i < 5000; ++i) {
    t += u(rng) < 0.01 ? 3.0 + 3.0 * u(rng) : 0.1 * u(rng);
    const double nis = u(rng) < 0.5 ? static_cast<double>(small(rng)) : tail(rng);
    m.add_nis("ANGLE", "B1", t, nis, 1, false);
    kept.emplace_back(t, nis);
    while (kept.size() > o.max_samples || kept.front().first < t - o.window_s)
      kept.erase(kept.begin());
    std::vector<double> v;
    for (const auto& k : kept) v.push_back(k.second);
    std::sort(v.begin(), v.end());
    const size_t mid = v.size() / 2;
    const double median = v.size() % 2 == 0 ? 0.5 * (v[mid] + v[mid - 1]) : v[mid];
    const ConsistencyMonitor::Verdict verdict = m.verdicts().at(0);
    ASSERT_EQ(verdict.n, v.size()) << "sample " << i;
    ASSERT_EQ(verdict.ratio, median / chi2_median(1)) << "sample " << i;
  }
}

struct FakeNode {
  std::string consistency, lasting;
  int reports = 0, ends = 0;
  void set_consistency(std::string s) { consistency = std::move(s); }
  void report_lasting_error(const std::string&, const std::string& t) {
    lasting = t;
    ++reports;
  }
  void end_lasting_error(const std::string&) { ++ends; }
};

// Learning per link: two tags ranging one anchor, one of them from an NLOS corner (its ranges 5x
// the configured sigma). Each link learns its own variance, so the clean tag's ranges keep the
// configured one; the verdict (HEALTH) stays one per anchor, over both tags. One tag alone
// learns its anchor's variance, as without links.
TEST(ConsistencyMonitor, EachLinkLearnsItsOwnVarianceTheVerdictIsPerAnchor) {
  ConsistencyMonitor m;
  std::mt19937 rng(4);
  const double cfg = 0.01, hph = 0.001;
  std::normal_distribution<double> clean(0.0, std::sqrt(hph + cfg)),
      nlos(0.0, std::sqrt(hph + 25 * cfg));
  const auto t1 = m.link("RANGE", "A1", "T1"), t2 = m.link("RANGE", "A1", "T2");
  EXPECT_NE(t1, t2);
  EXPECT_EQ(m.link("RANGE", "A1", "T1"), t1);  // one handle per link
  const auto t3 = m.link("RANGE", "A1", "T3");
  for (int i = 0; i < 200; ++i) {
    const double t = i * 0.1;
    m.add_scalar("RANGE", "A1", t, nlos(rng), hph, cfg, false, "range_sigma_m 0.1", t1);
    m.add_scalar("RANGE", "A1", t + 0.05, clean(rng), hph, cfg, false, "range_sigma_m 0.1", t2);
  }
  EXPECT_EQ(m.channels(), 1u);
  EXPECT_EQ(m.links(), 3u);
  EXPECT_NEAR(m.variance("RANGE", "A1", cfg, t1) / cfg, 25.0, 7.0);
  EXPECT_EQ(m.variance("RANGE", "A1", cfg, t2), cfg);  // within the deadband: the configured
  EXPECT_EQ(m.variance("RANGE", "A1", cfg, t3), cfg);  // a link not heard yet
  EXPECT_EQ(m.variance("RANGE", "A1", cfg, 99), cfg);  // no such link
  const double pooled = m.variance("RANGE", "A1", cfg) / cfg;  // the anchor's, over both tags
  EXPECT_GT(pooled, 2.0);
  EXPECT_LT(pooled, 20.0);
  ASSERT_EQ(m.verdicts().size(), 1u);
  EXPECT_EQ(m.verdicts()[0].n, 300u);

  // One tag: its link learns what its anchor does (floats against doubles: within 1e-5).
  ConsistencyMonitor one;
  const auto only_link = one.link("RANGE", "A1", "T1");
  std::mt19937 rng1(5);
  for (int i = 0; i < 300; ++i) {
    one.add_scalar("RANGE", "A1", i * 0.1, nlos(rng1), hph, cfg, false, "", only_link);
    EXPECT_NEAR(one.variance("RANGE", "A1", cfg, only_link), one.variance("RANGE", "A1", cfg),
                1e-5 * one.variance("RANGE", "A1", cfg))
        << i;
  }
  // Learning off, or a kind only monitored: no link learns.
  ConsistencyMonitor off;
  off.set_learning(false);
  const auto off_link = off.link("RANGE", "A1", "T1");
  for (int i = 0; i < 50; ++i)
    off.add_scalar("RANGE", "A1", i * 0.1, 1.0, hph, cfg, false, "", off_link);
  EXPECT_EQ(off.variance("RANGE", "A1", cfg, off_link), cfg);
  ConsistencyMonitor only;
  only.monitor_only("ANGLE");
  const auto angle_link = only.link("ANGLE", "B1", "T1");
  for (int i = 0; i < 50; ++i)
    only.add_scalar("ANGLE", "B1", i * 0.1, 1.0, hph, cfg, false, "", angle_link);
  EXPECT_EQ(only.variance("ANGLE", "B1", cfg, angle_link), cfg);
}

TEST(ConsistencyHealth, DegradesWhileUncompensatedAndEnds) {
  ConsistencyOptions o;
  o.learn = false;
  ConsistencyMonitor m(o);
  FakeNode node;
  ConsistencyHealth h;
  std::mt19937 rng(6);
  feed(m, "B1", 30, 10.0, 0.0, 1.0, 1.0, rng);
  h.report(node, m);
  EXPECT_EQ(node.reports, 0);
  EXPECT_NE(node.consistency.find("BARO B1 "), std::string::npos);
  feed(m, "B1", 200, 10.0, 0.0, 100.0, 1.0, rng, 3.0);
  h.report(node, m);
  h.report(node, m);
  EXPECT_EQ(node.reports, 1);
  EXPECT_NE(node.lasting.find("looks too small"), std::string::npos) << node.lasting;
  EXPECT_EQ(node.consistency, node.lasting);
  feed(m, "B1", 300, 10.0, 0.0, 1.0, 1.0, rng, 30.0);
  h.report(node, m);
  EXPECT_EQ(node.ends, 1);
}

}  // namespace
}  // namespace ips
