// ips-uwb-calibrate's core (estimators/uwb_twr/range_calibration.hpp): per-pair median offsets
// on exact synthetic ranges (outliers, truth gaps, refusals, keys, the site it writes), and on
// the simulated lab with biased radios (sensors.uwb_twr.pair_offset_min_m / max_m): the offsets
// recovered, and, written to the site and read back by the trackers' own parser, the capture's
// residual medians brought to zero.
#include "estimators/uwb_twr/range_calibration.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "drivers/sim/scenario.hpp"
#include "drivers/sim/sensor_model.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "tests/estimators/simulated_inputs.hpp"

namespace ips::uwb_twr {
namespace {

const char* kSiteText = R"(
name: calib
anchors:
  - {id: A1, kind: uwb, position: [0, 0, 2]}
  - {id: A2, kind: uwb, position: [6, 0, 2]}
  - {id: A3, kind: uwb, position: [6, 5, 2]}
  - {id: B1, kind: ble_aoa, position: [3, 0, 2]}
estimators:
  uwb_twr:
    range_sigma_m: 0.12
    range_offsets_m: {A3: 0.5, T1/A2: 0.4, T2/A1: 0.3}
)";

// A tag walking along x at 1 m/s, truth at 10 Hz from 0 to 20 s; ranges at 5 Hz (off the truth
// times) from each anchor with the offset + a +1 m outlier every 7th range.
struct Capture {
  std::vector<RangeSample> ranges;
  TruthTracks truth;
};
Eigen::Vector3d walk(double t) { return {0.5 + 0.25 * t, 1.0 + 0.1 * t, 1.0}; }
void add_tag(Capture& c, const Site& site, const std::string& tag,
             const std::map<std::string, double>& offsets, int n_ranges = 100) {
  for (int i = 0; i <= 200; ++i)
    c.truth[tag].push_back({static_cast<int64_t>(i) * 100000, walk(i * 0.1)});
  for (const auto& [anchor, off] : offsets)
    for (int k = 0; k < n_ranges; ++k) {
      const double t = 0.13 + k * 0.2;
      const double d = (walk(t) - site.find_anchor(anchor)->position).norm();
      c.ranges.push_back({tag, anchor, static_cast<int64_t>(std::llround(t * 1e6)),
                          d + off + (k % 7 == 3 ? 1.0 : 0.0)});
    }
}

TEST(RangeCalibration, MedianOffsetPerPairRobustToOutliers) {
  const Site site = parse_site_text(kSiteText, "test");
  Capture c;
  add_tag(c, site, "T1", {{"A1", 0.12}, {"A2", -0.05}, {"A3", 0.31}});
  c.ranges.push_back({"T1", "B1", 1000000, 3.0});   // not a uwb anchor
  c.ranges.push_back({"A1", "A2", 1000000, 6.0});   // between anchors
  c.ranges.push_back({"T1", "A1", 30000000, 3.0});  // after the truth ends
  c.ranges.push_back({"T1", "A1", 1000000, std::nan("")});
  const auto r = fit_range_offsets(site, c.ranges, c.truth, {});
  ASSERT_EQ(r.pairs.size(), 3u);
  EXPECT_EQ(r.stats.unknown_anchor, 1);
  EXPECT_EQ(r.stats.between_anchors, 1);
  EXPECT_EQ(r.stats.no_truth, 1);
  EXPECT_EQ(r.stats.invalid_range, 1);
  const double want[] = {0.12, -0.05, 0.31};
  for (size_t i = 0; i < 3; ++i) {
    const auto& p = r.pairs[i];
    EXPECT_EQ(p.n, 100);
    EXPECT_TRUE(p.refused.empty()) << p.refused;
    // Linear truth interpolation on a straight walk: exact but for rounding.
    EXPECT_NEAR(p.offset_m, want[i], 1e-6) << p.anchor_id;
    EXPECT_GT(p.mean_before_m, want[i] + 0.1);  // the outliers pull the mean, not the median
    EXPECT_NEAR(p.median_after_m, 0.0, 1e-9);
    EXPECT_NEAR(p.rms_after_m, std::sqrt(14 / 100.0), 1e-6);  // 14 outliers of 1 m left
    EXPECT_TRUE(std::isnan(p.site_offset_m));
  }
  // One tag: anchor keys.
  const auto w = offsets_to_write(r.pairs);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_NEAR(w.at("A2"), -0.05, 1e-6);
}

TEST(RangeCalibration, ScaleIsTheLeastSquaresSlope) {
  const Site site = parse_site_text(kSiteText, "test");
  Capture c;
  for (int i = 0; i <= 200; ++i) c.truth["T1"].push_back({i * 100000, walk(i * 0.1)});
  for (int k = 0; k < 100; ++k) {
    const double t = 0.13 + k * 0.2;
    const double d = (walk(t) - site.find_anchor("A1")->position).norm();
    c.ranges.push_back({"T1", "A1", static_cast<int64_t>(std::llround(t * 1e6)), 1.01 * d + 0.2});
  }
  const auto r = fit_range_offsets(site, c.ranges, c.truth, {});
  ASSERT_EQ(r.pairs.size(), 1u);
  EXPECT_NEAR(r.pairs[0].scale, 0.01, 1e-6);
  EXPECT_NEAR(r.pairs[0].scale_bias_m, 0.2, 1e-5);
}

// With fit_scale (ips-uwb-calibrate --scale) the scale is used and the offset is that of
// range / (1 + scale) - d, which the trackers take off after dividing by 1 + scale: both ranges
// exact then. Written as range_scales beside the offsets; a pair whose distances hardly vary
// keeps scale 0; a scale beyond the site's bound is refused; offsets written without scales
// drop the stale scales of their keys.
TEST(RangeCalibration, FittedScaleIsWrittenAndTheOffsetIsInItsTerms) {
  const Site site = parse_site_text(kSiteText, "test");
  Capture c;
  for (int i = 0; i <= 200; ++i) c.truth["T1"].push_back({i * 100000, walk(i * 0.1)});
  const std::map<std::string, std::pair<double, double>> truth_fit = {  // scale, offset
      {"A1", {0.01, 0.2}}, {"A2", {-0.004, 0.1}}, {"A3", {0.0, 0.05}}};
  for (const auto& [anchor, sb] : truth_fit)
    for (int k = 0; k < 100; ++k) {
      const double t = 0.13 + k * 0.2;
      const double d = (walk(t) - site.find_anchor(anchor)->position).norm();
      c.ranges.push_back({"T1", anchor, static_cast<int64_t>(std::llround(t * 1e6)),
                          (1 + sb.first) * d + sb.second});
    }
  RangeCalibrationOptions opts;
  opts.fit_scale = true;
  const auto r = fit_range_offsets(site, c.ranges, c.truth, opts);
  ASSERT_EQ(r.pairs.size(), 3u);
  for (const auto& p : r.pairs) {
    const auto [scale, offset] = truth_fit.at(p.anchor_id);
    EXPECT_EQ(p.scale_used, scale != 0.0) << p.anchor_id;  // exact 0: not off 1 by 3 se
    EXPECT_NEAR(p.scale, scale, 1e-6) << p.anchor_id;
    EXPECT_NEAR(p.offset_m, offset / (1 + scale), 1e-5) << p.anchor_id;
    EXPECT_NEAR(p.rms_after_m, 0.0, 1e-5) << p.anchor_id;
  }
  const std::string text =
      site_with_offsets_yaml(site, offsets_to_write(r.pairs), {}, scales_to_write(r.pairs));
  const TwrParams back = parse_twr_params(parse_site_text(text, "back").estimator_params("uwb_twr"));
  EXPECT_NEAR(pair_setting(back.range_scales, "T1", "A1"), 0.01, 1e-6);
  EXPECT_NEAR(pair_setting(back.range_scales, "T1", "A2"), -0.004, 1e-6);
  EXPECT_EQ(back.range_scales.count("A3"), 0u);  // exactly 0: not used, not written
  // What the trackers do with a range: divide, then take the offset off.
  for (const auto& [anchor, sb] : truth_fit) {
    const double d = 4.0, range = (1 + sb.first) * d + sb.second;
    const double written = pair_setting(back.range_scales, "T1", anchor);
    EXPECT_NEAR(range / (1 + (std::isnan(written) ? 0.0 : written)) -
                    pair_setting(back.range_offsets_m, "T1", anchor),
                d, 1e-4)
        << anchor;
  }
  // Without --scale the offsets are for unscaled ranges: the written keys' scales go.
  const std::string plain = site_with_offsets_yaml(parse_site_text(text, "scaled"),
                                                   {{"A1", 0.2}, {"A2", 0.1}}, {});
  const TwrParams p2 = parse_twr_params(parse_site_text(plain, "p").estimator_params("uwb_twr"));
  EXPECT_EQ(p2.range_scales.count("A1"), 0u);
  EXPECT_EQ(p2.range_scales.count("A2"), 0u);
  EXPECT_TRUE(p2.range_scales.empty());
  // A standing tag: no spread of distances, no scale (0), the plain median offset.
  Capture still;
  for (int i = 0; i <= 200; ++i) still.truth["T1"].push_back({i * 100000, walk(0.0)});
  for (int k = 0; k < 100; ++k)
    still.ranges.push_back({"T1", "A1", static_cast<int64_t>(std::llround((0.13 + k * 0.2) * 1e6)),
                            (walk(0.0) - site.find_anchor("A1")->position).norm() + 0.2 +
                                0.01 * ((k % 5) - 2)});
  const auto rs = fit_range_offsets(site, still.ranges, still.truth, opts);
  ASSERT_EQ(rs.pairs.size(), 1u);
  EXPECT_FALSE(rs.pairs[0].scale_used);
  EXPECT_NEAR(rs.pairs[0].offset_m, 0.2, 1e-9);
  EXPECT_TRUE(scales_to_write(rs.pairs).empty());
  // A scale of 20 % is beyond the site's bound: refused even with force.
  Capture wild;
  wild.truth = c.truth;
  for (const auto& rg : c.ranges)
    if (rg.anchor_id == "A1") {
      const double t = static_cast<double>(rg.utime) * 1e-6;
      wild.ranges.push_back({"T1", "A1", rg.utime,
                             1.2 * (walk(t) - site.find_anchor("A1")->position).norm()});
    }
  opts.force = true;
  const auto rw = fit_range_offsets(site, wild.ranges, wild.truth, opts);
  ASSERT_EQ(rw.pairs.size(), 1u);
  EXPECT_NE(rw.pairs[0].refused.find("scale +0.2000 outside"), std::string::npos)
      << rw.pairs[0].refused;
}

TEST(RangeCalibration, TruthMustBeWithinTheWindowOnBothSides) {
  const Site site = parse_site_text(kSiteText, "test");
  TruthTracks truth;
  truth["T1"] = {{0, walk(0)}, {500000, walk(0.5)}, {600000, walk(0.6)}};
  std::vector<RangeSample> ranges = {{"T1", "A1", 250000, 2.0},   // 0.25 s from both
                                     {"T1", "A1", 550000, 2.0},   // 0.05 s
                                     {"T1", "A1", 700000, 2.0},   // after the last
                                     {"T2", "A1", 550000, 2.0}};  // no truth of T2
  const auto r = fit_range_offsets(site, ranges, truth, {});
  EXPECT_EQ(r.stats.no_truth, 3);
  ASSERT_EQ(r.pairs.size(), 2u);
  EXPECT_EQ(r.pairs[0].n, 1);
  EXPECT_EQ(r.pairs[0].ranges, 3);
  EXPECT_EQ(r.pairs[1].n, 0);
  EXPECT_EQ(r.pairs[1].refused, "no range with truth (1 ranges)");
}

TEST(RangeCalibration, RefusesFewRangesAndLargeOffsetsUnlessForced) {
  const Site site = parse_site_text(kSiteText, "test");
  Capture c;
  add_tag(c, site, "T1", {{"A1", 1.2}});
  add_tag(c, site, "T2", {{"A1", 0.1}}, 19);
  add_tag(c, site, "T2", {{"A2", -0.1}}, 20);
  auto r = fit_range_offsets(site, c.ranges, c.truth, {});
  ASSERT_EQ(r.pairs.size(), 3u);
  EXPECT_EQ(r.pairs[0].refused, "offset +1.200 m outside [-1, 1] m");
  EXPECT_EQ(r.pairs[1].refused, "19 ranges with truth, fewer than the 20 required");
  EXPECT_EQ(r.pairs[2].refused, "");
  RangeCalibrationOptions force;
  force.force = true;
  r = fit_range_offsets(site, c.ranges, c.truth, force);
  for (const auto& p : r.pairs) EXPECT_EQ(p.refused, "");
  // Two tags: pair keys.
  const auto w = offsets_to_write(r.pairs);
  ASSERT_EQ(w.size(), 3u);
  EXPECT_NEAR(w.at("T1/A1"), 1.2, 1e-6);
  EXPECT_NEAR(w.at("T2/A2"), -0.1, 1e-6);
}

TEST(RangeCalibration, SiteKeepsOtherKeysAndTheTrackersReadTheOffsets) {
  const Site site = parse_site_text(kSiteText, "test");
  const std::string text =
      site_with_offsets_yaml(site, {{"A2", 0.2}, {"T2/A3", -0.15}}, {"first line", "second"});
  EXPECT_EQ(text.rfind("# first line\n# second\n", 0), 0u) << text;
  const Site back = parse_site_text(text, "back");
  EXPECT_EQ(back.anchors.size(), 4u);
  const TwrParams p = parse_twr_params(back.estimator_params("uwb_twr"));
  EXPECT_DOUBLE_EQ(p.range_sigma_m, 0.12);
  // A2 written for every tag; T1/A2 (which would override it) dropped; A3 and T2/A1 kept.
  const std::map<std::string, double> want = {
      {"A2", 0.2}, {"A3", 0.5}, {"T2/A1", 0.3}, {"T2/A3", -0.15}};
  EXPECT_EQ(p.range_offsets_m, want);
  EXPECT_NEAR(pair_setting(p.range_offsets_m, "T1", "A2"), 0.2, 1e-12);
  EXPECT_NEAR(pair_setting(p.range_offsets_m, "T2", "A3"), -0.15, 1e-12);
  EXPECT_NEAR(pair_setting(p.range_offsets_m, "T1", "A3"), 0.5, 1e-12);
  EXPECT_TRUE(std::isnan(pair_setting(p.range_offsets_m, "T1", "A1")));
}

// The simulated lab, 30 s, every tag-anchor pair offset by 0.1 to 0.3 m (plus the scenario's
// 0.10 m noise and 5 % NLOS of +0.3 to +1.5 m).
TEST(RangeCalibrationSim, BiasedLabOffsetsRecoveredAndResidualMediansZeroed) {
  std::string text = sim::builtin_scenario_text("lab");
  const std::string key = "    anchor_pairs_rate_hz: 1";
  const auto at = text.find(key);
  ASSERT_NE(at, std::string::npos);
  text.insert(text.find('\n', at) + 1, "    pair_offset_min_m: 0.1\n    pair_offset_max_m: 0.3\n");
  sim::Scenario sc = sim::parse_scenario_text(text, "lab-biased.yaml");
  sc.duration_s = 30;
  constexpr uint64_t kSeed = 3;
  std::vector<RangeSample> ranges;
  TruthTracks truth;
  test::SimHandlers h;
  h.uwb_range = [&](const uwb_range_t& m) {
    ranges.push_back({m.tag_id, m.anchor_id, m.utime, m.range_m});
  };
  h.truth = [&](const pose_t& m) {
    truth[m.tag_id].push_back({m.utime, {m.position[0], m.position[1], m.position[2]}});
  };
  test::run_simulated(sc, kSeed, h);
  const auto r = fit_range_offsets(sc.site, ranges, truth, {});
  ASSERT_EQ(r.pairs.size(), 4u);
  EXPECT_EQ(r.stats.between_anchors, 180);  // 6 anchor pairs at 1 Hz
  double worst = 0;
  for (const auto& p : r.pairs) {
    EXPECT_TRUE(p.refused.empty()) << p.refused;
    EXPECT_GE(p.n, 290);
    const double sim_offset = sim::uwb_pair_offset_m(kSeed, p.tag_id, p.anchor_id, 0.1, 0.3);
    EXPECT_NEAR(p.offset_m, sim_offset, 0.02) << p.anchor_id;
    worst = std::max(worst, std::abs(p.offset_m - sim_offset));
  }
  std::printf("worst offset error %.4f m\n", worst);

  // Written into the site, read back by the trackers' parser, applied to the capture's ranges.
  const Site back =
      parse_site_text(site_with_offsets_yaml(sc.site, offsets_to_write(r.pairs), {}), "calibrated");
  const auto offsets = parse_twr_params(back.estimator_params("uwb_twr")).range_offsets_m;
  ASSERT_EQ(offsets.size(), 4u);  // one tag: "A1".."A4"
  const auto before = fit_range_offsets(sc.site, ranges, truth, {}, {});
  const auto after = fit_range_offsets(back, ranges, truth, {}, offsets);
  for (size_t i = 0; i < after.pairs.size(); ++i) {
    EXPECT_GT(before.pairs[i].offset_m, 0.09);  // raw residual median: the bias
    EXPECT_NEAR(after.pairs[i].median_site_m, 0.0, 0.02) << after.pairs[i].anchor_id;
    std::printf("%s/%s median before %+.4f m, after the written offsets %+.4f m\n",
                after.pairs[i].tag_id.c_str(), after.pairs[i].anchor_id.c_str(),
                before.pairs[i].offset_m, after.pairs[i].median_site_m);
  }
  // The residuals themselves, offsets applied: median within 0.02 m of zero per pair.
  std::map<std::string, std::vector<double>> res;
  for (const auto& s : ranges) {
    const Anchor* a = sc.site.find_anchor(s.anchor_id);
    if (sc.site.find_anchor(s.tag_id) || !a) continue;
    const auto& tr = truth.at(s.tag_id);
    auto hi = std::lower_bound(tr.begin(), tr.end(), s.utime,
                               [](const TruthSample& x, int64_t v) { return x.utime < v; });
    if (hi == tr.begin() || hi == tr.end()) continue;
    const auto lo = std::prev(hi);
    const double f = double(s.utime - lo->utime) / double(hi->utime - lo->utime);
    const Eigen::Vector3d p = lo->position + f * (hi->position - lo->position);
    res[s.anchor_id].push_back(s.range_m - pair_setting(offsets, s.tag_id, s.anchor_id) -
                               (p - a->position).norm());
  }
  ASSERT_EQ(res.size(), 4u);
  for (auto& [anchor, v] : res) {
    std::sort(v.begin(), v.end());
    const double med =
        v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
    EXPECT_NEAR(med, 0.0, 0.02) << anchor;
  }
}

}  // namespace
}  // namespace ips::uwb_twr
