// The SVG floor map of ips-view: metres to pixels with y up, bounds around every anchor, the
// grid, covariance ellipses in pixels, the AoA boresight arrow, trails, colours and legend,
// escaping of every name from the air, and byte-identical output for the same model.
#include "viewer-headless/svg_render.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <numbers>
#include <regex>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace ips::view {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr utime_t kT0 = 1'700'000'000'000'000;
constexpr double kDeg = std::numbers::pi / 180.0;

pose_t pose(const std::string& tag, double x, double y) {
  pose_t p{};
  p.utime = kT0;
  p.source = "uwb_twr";
  p.tag_id = tag;
  p.position[0] = x, p.position[1] = y, p.position[2] = 1.2;
  for (double& c : p.position_cov) c = kNaN;
  for (double& v : p.velocity) v = kNaN;
  p.heading_rad = kNaN;
  p.residual_m = kNaN;
  p.status = pose_t::STATUS_OK;
  return p;
}

pose_t pose_with_cov(const std::string& tag, double x, double y, const Eigen::Matrix2d& cov) {
  pose_t p = pose(tag, x, y);
  p.position_cov[0] = cov(0, 0), p.position_cov[1] = cov(0, 1);
  p.position_cov[3] = cov(1, 0), p.position_cov[4] = cov(1, 1);
  p.position_cov[8] = 0.01;
  return p;
}

site_t site_msg(const std::string& yaml) {
  site_t m{};
  m.utime = kT0;
  m.source = "ips-sim";
  m.site_yaml = yaml;
  return m;
}

// config/sites/lab.yaml's room (10 m x 8 m), and two BLE AoA anchors: B1 looking along +y (yaw
// 90 deg) and B2 along +x (yaw 0).
const char* kLabSite = R"(name: lab
anchors:
  - {id: A1, kind: uwb, position: [0.0, 0.0, 2.4]}
  - {id: A2, kind: uwb, position: [10.0, 0.0, 2.4]}
  - {id: A3, kind: uwb, position: [10.0, 8.0, 2.4]}
  - {id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}
  - {id: B1, kind: ble_aoa, position: [5.0, 0.0, 2.8], orientation_deg: [0, 0, 90]}
  - {id: B2, kind: ble_aoa, position: [0.0, 4.0, 2.8], orientation_deg: [0, 0, 0]}
)";

ViewModel lab_model() {
  ViewModel m;
  m.on_site(site_msg(kLabSite), kT0);
  EXPECT_TRUE(m.has_site()) << m.last_site_error();
  return m;
}

struct Px {
  double x, y;
};

// (cx, cy) of every <circle class="cls" ...>, in document order.
std::vector<Px> circles(const std::string& svg, const std::string& cls) {
  std::vector<Px> out;
  const std::regex re("<circle class=\"" + cls + "\" cx=\"(-?[0-9.]+)\" cy=\"(-?[0-9.]+)\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it)
    out.push_back({std::stod((*it)[1]), std::stod((*it)[2])});
  return out;
}

size_t count(const std::string& haystack, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = haystack.find(needle); pos != std::string::npos;
       pos = haystack.find(needle, pos + needle.size()))
    ++n;
  return n;
}

// Well-formed XML made only of the elements the renderer writes: balanced tags, quoted attributes
// without '<', only predefined or numeric entity references, printable ASCII only. A name from
// the air that slipped through unescaped would add an element outside this list or break this.
bool well_formed_svg(const std::string& doc, std::string& why) {
  static const std::set<std::string> kElements = {"svg",     "title",  "rect", "defs", "clipPath",
                                                  "marker",  "path",   "g",    "line", "polyline",
                                                  "ellipse", "circle", "text"};
  static const std::regex kEntity("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
  for (unsigned char c : doc)
    if (!(c == '\n' || (c >= 0x20 && c < 0x7f))) return why = "byte " + std::to_string(c), false;
  std::vector<std::string> stack;
  int roots = 0;
  const auto is_name = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':';
  };
  size_t i = 0;
  while (i < doc.size()) {
    if (doc[i] == '&') {
      if (!std::regex_search(doc.begin() + static_cast<std::ptrdiff_t>(i), doc.end(), kEntity))
        return why = "bad & at " + std::to_string(i), false;
      ++i;
      continue;
    }
    if (doc[i] == '>') return why = "stray > at " + std::to_string(i), false;
    if (doc[i] != '<') {
      if (stack.empty() && !std::isspace(static_cast<unsigned char>(doc[i])))
        return why = "text outside the root", false;
      ++i;
      continue;
    }
    const bool closing = doc.compare(i, 2, "</") == 0;
    size_t j = i + (closing ? 2 : 1);
    const size_t name_start = j;
    while (j < doc.size() && is_name(doc[j])) ++j;
    const std::string name = doc.substr(name_start, j - name_start);
    if (!kElements.count(name))
      return why = "element <" + name + "> at " + std::to_string(i), false;
    if (closing) {
      if (j >= doc.size() || doc[j] != '>') return why = "bad end tag " + name, false;
      if (stack.empty() || stack.back() != name) return why = "mismatched </" + name + ">", false;
      stack.pop_back();
      i = j + 1;
      continue;
    }
    std::set<std::string> attrs;
    while (true) {
      while (j < doc.size() && std::isspace(static_cast<unsigned char>(doc[j]))) ++j;
      if (j >= doc.size()) return why = "open tag " + name, false;
      if (doc[j] == '>' || doc.compare(j, 2, "/>") == 0) break;
      const size_t a = j;
      while (j < doc.size() && is_name(doc[j])) ++j;
      const std::string attr = doc.substr(a, j - a);
      if (attr.empty() || doc.compare(j, 2, "=\"") != 0)
        return why = "bad attribute in <" + name + "> at " + std::to_string(j), false;
      if (!attrs.insert(attr).second) return why = "duplicate attribute " + attr, false;
      const size_t end = doc.find('"', j + 2);
      if (end == std::string::npos) return why = "open attribute", false;
      const std::string value = doc.substr(j + 2, end - j - 2);
      if (value.find('<') != std::string::npos) return why = "< in attribute " + attr, false;
      for (size_t k = value.find('&'); k != std::string::npos; k = value.find('&', k + 1))
        if (!std::regex_search(value.begin() + static_cast<std::ptrdiff_t>(k), value.end(),
                               kEntity))
          return why = "bad & in attribute " + attr, false;
      j = end + 1;
    }
    if (stack.empty()) ++roots;
    if (doc[j] == '>') {
      stack.push_back(name);
      i = j + 1;
    } else {
      i = j + 2;
    }
  }
  if (!stack.empty()) return why = "unclosed <" + stack.back() + ">", false;
  if (roots != 1) return why = std::to_string(roots) + " root elements", false;
  return true;
}

TEST(SvgRender, TagNamedScriptAppearsOnlyAsEscapedText) {
  ViewModel m;
  m.on_site(site_msg("name: \"<b>site</b>\"\nanchors:\n"
                     "  - {id: \"<img src=x onerror=alert(1)>\", position: [0, 0, 2]}\n"
                     "  - {id: \"A&B\", position: [4, 3, 2]}\n"),
            kT0);
  ASSERT_TRUE(m.has_site()) << m.last_site_error();
  pose_t p = pose_with_cov("<script>alert(1)</script>", 1, 1, Eigen::Matrix2d::Identity());
  p.source = "'src' \"x\" & <y>";
  m.on_pose("POSE_UWB", p, kT0);
  m.on_pose("POSE_<i>\"odd\"</i>", pose("T\x1b[2J", 2, 2), kT0);

  const std::string svg = render_svg(m, {});
  std::string why;
  EXPECT_TRUE(well_formed_svg(svg, why)) << why << "\n" << svg;
  EXPECT_EQ(svg.find("<script"), std::string::npos);
  EXPECT_EQ(svg.find("<img"), std::string::npos);
  EXPECT_EQ(svg.find("<b>"), std::string::npos);
  EXPECT_EQ(svg.find("<i>"), std::string::npos);
  EXPECT_NE(svg.find(">&lt;script&gt;alert(1)&lt;/script&gt;</text>"), std::string::npos) << svg;
  EXPECT_NE(svg.find(">&lt;img src=x onerror=alert(1)&gt;</text>"), std::string::npos);
  EXPECT_NE(svg.find(">A&amp;B</text>"), std::string::npos);
  EXPECT_NE(svg.find("<title>ips-view: &lt;b&gt;site&lt;/b&gt;</title>"), std::string::npos);
  EXPECT_NE(svg.find("(&#39;src&#39; &quot;x&quot; &amp; &lt;y&gt;)</title>"), std::string::npos);
  EXPECT_NE(svg.find(">POSE_&lt;i&gt;&quot;odd&quot;&lt;/i&gt;</text>"), std::string::npos);
  EXPECT_NE(svg.find(">T\\x1b[2J</text>"), std::string::npos);  // no raw escape byte
}

TEST(XmlText, EscapesMarkupQuotesAndNonPrintableBytes) {
  EXPECT_EQ(xml_text("<a href=\"x\">'&'</a>"),
            "&lt;a href=&quot;x&quot;&gt;&#39;&amp;&#39;&lt;/a&gt;");
  EXPECT_EQ(xml_text(std::string("a\0b\n\xff", 5)), "a\\x00b\\x0a\\xff");
  EXPECT_EQ(xml_text("A1"), "A1");
}

TEST(SvgRender, BoundsIncludeEveryAnchor) {
  ViewModel m;
  m.on_site(site_msg("anchors:\n"
                     "  - {id: A1, position: [-3.0, -2.0, 2.4]}\n"
                     "  - {id: A2, position: [12.0, 0.0, 2.4]}\n"
                     "  - {id: A3, position: [12.5, 9.0, 2.4]}\n"
                     "  - {id: A4, position: [0.0, 9.5, 2.4]}\n"
                     "  - {id: A5, position: [30.0, 1.0, 2.4], enabled: false}\n"),
            kT0);
  m.on_pose("POSE_UWB", pose("T1", 4, 4), kT0);
  SvgOptions o;
  o.margin_m = 1.0;
  const MapFrame f = map_frame(m, o);
  EXPECT_DOUBLE_EQ(f.x_min, -4.0);
  EXPECT_DOUBLE_EQ(f.x_max, 31.0);
  EXPECT_DOUBLE_EQ(f.y_min, -3.0);
  EXPECT_DOUBLE_EQ(f.y_max, 10.5);
  // 35 m x 13.5 m into 900 x 700 px: the width decides.
  EXPECT_NEAR(f.pixels_per_m, 900.0 / 35.0, 1e-12);

  const std::string svg = render_svg(m, o);
  std::string why;
  EXPECT_TRUE(well_formed_svg(svg, why)) << why;
  std::smatch vb;
  ASSERT_TRUE(std::regex_search(svg, vb, std::regex("viewBox=\"0 0 ([0-9.]+) ([0-9.]+)\"")));
  const double width = std::stod(vb[1]), height = std::stod(vb[2]);
  const auto anchors = circles(svg, "anchor");
  ASSERT_EQ(anchors.size(), 5u);
  for (const auto& a : m.anchors()) {
    const Eigen::Vector2d q = f.to_px(a.position.x(), a.position.y());
    // Inside the plot by the margin (1 m) on every side, and so inside the picture.
    EXPECT_GE(q.x(), f.left + f.pixels_per_m - 1e-9) << a.id;
    EXPECT_LE(q.x(), f.left + f.width_px() - f.pixels_per_m + 1e-9) << a.id;
    EXPECT_GE(q.y(), f.top + f.pixels_per_m - 1e-9) << a.id;
    EXPECT_LE(q.y(), f.top + f.height_px() - f.pixels_per_m + 1e-9) << a.id;
  }
  for (const auto& c : anchors) {
    EXPECT_GT(c.x, 0);
    EXPECT_LT(c.x, width);
    EXPECT_GT(c.y, 0);
    EXPECT_LT(c.y, height);
  }
  EXPECT_NE(svg.find(">A5 (disabled)</text>"), std::string::npos);
}

TEST(SvgRender, YIsUpOnThePage) {
  const ViewModel m = lab_model();
  const MapFrame f = map_frame(m, {});
  // 12 m x 10 m with the margin; 700 / 10 = 70 px/m (below the 120 px/m cap).
  EXPECT_NEAR(f.pixels_per_m, 70.0, 1e-12);
  const auto a = circles(render_svg(m, {}), "anchor");
  ASSERT_EQ(a.size(), 6u);  // site order: A1 (0,0), A2 (10,0), A3 (10,8), A4 (0,8), B1, B2
  EXPECT_NEAR(a[1].x - a[0].x, 10 * 70.0, 0.1);  // +x to the right
  EXPECT_NEAR(a[0].y - a[3].y, 8 * 70.0, 0.1);   // +y up: A4 is higher on the page
  EXPECT_NEAR(a[2].x, a[1].x, 0.1);
  EXPECT_NEAR(a[2].y, a[3].y, 0.1);
  EXPECT_NEAR(a[0].x, f.left + 70.0, 0.1);  // 1 m margin
  EXPECT_NEAR(a[0].y, f.top + 9 * 70.0, 0.1);
}

TEST(SvgRender, GridEveryMetreWithLabelledAxes) {
  const std::string svg = render_svg(lab_model(), {});
  // x from -1 to 11 m, y from -1 to 9 m: one labelled line per metre.
  EXPECT_EQ(count(svg, "<text class=\"xtick\""), 13u);
  EXPECT_EQ(count(svg, "<text class=\"ytick\""), 11u);
  for (const char* label : {">-1</text>", ">0</text>", ">5</text>", ">11</text>"})
    EXPECT_NE(svg.find(label), std::string::npos) << label;
  EXPECT_EQ(svg.find(">-0</text>"), std::string::npos);
  EXPECT_NE(svg.find(">x (m)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">y (m)</text>"), std::string::npos);

  EXPECT_EQ(grid_step_m(12), 1.0);
  EXPECT_EQ(grid_step_m(50), 1.0);
  EXPECT_EQ(grid_step_m(100), 2.0);
  EXPECT_EQ(grid_step_m(240), 5.0);
  EXPECT_EQ(grid_step_m(1000), 20.0);
  EXPECT_EQ(grid_step_m(2e9), 5e7);
}

TEST(SvgRender, CovarianceEllipseHasTwoSigmaAxesInPixels) {
  ViewModel m = lab_model();
  Eigen::Matrix2d diag;
  diag << 4, 0, 0, 1;  // 2-sigma semi-axes 4 m and 2 m
  Eigen::Matrix2d r;
  r << std::cos(30 * kDeg), -std::sin(30 * kDeg), std::sin(30 * kDeg), std::cos(30 * kDeg);
  m.on_pose("POSE_UWB", pose_with_cov("T1", 5, 4, diag), kT0);
  m.on_pose("POSE_TDOA", pose_with_cov("T1", 5, 4, r * diag * r.transpose()), kT0);
  Eigen::Matrix2d indefinite;
  indefinite << 1, 2, 2, 1;
  m.on_pose("POSE_AOA", pose_with_cov("T1", 5, 4, indefinite), kT0);

  const std::string svg = render_svg(m, {});
  const double ppm = map_frame(m, {}).pixels_per_m;
  const std::regex re(
      "<ellipse class=\"cov\" cx=\"([0-9.]+)\" cy=\"([0-9.]+)\" rx=\"([0-9.]+)\" "
      "ry=\"([0-9.]+)\" transform=\"rotate\\((-?[0-9.]+) [0-9.]+ [0-9.]+\\)\"");
  std::vector<std::smatch> found;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it)
    found.push_back(*it);
  // Sorted by channel: POSE_TDOA before POSE_UWB; POSE_AOA (not positive definite) has none.
  ASSERT_EQ(found.size(), 2u) << svg;
  EXPECT_NEAR(std::stod(found[0][3]), 4 * ppm, 0.01);
  EXPECT_NEAR(std::stod(found[0][4]), 2 * ppm, 0.01);
  EXPECT_NEAR(std::stod(found[0][5]), -30.0, 0.01);  // counter-clockwise, on a flipped page
  EXPECT_NEAR(std::stod(found[1][3]), 4 * ppm, 0.01);
  EXPECT_NEAR(std::stod(found[1][4]), 2 * ppm, 0.01);
  EXPECT_NEAR(std::stod(found[1][5]), 0.0, 0.01);
  const Eigen::Vector2d centre = map_frame(m, {}).to_px(5, 4);
  EXPECT_NEAR(std::stod(found[1][1]), centre.x(), 0.05);
  EXPECT_NEAR(std::stod(found[1][2]), centre.y(), 0.05);

  SvgOptions none;
  none.ellipse_sigma = 0;
  EXPECT_EQ(render_svg(m, none).find("<ellipse"), std::string::npos);
}

TEST(SvgRender, AoaAnchorArrowPointsAlongItsYaw) {
  const std::string svg = render_svg(lab_model(), {});
  const std::regex re(
      "<line class=\"aoa-axis\" x1=\"([0-9.]+)\" y1=\"([0-9.]+)\" x2=\"([0-9.]+)\" "
      "y2=\"([0-9.]+)\"");
  std::vector<std::smatch> arrows;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it)
    arrows.push_back(*it);
  ASSERT_EQ(arrows.size(), 2u);  // B1 and B2 only, not the UWB anchors
  // B1, yaw 90 deg: straight up the page.
  EXPECT_NEAR(std::stod(arrows[0][3]), std::stod(arrows[0][1]), 0.05);
  EXPECT_NEAR(std::stod(arrows[0][2]) - std::stod(arrows[0][4]), 26.0, 0.05);
  // B2, yaw 0: to the right.
  EXPECT_NEAR(std::stod(arrows[1][3]) - std::stod(arrows[1][1]), 26.0, 0.05);
  EXPECT_NEAR(std::stod(arrows[1][4]), std::stod(arrows[1][2]), 0.05);
  EXPECT_NE(svg.find("ble_aoa boresight (yaw)"), std::string::npos);
}

TEST(SvgRender, TrailIsAPolylineOfTheLastPositions) {
  ViewOptions vo;
  vo.trail_length = 5;
  ViewModel m(vo);
  m.on_site(site_msg(kLabSite), kT0);
  for (int i = 0; i < 8; ++i) m.on_pose("POSE_FUSED", pose("T1", i, 1.0), kT0 + i);
  const std::string svg = render_svg(m, {});
  const std::regex re("<polyline class=\"trail\" stroke=\"(#[0-9a-f]{6})\" points=\"([^\"]*)\"");
  std::smatch t;
  ASSERT_TRUE(std::regex_search(svg, t, re));
  EXPECT_EQ(t[1], "#d62728");  // POSE_FUSED's colour
  const std::string points = t[2];
  EXPECT_EQ(count(points, ","), 5u);
  const Eigen::Vector2d first = map_frame(m, {}).to_px(3, 1);  // the oldest kept: pose 3
  char expected[64];
  std::snprintf(expected, sizeof expected, "%.1f,%.1f ", first.x(), first.y());
  EXPECT_EQ(points.rfind(expected, 0), 0u) << points;

  SvgOptions no_trails;
  no_trails.trails = false;
  EXPECT_EQ(render_svg(m, no_trails).find("<polyline"), std::string::npos);
}

TEST(SvgRender, EachChannelHasItsColourAndOneLegendRow) {
  ViewModel m = lab_model();
  m.on_pose("TRUTH", pose("T1", 2, 2), kT0);
  m.on_pose("TRUTH", pose("T2", 3, 3), kT0);
  m.on_pose("POSE_UWB", pose("T1", 2.1, 2.1), kT0);
  pose_t coasting = pose("T2", 3.1, 3.1);
  coasting.status = int32_t{pose_t::STATUS_OK} | pose_t::STATUS_COASTING;
  m.on_pose("POSE_UWB", coasting, kT0);
  const std::string svg = render_svg(m, {});
  EXPECT_EQ(count(svg, "<circle class=\"estimate\""), 4u);
  EXPECT_EQ(count(svg, "fill=\"#000000\" stroke=\"#000000\""), 2u);  // TRUTH in black
  EXPECT_EQ(count(svg, "fill=\"#1f77b4\" stroke=\"#1f77b4\""), 1u);
  EXPECT_EQ(count(svg, "fill=\"#fff\" stroke=\"#1f77b4\""), 1u);  // coasting: hollow
  const size_t legend = svg.find("<g class=\"legend\">");
  ASSERT_NE(legend, std::string::npos);
  EXPECT_EQ(count(svg.substr(legend), ">TRUTH</text>"), 1u);
  EXPECT_EQ(count(svg.substr(legend), ">POSE_UWB</text>"), 1u);
  EXPECT_EQ(count(svg.substr(legend), ">anchor</text>"), 1u);
  EXPECT_NE(svg.find("ellipses: 2-sigma"), std::string::npos);
}

TEST(SvgRender, SameModelGivesTheSameBytes) {
  // The same messages, tags and channels arriving in another order: the same picture.
  const auto feed = [](ViewModel& m, bool reversed) {
    m.on_site(site_msg(kLabSite), kT0);
    std::vector<std::pair<std::string, pose_t>> msgs;
    for (int i = 0; i < 20; ++i) {
      const double x = 1 + 0.3 * i, y = 2 + 0.2 * i;
      Eigen::Matrix2d cov;
      cov << 0.04 + 0.001 * i, 0.01, 0.01, 0.09;
      msgs.push_back({"POSE_UWB", pose_with_cov("T1", x, y, cov)});
      msgs.push_back({"TRUTH", pose("T1", x + 0.05, y)});
      msgs.push_back({"POSE_FUSED", pose_with_cov("T2", y, x, cov)});
    }
    // Per (channel, tag) the order is kept; only the interleaving differs.
    if (reversed)
      std::stable_sort(msgs.begin(), msgs.end(),
                       [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [channel, p] : msgs) m.on_pose(channel, p, kT0);
  };
  ViewModel a, b;
  feed(a, false);
  feed(b, true);
  const std::string svg = render_svg(a, {});
  EXPECT_EQ(svg, render_svg(a, {}));
  EXPECT_EQ(svg, render_svg(b, {}));
  EXPECT_EQ(a.json(kT0), b.json(kT0));
}

TEST(SvgRender, WildEstimateDoesNotShrinkTheSite) {
  ViewModel m = lab_model();
  m.on_pose("POSE_UWB", pose("T1", 1e6, -1e300), kT0);
  const MapFrame f = map_frame(m, {});
  // At most max(5 m, half the 10 m site) beyond the anchors, plus the margin.
  EXPECT_DOUBLE_EQ(f.x_max, 10 + 5 + 1);
  EXPECT_DOUBLE_EQ(f.y_min, 0 - 5 - 1);
  const std::string svg = render_svg(m, {});
  std::string why;
  EXPECT_TRUE(well_formed_svg(svg, why)) << why;
  EXPECT_LT(svg.size(), 20000u);  // no 300-digit coordinates
}

TEST(SvgRender, EmptyModelIsAWellFormedMapWithANote) {
  const std::string svg = render_svg(ViewModel{}, {});
  std::string why;
  EXPECT_TRUE(well_formed_svg(svg, why)) << why << "\n" << svg;
  EXPECT_NE(svg.find("no site and no estimates yet"), std::string::npos);
  EXPECT_NE(svg.find("<title>ips-view</title>"), std::string::npos);
}

}  // namespace
}  // namespace ips::view
