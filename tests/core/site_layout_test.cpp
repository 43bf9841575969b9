// The building in a site file: floors and their plans (read from their files and carried in the
// site's YAML, so a SITE message holds them), zones, alert rules; every mistake named with its
// line.
#include "core/site_layout.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/site.hpp"

namespace ips {
namespace {

const char* const kAnchors = "name: b\nanchors:\n  - {id: A1, position: [0, 0, 2]}\n";

std::string error_of(const std::string& yaml) {
  try {
    parse_site_text(std::string(kAnchors) + yaml, "site.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "no error";
}

TEST(SiteLayout, FloorsZonesAndAlerts) {
  const Site s = parse_site_text(std::string(kAnchors) +
                                     "floors:\n"
                                     "  - {index: 1, name: First, height_m: 3.5}\n"
                                     "  - {index: 0, height_m: 0}\n"
                                     "zones:\n"
                                     "  - id: bench\n"
                                     "    floor: 0\n"
                                     "    polygon: [[0, 0], [4, 0], [4, 3], [0, 3]]\n"
                                     "    alert: [enter, dwell]\n"
                                     "    dwell_s: 30\n"
                                     "  - {id: hall, name: Hall, polygon: [[0, 0], [1, 0], [0, 1]], "
                                     "alert: leave}\n"
                                     "alerts: {tag_silent_s: 4, process_degraded: false}\n",
                                 "site.yaml");
  const SiteLayout& l = s.layout;
  ASSERT_EQ(l.floors.size(), 2u);
  EXPECT_EQ(l.floors[0].index, 0);  // sorted by height
  EXPECT_EQ(l.floors[0].name, "floor 0");
  EXPECT_EQ(l.floors[1].name, "First");
  EXPECT_EQ(l.floor_of_height(1.2), 0);
  EXPECT_EQ(l.floor_of_height(3.1), 1);  // within 0.5 m of the first floor's surface
  EXPECT_EQ(l.floor_of_height(-4), 0);
  ASSERT_EQ(l.zones.size(), 2u);
  EXPECT_EQ(l.zones[0].name, "bench");
  EXPECT_EQ(l.zones[0].floor, 0);
  EXPECT_TRUE(l.zones[0].alert.enter && l.zones[0].alert.dwell && !l.zones[0].alert.leave);
  EXPECT_DOUBLE_EQ(l.zones[0].dwell_s, 30);
  EXPECT_DOUBLE_EQ(l.zones[0].hysteresis_m, 0.3);
  EXPECT_FALSE(l.zones[1].floor.has_value());
  EXPECT_TRUE(l.zones[1].alert.leave && !l.zones[1].alert.enter);
  EXPECT_DOUBLE_EQ(l.alerts.tag_silent_s, 4);
  EXPECT_DOUBLE_EQ(l.alerts.process_silent_s, 5);
  EXPECT_FALSE(l.alerts.process_degraded);
  EXPECT_EQ(SiteLayout{}.floor_of_height(1.0), kNoFloor);
}

TEST(SiteLayout, MistakesNamedWithTheirLine) {
  EXPECT_EQ(error_of("zones:\n  - {id: z, polygon: [[0, 0], [1, 1]]}\n"),
            "site.yaml:5: zones[0].polygon: expected a list of 3 to 1000 [x, y] vertices");
  EXPECT_EQ(error_of("zones:\n  - {id: z, polygon: [[0, 0], [1, 1], [2, 2]]}\n"),
            "site.yaml:5: zones[0].polygon: encloses no area");
  EXPECT_EQ(error_of("zones:\n  - {id: z, floor: 2, polygon: [[0, 0], [1, 0], [0, 1]]}\n"),
            "site.yaml:5: zones[0].floor: no floor 2 in `floors` (none defined)");
  EXPECT_EQ(error_of("zones:\n  - {id: z, alert: exit, polygon: [[0, 0], [1, 0], [0, 1]]}\n"),
            "site.yaml:5: zones[0].alert: unknown event 'exit' (enter, leave, dwell)");
  EXPECT_EQ(error_of("zones:\n  - {id: z, alert: dwell, polygon: [[0, 0], [1, 0], [0, 1]]}\n"),
            "site.yaml:5: zones[0].alert: a dwell alert needs dwell_s > 0");
  EXPECT_EQ(error_of("zones:\n  - {id: z, polygon: [[0, 0], [1, 0], [0, 1]]}\n"
                     "  - {id: z, polygon: [[0, 0], [1, 0], [0, 1]]}\n"),
            "site.yaml:6: zones[1].id: duplicate zone id 'z'");
  EXPECT_EQ(error_of("floors:\n  - {index: 0, height_m: 0}\n  - {index: 0, height_m: 3}\n"),
            "site.yaml:6: floors[1].index: duplicate floor 0");
  EXPECT_EQ(error_of("floors:\n  - {index: 1, height_m: 0}\n  - {index: 0, height_m: 3}\n"),
            "site.yaml:5: floors: floor indices must rise with height_m (floor 0 is above "
            "floor 1)");
  EXPECT_EQ(error_of("floors:\n  - {index: 0, height_m: 0, plan: {image: a.png}}\n"),
            "site.yaml:5: floors[0].plan.size_m: field is required");
  EXPECT_EQ(error_of("alerts: {tag_silent: 3}\n"),
            "site.yaml:4: alerts.tag_silent: unknown field (known: tag_silent_s, "
            "process_silent_s, process_degraded)");
  EXPECT_EQ(error_of("plan_images: {a.png: 'data:text/html;base64,AAAA'}\n"),
            "site.yaml:4: plan_images.a.png: expected a data:image/png;base64 or "
            "data:image/svg+xml;base64 URI");
}

TEST(SiteLayout, PlanImagesAreCarriedInTheSite) {
  const auto dir = std::filesystem::temp_directory_path() / "ips_site_layout_test";
  std::filesystem::create_directories(dir / "plans");
  std::ofstream(dir / "plans" / "ground.svg")
      << "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"10\" "
         "height=\"5\"><rect width=\"10\" height=\"5\"/></svg>\n";
  const std::string text = std::string(kAnchors) +
                           "floors:\n"
                           "  - index: 0\n"
                           "    height_m: 0\n"
                           "    plan: {image: plans/ground.svg, origin: [-1, -2], size_m: [20, "
                           "10], rotation_deg: 90}\n";
  std::ofstream(dir / "site.yaml") << text;
  const Site s = load_site_file((dir / "site.yaml").string());
  ASSERT_EQ(s.layout.floors.size(), 1u);
  ASSERT_TRUE(s.layout.floors[0].plan.has_value());
  const FloorPlan& plan = *s.layout.floors[0].plan;
  EXPECT_EQ(plan.image, "plans/ground.svg");
  EXPECT_EQ(plan.origin, Eigen::Vector2d(-1, -2));
  EXPECT_EQ(plan.size_m, Eigen::Vector2d(20, 10));
  EXPECT_NEAR(plan.rotation_rad, M_PI / 2, 1e-12);
  EXPECT_EQ(plan.data_uri.rfind("data:image/svg+xml;base64,PD94bWwg", 0), 0u) << plan.data_uri;
  // The file's text comes first, unchanged (its line numbers hold), then the images.
  EXPECT_EQ(s.yaml_text.rfind(text, 0), 0u);
  // Through a SITE message, without the image file.
  std::filesystem::remove_all(dir);
  const Site back = site_from_msg(site_to_msg(s, 1, "test"));
  ASSERT_TRUE(back.layout.floors[0].plan.has_value());
  EXPECT_EQ(back.layout.floors[0].plan->data_uri, plan.data_uri);
  // A missing image is the plan's error, with its line.
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "site.yaml") << text;
  try {
    load_site_file((dir / "site.yaml").string());
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("site.yaml:7: floors[0].plan.image: floor plan: "),
              std::string::npos)
        << e.what();
  }
  std::ofstream(dir / "plans.txt") << "not an image";
  std::ofstream(dir / "site.yaml")
      << kAnchors << "floors:\n  - {index: 0, height_m: 0, plan: {image: plans.txt, size_m: [1, "
      << "1]}}\n";
  try {
    load_site_file((dir / "site.yaml").string());
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("is neither PNG nor SVG"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(SiteLayout, PolygonGeometry) {
  const std::vector<Eigen::Vector2d> square = {{0, 0}, {4, 0}, {4, 4}, {0, 4}};
  EXPECT_TRUE(polygon_contains(square, {1, 1}));
  EXPECT_FALSE(polygon_contains(square, {5, 1}));
  EXPECT_FALSE(polygon_contains(square, {-0.1, 2}));
  const std::vector<Eigen::Vector2d> ell = {{0, 0}, {4, 0}, {4, 1}, {1, 1}, {1, 4}, {0, 4}};
  EXPECT_TRUE(polygon_contains(ell, {0.5, 3}));
  EXPECT_FALSE(polygon_contains(ell, {3, 3}));  // the notch
  EXPECT_DOUBLE_EQ(polygon_boundary_distance(square, {1, 2}), 1.0);
  EXPECT_DOUBLE_EQ(polygon_boundary_distance(square, {7, 4}), 3.0);
  EXPECT_DOUBLE_EQ(polygon_boundary_distance(square, {7, 8}), 5.0);  // to the corner
}

TEST(SiteLayout, Base64) {
  EXPECT_EQ(base64_encode(""), "");
  EXPECT_EQ(base64_encode("f"), "Zg==");
  EXPECT_EQ(base64_encode("fo"), "Zm8=");
  EXPECT_EQ(base64_encode("foo"), "Zm9v");
  EXPECT_EQ(base64_encode("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64_encode(std::string("\xff\x00\x80", 3)), "/wCA");
}

}  // namespace
}  // namespace ips
