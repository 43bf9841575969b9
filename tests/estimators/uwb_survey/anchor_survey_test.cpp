// The anchor survey on exact ranges (positions come back exactly), on noisy and NLOS ranges, the
// mirror decided by a known point, and its errors.
#include "estimators/uwb_survey/anchor_survey.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>

namespace ips::uwb_survey {
namespace {

using Layout = std::vector<std::pair<std::string, Eigen::Vector3d>>;

// The survey frame of `truth` for the order given by its first two entries: the first at the
// origin, the second on +x, rotation only (no reflection), heights unchanged.
Layout to_frame(const Layout& truth) {
  const Eigen::Vector2d o = truth[0].second.head<2>();
  const Eigen::Vector2d ex = (truth[1].second.head<2>() - o).normalized();
  const Eigen::Vector2d ey(-ex.y(), ex.x());
  Layout out;
  for (const auto& [id, p] : truth) {
    const Eigen::Vector2d d = p.head<2>() - o;
    out.push_back({id, Eigen::Vector3d(d.dot(ex), d.dot(ey), p.z())});
  }
  return out;
}

Layout reflected(Layout l) {
  for (auto& [id, p] : l) p.y() = -p.y();
  return l;
}

// Every pair ranged `n` times; `error(pair index, sample)` is added to the true 3D distance.
SurveyInput input_for(const Layout& truth, int n = 10,
                      const std::function<double(size_t, int)>& error = nullptr) {
  SurveyInput in;
  for (const auto& [id, p] : truth) in.anchors.push_back({id, p.z()});
  size_t pair = 0;
  for (size_t i = 0; i < truth.size(); ++i)
    for (size_t j = i + 1; j < truth.size(); ++j, ++pair) {
      PairRanges pr{truth[i].first, truth[j].first, {}};
      for (int k = 0; k < n; ++k)
        pr.ranges_m.push_back((truth[i].second - truth[j].second).norm() +
                              (error ? error(pair, k) : 0.0));
      in.pairs.push_back(pr);
    }
  return in;
}

KnownPoint known_point(const Layout& truth, const Eigen::Vector3d& point) {
  KnownPoint kp{"T1", point, {}};
  for (const auto& [id, p] : truth) kp.ranges.push_back({"T1", id, {(point - p).norm()}});
  return kp;
}

void expect_positions(const SurveyResult& r, const Layout& want, double tol) {
  ASSERT_EQ(r.anchors.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(r.anchors[i].id, want[i].first);
    EXPECT_LE((r.anchors[i].position - want[i].second).norm(), tol)
        << want[i].first << ": got " << r.anchors[i].position.transpose() << ", want "
        << want[i].second.transpose();
  }
}

// The lab (config/scenarios/lab.yaml): A1 at the origin, A2 on +x, so its frame is the survey's.
const Layout kLab = {
    {"A1", {0, 0, 2.4}}, {"A2", {10, 0, 2.4}}, {"A3", {10, 8, 2.4}}, {"A4", {0, 8, 2.4}}};

// Six anchors at different heights in a site frame that is not the survey frame, one of them on
// the -y side of the A1-A2 line and one outside the hull of the first three.
const Layout kSix = {{"A1", {2.0, 1.0, 2.4}},  {"A2", {9.0, 3.0, 3.1}},  {"A3", {6.0, 9.0, 2.0}},
                     {"A4", {-1.0, 7.0, 2.8}}, {"A5", {8.0, -2.0, 1.6}}, {"A6", {14.0, 6.0, 2.2}}};

TEST(AnchorSurvey, ExactRangesGiveTheLabExactly) {
  const SurveyResult r = survey_anchors(input_for(kLab));
  expect_positions(r, kLab, 1e-6);
  EXPECT_EQ(r.mirror, MirrorChoice::kConvention);
  EXPECT_EQ(r.redundancy, 1);  // 6 pairs, 5 free coordinates
  EXPECT_LT(r.residual_rms_m, 1e-9);
  ASSERT_EQ(r.pairs.size(), 6u);
  EXPECT_EQ(r.pairs[0].samples, 10u);
  EXPECT_NEAR(r.pairs[1].range_m, std::hypot(10.0, 8.0), 1e-12);  // A1-A3
  for (const auto& a : r.anchors) EXPECT_EQ(a.pairs_used, 3);
}

TEST(AnchorSurvey, ExactRangesGiveSixAnchorsAtDifferentHeightsExactly) {
  const SurveyResult r = survey_anchors(input_for(kSix));
  expect_positions(r, to_frame(kSix), 1e-6);  // A3 is on the +y side of A1->A2 here
  EXPECT_EQ(r.redundancy, 15 - 9);
  EXPECT_LT(r.residual_rms_m, 1e-9);
  // Heights are the given ones, never estimated.
  for (size_t i = 0; i < kSix.size(); ++i) EXPECT_EQ(r.anchors[i].position.z(), kSix[i].second.z());
}

TEST(AnchorSurvey, OrderChoosesTheFrame) {
  // A5 at the origin, A6 on +x, A1 third: A1 is on the +y side of A5->A6.
  const Layout order = {kSix[4], kSix[5], kSix[0], kSix[1], kSix[2], kSix[3]};
  ASSERT_GT(to_frame(order)[2].second.y(), 0);
  expect_positions(survey_anchors(input_for(order)), to_frame(order), 1e-6);
}

TEST(AnchorSurvey, WithoutAKnownPointTheThirdAnchorIsPutAtPlusY) {
  // A2 at the origin, A1 on +x: A3 (and A4) are on the -y side, so the +y convention gives the
  // reflection of the true layout; every distance still fits.
  const Layout order = {kLab[1], kLab[0], kLab[2], kLab[3]};
  ASSERT_LT(to_frame(order)[2].second.y(), 0);
  const SurveyResult r = survey_anchors(input_for(order));
  EXPECT_EQ(r.mirror, MirrorChoice::kConvention);
  expect_positions(r, reflected(to_frame(order)), 1e-6);
  EXPECT_LT(r.residual_rms_m, 1e-9);
}

TEST(AnchorSurvey, KnownPointPicksTheReflection) {
  const Layout order = {kLab[1], kLab[0], kLab[2], kLab[3]};
  const Layout want = to_frame(order);  // A3 at (0, -8)
  SurveyInput in = input_for(order);
  // The tag stands at lab (2, 1.5, 1.2): (8, -1.5, 1.2) in this frame.
  in.known_point = known_point(want, {8, -1.5, 1.2});
  const SurveyResult r = survey_anchors(in);
  EXPECT_EQ(r.mirror, MirrorChoice::kReflected);
  expect_positions(r, want, 1e-6);
  EXPECT_LT(r.known_point_rms_m, 1e-6);
  EXPECT_GT(r.known_point_mirror_rms_m, 0.5);
  EXPECT_EQ(r.known_point_anchors, 4);
}

TEST(AnchorSurvey, KnownPointConfirmsPlusY) {
  SurveyInput in = input_for(kSix);
  const Layout want = to_frame(kSix);
  in.known_point = known_point(want, {4.0, 3.0, 1.0});
  const SurveyResult r = survey_anchors(in);
  EXPECT_EQ(r.mirror, MirrorChoice::kKept);
  expect_positions(r, want, 1e-6);
  EXPECT_LT(r.known_point_rms_m, 1e-6);
  EXPECT_GT(r.known_point_mirror_rms_m, 0.5);
}

TEST(AnchorSurvey, KnownPointOnTheXAxisCannotDecide) {
  SurveyInput in = input_for(kLab);
  in.known_point = known_point(kLab, {5, 0, 1.2});  // on the A1-A2 line: both reflections fit
  try {
    survey_anchors(in);
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "known point (5.000, 0.000, 1.200) does not tell the reflections apart (range "
                 "residual RMS 0.000 m with A3 at +y, 0.000 m at -y); choose a point away from "
                 "the line A1-A2");
  }
  in.known_point->ranges.resize(2);  // ranges to A1 and A2 only
  in.known_point->position = {3, 3, 1.2};
  try {
    survey_anchors(in);
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "known point: tag T1 has ranges to A1, A2 while at the point; 3 anchors "
                 "are needed to tell the reflections apart");
  }
}

TEST(AnchorSurvey, MissingPairOfTheFirstThreeIsNamed) {
  SurveyInput in = input_for(kLab);
  in.pairs.erase(in.pairs.begin() + 3);  // A2-A3
  try {
    survey_anchors(in);
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(), "pair A2-A3: no ranges (needed to place A3)");
  }
  in = input_for(kLab);
  in.pairs[1].ranges_m.resize(4);  // A1-A3: 4 samples
  try {
    survey_anchors(in);
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(), "pair A1-A3: 4 ranges, fewer than the 10 required (needed to place A3)");
  }
  SurveyOptions o;
  o.min_samples_per_pair = 4;
  EXPECT_NO_THROW(survey_anchors(in, o));
}

TEST(AnchorSurvey, AnchorWithoutThreePartnersIsNamedWithItsMissingPairs) {
  SurveyInput in = input_for(kSix);
  // A4 keeps only its ranges to A1 and A2 (pairs A3-A4, A4-A5, A4-A6 go).
  std::erase_if(in.pairs, [](const PairRanges& p) {
    return (p.a == "A4" || p.b == "A4") && p.a != "A1" && p.a != "A2";
  });
  try {
    survey_anchors(in);
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "cannot place anchor A4: it has ranges to A1, A2 of the placed anchors, "
                 "and needs 3 not on one line; missing pairs: A3-A4: no ranges; A4-A5: "
                 "no ranges; A4-A6: no ranges");
  }
}

TEST(AnchorSurvey, LaterAnchorIsPlacedOnceItsPartnersAre) {
  // A4 ranges only to A1, A2 and A6; A6 is placed from A1, A2, A3 first, then A4 from it.
  SurveyInput in = input_for(kSix);
  std::erase_if(in.pairs, [](const PairRanges& p) {
    return (p.a == "A4" || p.b == "A4") && p.a != "A1" && p.a != "A2" && p.b != "A6";
  });
  expect_positions(survey_anchors(in), to_frame(kSix), 1e-6);
}

TEST(AnchorSurvey, CollinearFirstThreeAreRefused) {
  const Layout line = {
      {"A1", {0, 0, 2}}, {"A2", {10, 0, 2}}, {"A3", {20, 0.3, 2}}, {"A4", {0, 8, 2}}};
  try {
    survey_anchors(input_for(line));
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "anchors A1, A2, A3 are (nearly) collinear: A3 is 0.300 m from the line "
                 "A1-A2 (at least 0.500 m needed); choose a third anchor off that line");
  }
  // The same anchors in another order survey fine.
  const Layout ok = {line[0], line[1], line[3], line[2]};
  expect_positions(survey_anchors(input_for(ok)), to_frame(ok), 1e-6);
}

TEST(AnchorSurvey, TooFewAnchorsAndCoincidentFirstTwoAreRefused) {
  EXPECT_THROW(survey_anchors(input_for({kLab[0], kLab[1]})), SurveyError);
  const Layout stacked = {{"A1", {0, 0, 2}}, {"A2", {0.05, 0, 3}}, {"A3", {5, 5, 2}}};
  try {
    survey_anchors(input_for(stacked));
    FAIL();
  } catch (const SurveyError& e) {
    EXPECT_STREQ(e.what(),
                 "anchors A1 and A2 are 0.050 m apart horizontally: too close to define "
                 "the x axis; choose another second anchor");
  }
}

// Gaussian noise 0.10 m on every range and 20 % NLOS ranges (+0.3 to +1.5 m, the lab's model),
// 100 samples per pair as in the source's campaign.
TEST(AnchorSurvey, MedianRangesIgnoreNlos) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> noise(0, 0.10);
  std::uniform_real_distribution<double> u(0, 1);
  double mean_bias = 0;
  int samples = 0;
  SurveyInput in = input_for(kSix, 100, [&](size_t, int) {
    double e = noise(rng);
    if (u(rng) < 0.2) e += 0.3 + 1.2 * u(rng);
    mean_bias += e;
    ++samples;
    return e;
  });
  mean_bias /= samples;
  EXPECT_GT(mean_bias, 0.15);  // a mean per pair would be ~0.18 m long
  const Layout want = to_frame(kSix);
  auto worst_error = [&](const SurveyResult& r) {
    double worst = 0;
    for (size_t i = 0; i < want.size(); ++i)
      worst = std::max(worst, (r.anchors[i].position - want[i].second).norm());
    return worst;
  };
  const SurveyResult r = survey_anchors(in);
  // The same data with each pair reduced to its mean (one sample per pair): what the median saves.
  SurveyInput by_mean = in;
  for (auto& p : by_mean.pairs) {
    double sum = 0;
    for (double x : p.ranges_m) sum += x;
    p.ranges_m = {sum / static_cast<double>(p.ranges_m.size())};
  }
  SurveyOptions one;
  one.min_samples_per_pair = 1;
  const double worst_median = worst_error(r),
               worst_mean = worst_error(survey_anchors(by_mean, one));
  std::printf(
      "20 %% NLOS, 100 samples per pair: worst anchor error %.3f m by the median (residual "
      "RMS %.3f m), %.3f m by the mean\n",
      worst_median, r.residual_rms_m, worst_mean);
  // The median of a 20 %-contaminated pair is its clean 62.5th percentile: +0.32 sigma = +0.03 m
  // on every pair, which moves the anchors by a few centimetres.
  EXPECT_LT(worst_median, 0.10);
  EXPECT_GT(worst_mean, 2 * worst_median);
  EXPECT_LT(r.residual_rms_m, 0.05);
}

TEST(AnchorSurvey, ResidualsPointAtTheBadPair) {
  // Every A2-A4 range 0.5 m long (a reflection seen every time): the two anchors of that pair
  // carry the largest residuals.
  SurveyInput in = input_for(kSix);
  for (auto& p : in.pairs)
    if (p.a == "A2" && p.b == "A4")
      for (double& x : p.ranges_m) x += 0.5;
  const SurveyResult r = survey_anchors(in);
  std::map<std::string, double> rms;
  for (const auto& a : r.anchors) rms[a.id] = a.residual_rms_m;
  for (const char* other : {"A1", "A3", "A5", "A6"}) {
    EXPECT_GT(rms["A2"], rms[other]) << other;
    EXPECT_GT(rms["A4"], rms[other]) << other;
  }
  double worst = 0;
  std::string worst_pair;
  for (const auto& p : r.pairs)
    if (std::abs(p.residual_m) > worst)
      worst = std::abs(p.residual_m), worst_pair = p.a + "-" + p.b;
  EXPECT_EQ(worst_pair, "A2-A4");
}

TEST(AnchorSurvey, QuantileInterpolatesOrderStatistics) {
  EXPECT_DOUBLE_EQ(quantile({4, 1, 3, 2}, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(quantile({4, 1, 3, 2}, 0.25), 1.75);
  EXPECT_DOUBLE_EQ(quantile({5}, 0.9), 5);
  EXPECT_TRUE(std::isnan(quantile({}, 0.5)));
}

TEST(AnchorSurvey, TooShortPairsAreReportedAndSkipped) {
  // Every pair but A2-A4 has 10 samples; A2-A4 has 3: not used, said so, and A4 is placed from
  // its other four pairs.
  SurveyInput in = input_for(kSix);
  for (auto& p : in.pairs)
    if (p.a == "A2" && p.b == "A4") p.ranges_m.resize(3);
  const SurveyResult r = survey_anchors(in);
  expect_positions(r, to_frame(kSix), 1e-6);
  EXPECT_EQ(r.pairs.size(), 14u);
  EXPECT_EQ(r.redundancy, 14 - 9);
  EXPECT_EQ(r.anchors[3].pairs_used, 4);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0], "pair A2-A4: 3 ranges, fewer than the 10 required: not used");
}

}  // namespace
}  // namespace ips::uwb_survey
