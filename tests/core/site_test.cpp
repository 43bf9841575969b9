// Site files: valid files load; every kind of mistake gives file, line, field and reason.
#include "core/site.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

namespace ips {
namespace {

std::string error_of(const std::string& yaml) {
  try {
    parse_site_text(yaml, "site.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Site, LoadsTheLabSiteFile) {
  Site s = load_site_file(IPS_SOURCE_DIR "/config/sites/lab.yaml");
  EXPECT_EQ(s.name, "lab");
  ASSERT_EQ(s.anchors.size(), 12u);  // 4 uwb, 4 uwb_tdoa, 4 ble_aoa
  EXPECT_EQ(s.anchors[2].id, "A3");
  EXPECT_EQ(s.anchors[2].position, Eigen::Vector3d(10, 8, 2.4));
  EXPECT_EQ(s.anchors[4].kind, "uwb_tdoa");
  EXPECT_EQ(s.anchors[8].kind, "ble_aoa");
  EXPECT_NEAR(s.anchors[8].orientation_rad.z(), M_PI / 2, 1e-12);
  ASSERT_EQ(s.baro_stations.size(), 1u);
  ASSERT_EQ(s.tags.size(), 1u);
  EXPECT_DOUBLE_EQ(s.tags[0].height_m, 1.2);
  EXPECT_TRUE(s.tags[0].has_start());
  EXPECT_DOUBLE_EQ(s.estimator_params("uwb_twr").get_double("range_sigma_m", 0), 0.10);
  EXPECT_FALSE(s.estimator_params("nothing").defined());
}

TEST(Site, DefaultsAndOrientation) {
  Site s = parse_site_text(
      "anchors:\n  - {id: B, kind: ble_aoa, position: [1, 2, 3], orientation_deg: [0, 0, 90]}\n"
      "tags:\n  - {id: T}\n",
      "x");
  EXPECT_EQ(s.name, "unnamed");
  EXPECT_EQ(s.anchors[0].kind, "ble_aoa");
  EXPECT_NEAR(s.anchors[0].orientation_rad.z(), M_PI / 2, 1e-12);
  EXPECT_TRUE(s.anchors[0].enabled);
  EXPECT_TRUE(std::isnan(s.tags[0].height_m));
}

TEST(Site, RoundTripsThroughSiteMessage) {
  Site s = load_site_file(IPS_SOURCE_DIR "/config/sites/lab.yaml");
  site_t m = site_to_msg(s, 123, "test");
  EXPECT_EQ(m.num_anchors, 12);
  EXPECT_EQ(m.anchors[1].position[0], 10.0);
  EXPECT_EQ(m.num_tags, 1);
  Site back = site_from_msg(m);
  EXPECT_EQ(back.anchors.size(), 12u);
  EXPECT_EQ(back.anchors[3].position, s.anchors[3].position);
  EXPECT_DOUBLE_EQ(back.estimator_params("uwb_twr").get_double("range_sigma_m", 0), 0.10);
}

TEST(SiteErrors, SyntaxErrorNamesLineAndColumn) {
  EXPECT_EQ(error_of("anchors: [\n  {id: A1, position: [0, 0"),
            "site.yaml:2:1: YAML syntax error: end of sequence flow not found");
}

TEST(SiteErrors, MissingAnchors) {
  EXPECT_EQ(error_of("name: x\n"), "site.yaml:1: anchors: field is required");
}

TEST(SiteErrors, PositionWithTwoNumbers) {
  EXPECT_EQ(error_of("anchors:\n  - id: A1\n    position: [1, 2]\n"),
            "site.yaml:3: anchors[0].position: expected a list of 3 numbers [x, y, z]");
}

TEST(SiteErrors, NonNumericCoordinate) {
  EXPECT_EQ(error_of("anchors:\n  - {id: A1, position: [1, two, 3]}\n"),
            "site.yaml:2: anchors[0].position[1]: expected a number, got 'two'");
}

TEST(SiteErrors, DuplicateAnchor) {
  EXPECT_EQ(error_of("anchors:\n  - {id: A1, position: [0, 0, 0]}\n  - {id: A1, position: [1, 0, 0]}\n"),
            "site.yaml:3: anchors[1].id: duplicate anchor id 'A1'");
}

TEST(SiteErrors, UnknownKind) {
  EXPECT_EQ(error_of("anchors:\n  - {id: A1, kind: lidar, position: [0, 0, 0]}\n"),
            "site.yaml:2: anchors[0].kind: unknown kind 'lidar' (uwb, uwb_tdoa, ble_aoa)");
}

TEST(SiteErrors, MisspeltFieldIsAnErrorNotADefault) {
  EXPECT_EQ(error_of("anchors:\n  - {id: A1, position: [0, 0, 0]}\ntags:\n  - {id: T1, heigth_m: 1.2}\n"),
            "site.yaml:4: tags[0].heigth_m: unknown field (known: id, height_m, start_position, "
            "start_heading_deg)");
}

TEST(Site, TagStartPoseForTheRelativeEstimators) {
  const Site s = parse_site_text(
      "anchors: []\ntags:\n"
      "  - {id: P1, height_m: 1.1, start_position: [2, 3], start_heading_deg: 90}\n"
      "  - {id: P2, start_position: [4, 5, 0.2]}\n  - {id: P3}\n",
      "site.yaml");
  ASSERT_EQ(s.tags.size(), 3u);
  EXPECT_TRUE(s.tags[0].has_start());
  EXPECT_EQ(s.tags[0].start_position, Eigen::Vector3d(2, 3, 1.1));  // z: the carrying height
  EXPECT_DOUBLE_EQ(s.tags[0].start_heading_rad, M_PI / 2);
  EXPECT_EQ(s.tags[1].start_position, Eigen::Vector3d(4, 5, 0.2));
  EXPECT_TRUE(std::isnan(s.tags[1].start_heading_rad));
  EXPECT_FALSE(s.tags[2].has_start());
  EXPECT_EQ(error_of("anchors: []\ntags:\n  - {id: P1, start_position: [1]}\n"),
            "site.yaml:3: tags[0].start_position: expected a list of 3 numbers [x, y, z]");
  EXPECT_EQ(error_of("anchors: []\ntags:\n  - {id: P1, start_heading_deg: 400}\n"),
            "site.yaml:3: tags[0].start_heading_deg: must be in [-360, 360]");
}

TEST(SiteErrors, EmptyTagIdAndDuplicateStation) {
  EXPECT_EQ(error_of("anchors: []\ntags:\n  - {id: ''}\n"), "site.yaml:3: tags[0].id: must not be empty");
  EXPECT_EQ(error_of("anchors:\n  - {id: A1, position: [0, 0, 0]}\nbaro_stations:\n  - {id: A1, position: [0, 0, 0]}\n"),
            "site.yaml:4: baro_stations[0].id: duplicate id 'A1'");
}

TEST(SiteErrors, NotAMap) {
  EXPECT_EQ(error_of("- 1\n- 2\n"), "site.yaml:1: expected a site map (name, anchors, tags)");
}

TEST(SiteErrors, UnreadableFile) {
  try {
    load_site_file("/nonexistent/site.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/site.yaml: cannot read: No such file or directory");
  }
}

}  // namespace
}  // namespace ips

namespace ips {
namespace {

// An estimator of one anchor kind says at start (and in HEALTH) that its site has none.
TEST(SiteAnchorKind, AMissingKindIsSaidWithWhatTheSiteHas) {
  const Site lab = load_site_file(IPS_SOURCE_DIR "/config/sites/lab.yaml");
  for (const char* kind : {"uwb", "uwb_tdoa", "ble_aoa"})
    EXPECT_EQ(missing_anchor_kind(lab, kind, "ips-x"), "") << kind;
  Site s = parse_site_text(
      "name: hall\nanchors:\n  - {id: A1, position: [0, 0, 2]}\n  - {id: A2, position: [5, 0, 2]}\n"
      "  - {id: B1, kind: ble_aoa, position: [0, 5, 2], enabled: false}\n",
      "hall.yaml");
  EXPECT_EQ(missing_anchor_kind(s, "ble_aoa", "ips-aoa"),
            "site 'hall' (hall.yaml) has no enabled ble_aoa anchor (it has 2 uwb): ips-aoa "
            "estimates nothing until a site with them arrives");
  EXPECT_EQ(missing_anchor_kind(s, "uwb", "ips-uwb-twr"), "");
  s.anchors.clear();
  EXPECT_EQ(missing_anchor_kind(s, "uwb_tdoa", "ips-uwb-tdoa"),
            "site 'hall' (hall.yaml) has no enabled uwb_tdoa anchor (it has none): ips-uwb-tdoa "
            "estimates nothing until a site with them arrives");
}

}  // namespace
}  // namespace ips
