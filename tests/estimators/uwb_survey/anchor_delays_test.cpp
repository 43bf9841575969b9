// Antenna delays from anchor-to-anchor ranges between anchors at known positions: exact recovery
// on noiseless ranges, the noise and NLOS of the lab's model (0.10 m Gaussian, 5 % NLOS +0.3 to
// +1.5 m), the seeded tag offsets, and the refusals (no odd cycle, too few samples).
// Delays of 0.04 to 0.16 m per device: real DW1000 pairs read +0.08 to +0.32 m long
// (estimators/uwb_twr/models/range_bias.hpp), the sum of two such delays.
#include "estimators/uwb_survey/anchor_delays.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

namespace ips::uwb_survey {
namespace {

// The lab's four corner anchors (config/scenarios/lab.yaml) and a fifth, lower, mid-wall.
const std::vector<KnownAnchor> kAnchors = {{"A1", {0.0, 0.0, 2.4}},
                                           {"A2", {10.0, 0.0, 2.4}},
                                           {"A3", {10.0, 8.0, 2.4}},
                                           {"A4", {0.0, 8.0, 2.4}},
                                           {"A5", {5.0, 8.0, 1.5}}};
const std::map<std::string, double> kDelays = {
    {"A1", 0.05}, {"A2", 0.12}, {"A3", 0.09}, {"A4", 0.16}, {"A5", 0.04}};

const KnownAnchor& anchor(const std::string& id) {
  for (const auto& a : kAnchors)
    if (a.id == id) return a;
  throw std::logic_error("no anchor " + id);
}

// `n` samples of the pair's range, long by both delays, with the lab's noise and NLOS when rng.
PairRanges pair(const std::string& a, const std::string& b, int n, std::mt19937_64* rng = nullptr,
                double nlos_probability = 0.05) {
  const double r = (anchor(a).position - anchor(b).position).norm() + kDelays.at(a) + kDelays.at(b);
  PairRanges p{a, b, {}};
  std::normal_distribution<double> noise(0.0, 0.10);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int k = 0; k < n; ++k) {
    double v = r;
    if (rng) {
      v += noise(*rng);
      if (uni(*rng) < nlos_probability) v += 0.3 + 1.2 * uni(*rng);
    }
    p.ranges_m.push_back(v);
  }
  return p;
}

std::vector<KnownAnchor> first(size_t n) { return {kAnchors.begin(), kAnchors.begin() + n}; }

std::vector<PairRanges> all_pairs(size_t n, int samples, std::mt19937_64* rng = nullptr) {
  std::vector<PairRanges> out;
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      out.push_back(pair(kAnchors[i].id, kAnchors[j].id, samples, rng));
  return out;
}

TEST(AnchorDelays, NoiselessRangesGiveTheDelaysExactly) {
  const DelayResult r = solve_anchor_delays(kAnchors, all_pairs(5, 10));
  ASSERT_EQ(r.anchors.size(), 5u);
  EXPECT_EQ(r.pairs.size(), 10u);
  EXPECT_EQ(r.redundancy, 5);
  EXPECT_NEAR(r.residual_rms_m, 0.0, 1e-12);
  double mean = 0;
  for (const auto& [id, d] : kDelays) mean += d / 5;
  EXPECT_NEAR(r.tag_delay_m, mean, 1e-12);
  for (const auto& a : r.anchors) {
    EXPECT_NEAR(a.delay_m, kDelays.at(a.id), 1e-12) << a.id;
    EXPECT_NEAR(a.sigma_m, 0.0, 1e-9) << a.id;
    EXPECT_EQ(a.pairs_used, 4) << a.id;
    EXPECT_NEAR(a.seed_m, kDelays.at(a.id) + mean, 1e-12) << a.id;
  }
  for (const auto& p : r.pairs) {
    EXPECT_TRUE(p.refused.empty());
    EXPECT_NEAR(p.offset_m, kDelays.at(p.a) + kDelays.at(p.b), 1e-12) << p.a << "-" << p.b;
    EXPECT_NEAR(p.residual_m, 0.0, 1e-12);
  }
  const auto seeded = seeded_range_offsets(r);
  ASSERT_EQ(seeded.size(), 5u);
  EXPECT_NEAR(seeded.at("A4"), 0.16 + mean, 1e-12);
}

TEST(AnchorDelays, ATriangleAloneIsExactButHasNoSigma) {
  const DelayResult r = solve_anchor_delays(first(3), all_pairs(3, 10));
  EXPECT_EQ(r.redundancy, 0);
  for (const auto& a : r.anchors) {
    EXPECT_NEAR(a.delay_m, kDelays.at(a.id), 1e-12) << a.id;
    EXPECT_TRUE(std::isnan(a.sigma_m)) << a.id;
    EXPECT_TRUE(std::isnan(a.seed_sigma_m)) << a.id;
  }
}

TEST(AnchorDelays, BothDirectionsAreMergedAndOtherIdsSkipped) {
  std::vector<PairRanges> pairs = all_pairs(3, 6);
  pairs.push_back(pair("A2", "A1", 6));                 // the other direction: 12 samples
  pairs.push_back({"T1", "A1", {3.0, 3.0, 3.0}});       // a tag: not ours
  pairs.push_back({"A1", "A1", {0.1, 0.1, 0.1, 0.1}});  // an anchor with itself
  const DelayResult r = solve_anchor_delays(first(3), pairs, {.min_samples_per_pair = 6});
  ASSERT_EQ(r.pairs.size(), 3u);
  EXPECT_EQ(r.pairs[0].a + "-" + r.pairs[0].b, "A1-A2");
  EXPECT_EQ(r.pairs[0].samples, 12u);
  for (const auto& a : r.anchors) EXPECT_NEAR(a.delay_m, kDelays.at(a.id), 1e-12);
}

// The lab's error model, 100 samples per pair (100 s at 1 Hz): every delay within 0.03 m, and
// the reported sigma of the right size (the errors within 4 sigma, sigma under 0.03 m).
TEST(AnchorDelays, NoisyNlosRangesGiveTheDelaysWithinThreeCentimetres) {
  for (uint64_t seed : {1, 2, 3, 4, 5}) {
    std::mt19937_64 rng(seed);
    const DelayResult r = solve_anchor_delays(kAnchors, all_pairs(5, 100, &rng));
    for (const auto& a : r.anchors) {
      const double err = a.delay_m - kDelays.at(a.id);
      std::printf("seed %d %s: delay %.3f m, error %+.4f m, sigma %.4f m\n", static_cast<int>(seed),
                  a.id.c_str(), a.delay_m, err, a.sigma_m);
      EXPECT_LT(std::abs(err), 0.03) << "seed " << seed << " " << a.id;
      EXPECT_GT(a.sigma_m, 0.001);
      EXPECT_LT(a.sigma_m, 0.03);
      EXPECT_LT(std::abs(err), 4 * a.sigma_m + 0.005) << "seed " << seed << " " << a.id;
    }
  }
}

TEST(AnchorDelays, ASquaresFourSidesDoNotDetermineTheDelays) {
  // Even cycle: A1 + c, A2 − c, A3 + c, A4 − c fits every side alike.
  const std::vector<PairRanges> sides = {pair("A1", "A2", 10), pair("A2", "A3", 10),
                                         pair("A3", "A4", 10), pair("A4", "A1", 10)};
  try {
    solve_anchor_delays(first(4), sides);
    FAIL() << "no error";
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "delays not determined: A1, A2, A3, A4 (their pairs A1-A2, A1-A4, A2-A3, A3-A4 "
                 "close no odd cycle such as a triangle, so +c and -c alternately fit alike)");
  }
  // One diagonal closes two triangles: determined.
  std::vector<PairRanges> closed = sides;
  closed.push_back(pair("A1", "A3", 10));
  const DelayResult r = solve_anchor_delays(first(4), closed);
  for (const auto& a : r.anchors) EXPECT_NEAR(a.delay_m, kDelays.at(a.id), 1e-12) << a.id;
}

TEST(AnchorDelays, PairsWithTooFewSamplesAreRefusedAndNamed) {
  std::vector<PairRanges> pairs = all_pairs(4, 10);
  pairs.push_back(pair("A5", "A1", 4));  // A5's only pair: too few
  try {
    solve_anchor_delays(kAnchors, pairs);
    FAIL() << "no error";
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "delays not determined: A5 (no pair used); refused pairs: A1-A5 (4 ranges, "
                 "fewer than the 10 required)");
  }
  // Enough with --min-samples 4: A5 hangs on one pair of a determined anchor, so it is determined.
  const DelayResult r = solve_anchor_delays(kAnchors, pairs, {.min_samples_per_pair = 4});
  EXPECT_NEAR(r.anchors[4].delay_m, 0.04, 1e-12);
  EXPECT_EQ(r.anchors[4].pairs_used, 1);
  // A refused pair is reported, not used.
  pairs.push_back(pair("A5", "A2", 12));
  pairs.push_back(pair("A5", "A3", 12));
  const DelayResult s = solve_anchor_delays(kAnchors, pairs);
  int refused = 0;
  for (const auto& p : s.pairs)
    if (!p.refused.empty()) {
      ++refused;
      EXPECT_EQ(p.a + "-" + p.b, "A1-A5");
      EXPECT_TRUE(std::isnan(p.residual_m));
    }
  EXPECT_EQ(refused, 1);
  EXPECT_EQ(s.anchors[4].pairs_used, 2);
  EXPECT_NEAR(s.anchors[4].delay_m, 0.04, 1e-12);
}

TEST(AnchorDelays, FewerThanThreeAnchorsOrBadInputIsAnError) {
  EXPECT_THROW(solve_anchor_delays(first(2), all_pairs(2, 10)), SurveyError);
  std::vector<KnownAnchor> twice = first(3);
  twice.push_back(kAnchors[0]);
  EXPECT_THROW(solve_anchor_delays(twice, all_pairs(3, 10)), SurveyError);
  std::vector<KnownAnchor> nan = first(3);
  nan[1].position.x() = std::nan("");
  EXPECT_THROW(solve_anchor_delays(nan, all_pairs(3, 10)), SurveyError);
  EXPECT_THROW(solve_anchor_delays(first(3), all_pairs(3, 10), {.range_quantile = 0}), SurveyError);
  EXPECT_THROW(solve_anchor_delays(first(3), {}), SurveyError);
}

}  // namespace
}  // namespace ips::uwb_survey
