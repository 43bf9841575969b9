// Sorting UWB_RANGE messages into survey input, the survey order, and the site file written.
#include "estimators/uwb_survey/range_collector.hpp"

#include <gtest/gtest.h>

#include "estimators/uwb_survey/surveyed_site.hpp"

namespace ips::uwb_survey {
namespace {

const char* kSite =
    "name: room\n"
    "anchors:\n"
    "  - {id: A1, position: [0, 0, 2.4]}\n"
    "  - {id: A2, kind: uwb, position: [10, 0, 2.5]}\n"
    "  - {id: D1, kind: uwb_tdoa, position: [1, 1, 2.6]}\n"
    "  - {id: A3, position: [10, 8, 2.6]}\n"
    "  - {id: A9, position: [5, 5, 2.0], enabled: false}\n"
    "  - id: A4\n"
    "    position: [0, 8, 2.7]\n"
    "tags:\n"
    "  - {id: T1, height_m: 1.2}\n"
    "estimators:\n"
    "  uwb_twr:\n"
    "    range_sigma_m: 0.12\n";

uwb_range_t range(const std::string& tag, const std::string& anchor, double r) {
  uwb_range_t m;
  m.utime = 1767225600000000;
  m.tag_id = tag;
  m.anchor_id = anchor;
  m.range_m = r;
  return m;
}

TEST(RangeCollector, SortsAnchorPairsKnownTagAndOthers) {
  CollectorOptions o;
  o.known_tag = "T1";
  o.window_start_s = 5;
  o.window_end_s = 10;
  RangeCollector c(o);
  c.add(range("A1", "A2", 10.0), 0.5);  // before the site: held, then sorted
  c.set_site(parse_site_text(kSite, "room.yaml"));
  c.add(range("A2", "A1", 10.2), 1);  // the other direction: the same pair
  c.add(range("A3", "A4", 10.0), 1);
  c.add(range("T1", "A1", 3.0), 4.9);  // before the window
  c.add(range("T1", "A1", 3.1), 5.0);
  c.add(range("T1", "A2", 8.1), 10.0);
  c.add(range("T1", "A3", 9.0), 10.1);  // after it
  c.add(range("T2", "A1", 3.0), 6);     // another tag
  c.add(range("A1", "A2", std::nan("")), 6);
  c.add(range("A1", "A2", -1), 6);
  EXPECT_EQ(c.stats().ranges_in, 10);
  EXPECT_EQ(c.stats().anchor_pair, 3);
  EXPECT_EQ(c.stats().known_point, 2);
  EXPECT_EQ(c.stats().other, 3);
  EXPECT_EQ(c.stats().invalid, 2);
  const auto counts = c.pair_counts();
  ASSERT_EQ(counts.size(), 2u);
  EXPECT_EQ(counts.at({"A1", "A2"}), 2u);
  EXPECT_EQ(counts.at({"A3", "A4"}), 1u);

  const SurveyInput in = c.input(survey_order(c.site(), {}), Eigen::Vector3d(1, 2, 1.2));
  ASSERT_EQ(in.anchors.size(), 4u);
  size_t pair_samples = 0;
  for (const auto& p : in.pairs) pair_samples += p.ranges_m.size();
  EXPECT_EQ(pair_samples, 3u);
  ASSERT_TRUE(in.known_point);
  EXPECT_EQ(in.known_point->position, Eigen::Vector3d(1, 2, 1.2));
  ASSERT_EQ(in.known_point->ranges.size(), 2u);
  EXPECT_EQ(in.known_point->ranges[0].b, "A1");
  EXPECT_EQ(in.known_point->ranges[0].ranges_m, std::vector<double>{3.1});
  EXPECT_FALSE(c.input(in.anchors, std::nullopt).known_point);
}

TEST(RangeCollector, FirstSiteWinsAndPendingRangesAreBounded) {
  CollectorOptions o;
  o.max_pending = 2;
  RangeCollector c(o);
  for (int i = 0; i < 3; ++i) c.add(range("A1", "A2", 10), i);
  EXPECT_EQ(c.stats().pending_dropped, 1);
  const Site site = parse_site_text(kSite, "room.yaml");
  c.set_site(site);
  c.set_site(site);  // the same text: not counted
  c.set_site(parse_site_text("anchors: []\n", "other.yaml"));
  EXPECT_EQ(c.stats().sites_ignored, 1);
  EXPECT_EQ(c.site().name, "room");
  EXPECT_EQ(c.stats().anchor_pair, 2);
}

TEST(SurveyOrder, EnabledUwbAnchorsOrderFirstThenSiteOrder) {
  const Site site = parse_site_text(kSite, "room.yaml");
  auto ids = [](const std::vector<SurveyAnchor>& v) {
    std::vector<std::string> out;
    for (const auto& a : v) out.push_back(a.id);
    return out;
  };
  const auto def = survey_order(site, {});
  EXPECT_EQ(ids(def), (std::vector<std::string>{"A1", "A2", "A3", "A4"}));
  EXPECT_DOUBLE_EQ(def[3].height_m, 2.7);
  EXPECT_EQ(ids(survey_order(site, {"A3", "A1", "A4"})),
            (std::vector<std::string>{"A3", "A1", "A4", "A2"}));
  auto error = [&](const std::vector<std::string>& order) {
    try {
      survey_order(site, order);
    } catch (const SurveyError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error({"A1", "A2"}),
            "anchor order: give at least 3 anchors (first, second, third), got 2");
  EXPECT_EQ(error({"A1", "A2", "A7"}), "anchor order: no anchor 'A7' in the site");
  EXPECT_EQ(error({"A1", "A2", "D1"}), "anchor order: anchor 'D1' is of kind uwb_tdoa, not uwb");
  EXPECT_EQ(error({"A1", "A2", "A9"}), "anchor order: anchor 'A9' is disabled");
  EXPECT_EQ(error({"A1", "A2", "A1"}), "anchor order: 'A1' is listed twice");
  const Site two = parse_site_text(
      "anchors:\n  - {id: A1, position: [0, 0, 2]}\n"
      "  - {id: A2, position: [5, 0, 2]}\n",
      "two.yaml");
  EXPECT_THROW(survey_order(two, {}), SurveyError);
}

TEST(SurveyedSite, ReplacesXAndYKeepsEverythingElse) {
  const Site site = parse_site_text(kSite, "room.yaml");
  std::vector<SurveyedAnchor> s(2);
  s[0].id = "A2";
  s[0].position = {9.98765, -0.0001, 99};  // z is never written: the site's height stays
  s[1].id = "A4";
  s[1].position = {0.0123, 8.0456, 2.7};
  const std::string text = surveyed_site_yaml(site, s, {"Surveyed by a test.", "Second line."});
  EXPECT_EQ(text.rfind("# Surveyed by a test.\n# Second line.\n", 0), 0u) << text;
  const Site out = parse_site_text(text, "out.yaml");
  EXPECT_EQ(out.name, "room");
  ASSERT_EQ(out.anchors.size(), site.anchors.size());
  EXPECT_EQ(out.find_anchor("A2")->position, Eigen::Vector3d(9.988, 0, 2.5));
  EXPECT_EQ(out.find_anchor("A4")->position, Eigen::Vector3d(0.012, 8.046, 2.7));
  EXPECT_EQ(out.find_anchor("A1")->position, site.find_anchor("A1")->position);
  EXPECT_EQ(out.find_anchor("D1")->kind, "uwb_tdoa");
  EXPECT_FALSE(out.find_anchor("A9")->enabled);
  EXPECT_DOUBLE_EQ(out.find_tag("T1")->height_m, 1.2);
  EXPECT_DOUBLE_EQ(out.estimator_params("uwb_twr")["range_sigma_m"].as_double(), 0.12);
  EXPECT_NE(text.find("{id: A2, kind: uwb, position: [9.988, 0.000, 2.5]}"), std::string::npos)
      << text;  // flow style kept, millimetres, no "-0.000"
  s[1].id = "A7";
  EXPECT_THROW(surveyed_site_yaml(site, s, {}), SurveyError);
}

}  // namespace
}  // namespace ips::uwb_survey
