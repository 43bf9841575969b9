// ips-site's reload logic (tools/site/site_keeper.hpp): the site it publishes and the error it
// reports, fed successive versions of a site file as an operator edits it.
#include "tools/site/site_keeper.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ips::site_tool {
namespace {

using Kind = SiteOutcome::Kind;

// config/sites/lab.yaml's content, with the one line each test edits marked by a placeholder.
std::string lab(const std::string& a2 = "[10.0, 0.0, 2.4]", const std::string& t1_height = "1.2",
                const std::string& estimators = "  uwb_twr:\n    range_sigma_m: 0.10\n") {
  return "name: lab\n"
         "anchors:\n"
         "  - {id: A1, kind: uwb, position: [0.0, 0.0, 2.4]}\n"
         "  - {id: A2, kind: uwb, position: " + a2 + "}\n"
         "  - {id: A3, kind: uwb, position: [10.0, 8.0, 2.4]}\n"
         "  - {id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}\n"
         "tags:\n"
         "  - {id: T1, height_m: " + t1_height + "}\n"
         "estimators:\n" + estimators;
}

TEST(SiteKeeper, FirstValidTextIsTheSite) {
  SiteKeeper k("lab.yaml");
  EXPECT_FALSE(k.has_site());
  const SiteOutcome o = k.offer_text(lab());
  EXPECT_EQ(o.kind, Kind::kFirst);
  ASSERT_TRUE(k.has_site());
  EXPECT_EQ(k.site().name, "lab");
  ASSERT_EQ(k.site().anchors.size(), 4u);
  EXPECT_EQ(k.site().anchors[1].position, Eigen::Vector3d(10, 0, 2.4));
  EXPECT_EQ(k.site().yaml_text, lab());  // the file's own text goes into SITE
  EXPECT_EQ(k.error(), "");
  EXPECT_EQ(k.replaced(), 0);
  EXPECT_EQ(k.rejected(), 0);
}

TEST(SiteKeeper, SameTextAgainIsUnchanged) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o = k.offer_text(lab());
  EXPECT_EQ(o.kind, Kind::kUnchanged);
  EXPECT_FALSE(o.error_cleared);
  EXPECT_EQ(k.replaced(), 0);
}

TEST(SiteKeeper, MovedAnchorReplacesTheSiteAndSaysWhatMoved) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o = k.offer_text(lab("[10.5, 0.0, 2.4]"));
  EXPECT_EQ(o.kind, Kind::kReplaced);
  EXPECT_FALSE(o.error_cleared);
  EXPECT_EQ(o.text, "anchor A2 moved 0.50 m to [10.5, 0, 2.4]");
  EXPECT_EQ(k.site().anchors[1].position, Eigen::Vector3d(10.5, 0, 2.4));
  EXPECT_EQ(k.replaced(), 1);
}

TEST(SiteKeeper, BadEditKeepsThePreviousSiteAndNamesFileAndLine) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab("[10.5, 0.0, 2.4]"));
  const SiteOutcome o = k.offer_text(lab("[10.0, 0.0]"));
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text, "lab.yaml:4: anchors[1].position: expected a list of 3 numbers [x, y, z]");
  EXPECT_EQ(k.error(), o.text);
  ASSERT_TRUE(k.has_site());
  EXPECT_EQ(k.site().anchors[1].position, Eigen::Vector3d(10.5, 0, 2.4));  // still the old one
  EXPECT_EQ(k.rejected(), 1);
  // The same bad text read again (SIGHUP, a touch): still refused, still the old site.
  EXPECT_EQ(k.offer_text(lab("[10.0, 0.0]")).kind, Kind::kRejected);
  EXPECT_EQ(k.rejected(), 2);
  EXPECT_EQ(k.site().anchors[1].position, Eigen::Vector3d(10.5, 0, 2.4));
}

TEST(SiteKeeper, SyntaxErrorNamesLineAndColumn) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o = k.offer_text(lab("[10.0, 0.0, 2.4"));
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text.rfind("lab.yaml:4:", 0), 0u) << o.text;
  EXPECT_NE(o.text.find("YAML syntax error"), std::string::npos) << o.text;
}

TEST(SiteKeeper, FixedFileClearsTheErrorAndIsPublished) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  k.offer_text(lab("[10.0, 0.0]"));
  const SiteOutcome o = k.offer_text(lab("[10.2, 0.0, 2.4]"));
  EXPECT_EQ(o.kind, Kind::kReplaced);
  EXPECT_TRUE(o.error_cleared);
  EXPECT_EQ(k.error(), "");
  EXPECT_EQ(k.site().anchors[1].position, Eigen::Vector3d(10.2, 0, 2.4));
}

TEST(SiteKeeper, EditUndoneClearsTheErrorWithoutANewSite) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  k.offer_text(lab("[10.0, 0.0]"));
  const SiteOutcome o = k.offer_text(lab());  // back to the published text
  EXPECT_EQ(o.kind, Kind::kUnchanged);
  EXPECT_TRUE(o.error_cleared);
  EXPECT_EQ(k.error(), "");
  EXPECT_EQ(k.replaced(), 0);
}

TEST(SiteKeeper, UnreadableFileKeepsTheSite) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o = k.offer_read_error("lab.yaml: cannot read: No such file or directory");
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(k.error(), "lab.yaml: cannot read: No such file or directory");
  EXPECT_EQ(k.site().anchors.size(), 4u);
  // Written again (an editor's rename): loads again, nothing new to publish.
  EXPECT_EQ(k.offer_text(lab()).kind, Kind::kUnchanged);
  EXPECT_EQ(k.error(), "");
}

TEST(SiteKeeper, EmptyFileIsRefused) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o = k.offer_text("");  // truncated by a writer that has not written yet
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_NE(o.text.find("lab.yaml"), std::string::npos) << o.text;
  EXPECT_EQ(k.site().anchors.size(), 4u);
}

TEST(SiteKeeper, OversizedFileIsRefused) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const std::string big = lab() + "# " + std::string(kMaxSiteFileBytes, 'x') + "\n";
  const SiteOutcome o = k.offer_text(big);
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text, "lab.yaml: " + std::to_string(big.size()) +
                        " bytes; a site file may have at most 1048576");
}

// The loader takes these; the estimators that would take the site refuse them, so ips-site does.
TEST(SiteKeeper, EstimatorParameterOutOfRangeIsRefused) {
  SiteKeeper k("lab.yaml");
  k.offer_text(lab());
  const SiteOutcome o =
      k.offer_text(lab("[10.0, 0.0, 2.4]", "1.2", "  uwb_twr:\n    range_sigma_m: -0.1\n"));
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text, "lab.yaml:11: estimators.uwb_twr.range_sigma_m: must be in (0, 1e6]");
  EXPECT_DOUBLE_EQ(k.site().estimator_params("uwb_twr").get_double("range_sigma_m", 0), 0.10);
}

TEST(SiteKeeper, MisspeltEstimatorParameterIsRefused) {
  SiteKeeper k("lab.yaml");
  const SiteOutcome o = k.offer_text(lab("[10.0, 0.0, 2.4]", "1.2", "  pdr:\n    stepp: 1\n"));
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text.rfind("lab.yaml:11: estimators.pdr.stepp: unknown field", 0), 0u) << o.text;
  EXPECT_FALSE(k.has_site());
}

TEST(SiteKeeper, SectionNamingAnAnchorThatIsNotThereIsRefused) {
  SiteKeeper k("lab.yaml");
  const SiteOutcome o =
      k.offer_text(lab("[10.0, 0.0, 2.4]", "1.2", "  uwb_tdoa:\n    master: D1\n"));
  EXPECT_EQ(o.kind, Kind::kRejected);
  EXPECT_EQ(o.text,
            "lab.yaml:11: estimators.uwb_tdoa.master: 'D1' is not an enabled uwb_tdoa anchor of "
            "the site");
}

TEST(SiteChange, SaysWhatChanged) {
  const Site before = parse_site_text(lab(), "a");
  EXPECT_EQ(describe_site_change(before, parse_site_text(lab(), "b")), "comments or layout only");
  EXPECT_EQ(describe_site_change(before, parse_site_text("# edited\n" + lab(), "b")),
            "comments or layout only");
  EXPECT_EQ(describe_site_change(before, parse_site_text(lab("[10.0, 0.0, 2.4]", "1.25"), "b")),
            "tag T1 height_m 1.2 -> 1.25");
  EXPECT_EQ(describe_site_change(
                before, parse_site_text(lab("[10.0, 0.0, 2.4]", "1.2",
                                            "  uwb_twr:\n    range_sigma_m: 0.2\n  pdr: {}\n"),
                                        "b")),
            "estimators.pdr added; estimators.uwb_twr changed");
  std::string moved = lab();
  moved.replace(moved.find("{id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}"),
                std::string("{id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}").size(),
                "{id: A5, kind: uwb, position: [0.0, 8.0, 2.4], enabled: true}");
  moved.replace(moved.find("{id: A3, kind: uwb,"), std::string("{id: A3, kind: uwb,").size(),
                "{id: A3, kind: uwb, enabled: false,");
  EXPECT_EQ(describe_site_change(before, parse_site_text(moved, "b")),
            "anchor A3 disabled; anchor A4 removed; anchor A5 added");
}

}  // namespace
}  // namespace ips::site_tool
