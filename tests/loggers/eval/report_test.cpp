// The --report figures: data-to-pixel mapping, one polyline per channel and tag, the CDF staircase,
// decimation bounds, escaping of names from the log, and pages without data.
#include "loggers/eval/report.hpp"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <map>
#include <numbers>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "core/channel_colours.hpp"
#include "loggers/eval/evaluation.hpp"
#include "tests/loggers/eval/pose_samples.hpp"

namespace ips::eval {
namespace {

using testing::kT0;
using testing::planar_pose;
using testing::pose;

ReportInput input_from(const Evaluator& ev) {
  ReportInput in;
  in.log_path = "test.lcm";
  in.rows = ev.rows();
  in.series = ev.estimate_series();
  in.truth = &ev.truth_tracks();
  in.static_point = ev.static_point();
  return in;
}

// The lab site's anchors (config/sites/lab.yaml): a 10 m x 8 m room.
std::vector<ReportAnchor> lab_anchors() {
  return {{"A1", 0, 0, true}, {"A2", 10, 0, true}, {"A3", 10, 8, true}, {"A4", 0, 8, true}};
}

size_t count(const std::string& haystack, const std::string& needle) {
  size_t n = 0;
  for (size_t pos = haystack.find(needle); pos != std::string::npos;
       pos = haystack.find(needle, pos + needle.size()))
    ++n;
  return n;
}

// The `points` of every <polyline class="cls">, parsed into pixel coordinates. (Not std::regex:
// libstdc++'s matcher recurses once per character, and a 2000-point attribute overflows the
// stack under ASan.)
std::vector<std::vector<Point>> polylines(const std::string& svg, const std::string& cls) {
  std::vector<std::vector<Point>> out;
  const std::string open = "<polyline class=\"" + cls + "\"";
  for (size_t at = svg.find(open); at != std::string::npos; at = svg.find(open, at + 1)) {
    const size_t end = svg.find('>', at);
    const size_t attr = svg.find("points=\"", at);
    std::vector<Point> pts;
    if (attr != std::string::npos && attr < end) {
      const size_t first = attr + 8, last = svg.find('"', first);
      std::istringstream in(svg.substr(first, last - first));
      std::string pair;
      while (in >> pair) {
        const size_t comma = pair.find(',');
        if (comma == std::string::npos) break;
        pts.push_back({std::stod(pair.substr(0, comma)), std::stod(pair.substr(comma + 1))});
      }
    }
    out.push_back(pts);
  }
  return out;
}

// A minimal XML well-formedness check (enough for what the report writes): one root element,
// balanced tags, quoted attributes without '<' and without duplicates, only the predefined and
// numeric entity references, and only printable ASCII or whitespace (the report promises ASCII,
// so no byte can be invalid UTF-8 or a character XML forbids).
bool well_formed_xml(const std::string& doc, std::string& why) {
  auto entity_ok = [&](const std::string& s, size_t amp) {
    static const std::regex ref("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
    return std::regex_search(s.begin() + static_cast<std::ptrdiff_t>(amp), s.end(), ref);
  };
  for (unsigned char c : doc)
    if (!(c == '\t' || c == '\n' || c == '\r' || (c >= 0x20 && c < 0x7f))) {
      why = "byte " + std::to_string(c);
      return false;
    }
  size_t i = 0;
  if (doc.compare(0, 5, "<?xml") == 0) i = doc.find("?>") + 2;
  std::vector<std::string> stack;
  int roots = 0;
  auto is_name = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
           c == '.';
  };
  while (i < doc.size()) {
    if (doc[i] != '<') {
      if (doc[i] == '&' && !entity_ok(doc, i))
        return why = "bad & in text at " + std::to_string(i), false;
      if (stack.empty() && !std::isspace(static_cast<unsigned char>(doc[i])))
        return why = "text outside the root", false;
      ++i;
      continue;
    }
    if (doc.compare(i, 4, "<!--") == 0) {
      i = doc.find("-->", i);
      if (i == std::string::npos) return why = "open comment", false;
      i += 3;
      continue;
    }
    if (doc.compare(i, 2, "</") == 0) {
      size_t j = i + 2;
      while (j < doc.size() && is_name(doc[j])) ++j;
      const std::string name = doc.substr(i + 2, j - i - 2);
      if (j >= doc.size() || doc[j] != '>') return why = "bad end tag " + name, false;
      if (stack.empty() || stack.back() != name) return why = "mismatched </" + name + ">", false;
      stack.pop_back();
      i = j + 1;
      continue;
    }
    size_t j = i + 1;
    while (j < doc.size() && is_name(doc[j])) ++j;
    const std::string name = doc.substr(i + 1, j - i - 1);
    if (name.empty()) return why = "'<' without a name at " + std::to_string(i), false;
    std::set<std::string> attrs;
    while (true) {
      while (j < doc.size() && std::isspace(static_cast<unsigned char>(doc[j]))) ++j;
      if (j >= doc.size()) return why = "open tag " + name, false;
      if (doc.compare(j, 2, "/>") == 0 || doc[j] == '>') break;
      const size_t a = j;
      while (j < doc.size() && is_name(doc[j])) ++j;
      const std::string attr = doc.substr(a, j - a);
      if (attr.empty() || j + 1 >= doc.size() || doc[j] != '=' ||
          (doc[j + 1] != '"' && doc[j + 1] != '\''))
        return why = "bad attribute in <" + name + "> at " + std::to_string(a), false;
      if (!attrs.insert(attr).second) return why = "duplicate attribute " + attr, false;
      const char quote = doc[j + 1];
      const size_t end = doc.find(quote, j + 2);
      if (end == std::string::npos) return why = "open attribute " + attr, false;
      for (size_t k = j + 2; k < end; ++k) {
        if (doc[k] == '<') return why = "'<' in attribute " + attr, false;
        if (doc[k] == '&' && !entity_ok(doc, k)) return why = "bad & in attribute " + attr, false;
      }
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

void expect_well_formed(const std::string& svg) {
  std::string why;
  EXPECT_TRUE(well_formed_xml(svg_document(svg), why)) << why;
}

TEST(CdfSteps, OneStepPerSampleFromZeroToOne) {
  // Three finite errors (the NaN is not a sample): y steps by 1/3 at each sorted error.
  const auto pts = cdf_steps({0.3, 0.1, NAN, 0.2}, 2000);
  const std::vector<Point> want = {{0.1, 0},       {0.1, 1 / 3.0}, {0.2, 1 / 3.0},
                                   {0.2, 2 / 3.0}, {0.3, 2 / 3.0}, {0.3, 1}};
  ASSERT_EQ(pts.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_DOUBLE_EQ(pts[i].x, want[i].x) << i;
    EXPECT_DOUBLE_EQ(pts[i].y, want[i].y) << i;
  }
  EXPECT_TRUE(cdf_steps({}, 2000).empty());
}

TEST(CdfSteps, DecimatedToEvenlySpacedRanksStillEndsAtOne) {
  std::vector<double> e;
  for (int i = 10000; i >= 1; --i) e.push_back(i * 1e-3);  // 0.001 .. 10 m, reversed
  const auto pts = cdf_steps(e, 2000);
  ASSERT_EQ(pts.size(), 2000u);  // 1000 steps of 10 samples
  EXPECT_DOUBLE_EQ(pts.front().y, 0.0);
  EXPECT_DOUBLE_EQ(pts.back().y, 1.0);
  EXPECT_DOUBLE_EQ(pts.back().x, 10.0);
  for (size_t i = 1; i < pts.size(); ++i) {
    EXPECT_GE(pts[i].y, pts[i - 1].y);
    EXPECT_GE(pts[i].x, pts[i - 1].x);
  }
  // Step 500 reaches rank 5000: the median sample, 5.000 m, at y 0.5.
  EXPECT_DOUBLE_EQ(pts[999].x, 5.0);
  EXPECT_DOUBLE_EQ(pts[999].y, 0.5);
}

TEST(DecimateMinMax, BoundsPointsAndKeepsTheWorstError) {
  std::vector<Point> pts;
  for (int i = 0; i < 100000; ++i) pts.push_back({i * 0.01, 0.1 + 0.01 * std::sin(i * 0.1)});
  pts[54321].y = 7.5;  // one wild estimate
  const auto out = decimate_min_max(pts, 2000);
  EXPECT_LE(out.size(), 2000u);
  EXPECT_GE(out.size(), 1000u);
  bool spike = false;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].y == 7.5 && out[i].x == pts[54321].x) spike = true;
    if (i > 0) {
      EXPECT_GT(out[i].x, out[i - 1].x);  // still in time order
    }
  }
  EXPECT_TRUE(spike);
  const std::vector<Point> few = {{0, 1}, {1, 2}};
  EXPECT_EQ(decimate_min_max(few, 2000).size(), 2u);
}

TEST(DecimateLttb, BoundsPointsKeepsEndsAndExtent) {
  // A 3 m circle walked 20 times, 100 000 points.
  std::vector<Point> pts;
  for (int i = 0; i < 100000; ++i) {
    const double a = 2 * std::numbers::pi * 20 * i / 100000.0;
    pts.push_back({3 * std::cos(a), 3 * std::sin(a)});
  }
  const auto out = decimate_lttb(pts, 2000);
  ASSERT_EQ(out.size(), 2000u);
  EXPECT_DOUBLE_EQ(out.front().x, pts.front().x);
  EXPECT_DOUBLE_EQ(out.back().x, pts.back().x);
  double x_max = -1e9, y_min = 1e9;
  for (const auto& p : out) x_max = std::max(x_max, p.x), y_min = std::min(y_min, p.y);
  EXPECT_NEAR(x_max, 3.0, 0.01);  // the shape's extent survives
  EXPECT_NEAR(y_min, -3.0, 0.01);
  EXPECT_EQ(decimate_lttb({{0, 0}, {1, 1}, {2, 0}}, 2000).size(), 3u);
}

TEST(NiceTicks, StepsOfOneTwoOrFive) {
  EXPECT_EQ(nice_ticks(-0.5, 10.5, 8), (std::vector<double>{0, 2, 4, 6, 8, 10}));
  EXPECT_EQ(nice_ticks(0, 1.05, 5), (std::vector<double>{0, 0.5, 1.0}));
  EXPECT_EQ(nice_ticks(0, 60, 8), (std::vector<double>{0, 10, 20, 30, 40, 50, 60}));
  EXPECT_TRUE(nice_ticks(1, 1, 5).empty());
  EXPECT_TRUE(nice_ticks(0, NAN, 5).empty());
}

TEST(MapFigure, PutsAnchorsAtTheirPixelsWithEqualScale) {
  ReportInput in;
  in.anchors = lab_anchors();
  // The frame: the anchors' box padded by 5 % of 10 m (0.5 m): x -0.5..10.5, y -0.5..8.5; one
  // scale min(640 / 11, 520 / 9) = 57.78 px/m; plot at (64, 28). So A1 (0, 0) is at
  // (64 + 0.5 * 57.78, 28 + 8.5 * 57.78) = (92.9, 519.1) and A3 (10, 8) at (670.7, 56.9).
  const PlotFrame f = map_frame(in);
  EXPECT_NEAR(f.to_px(0, 0).x, 92.9, 0.05);
  EXPECT_NEAR(f.to_px(0, 0).y, 519.1, 0.05);
  EXPECT_NEAR(f.to_px(10, 8).x, 670.7, 0.05);
  EXPECT_NEAR(f.to_px(10, 8).y, 56.9, 0.05);

  const std::string svg = build_report(in).map_svg;
  expect_well_formed(svg);
  std::map<std::string, Point> at;
  const std::regex anchor(
      "<circle class=\"anchor\" cx=\"([-0-9.]+)\" cy=\"([-0-9.]+)\"[^\\n]*"
      "<text class=\"anchor-id\"[^>]*>([^<]*)</text>");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), anchor); it != std::sregex_iterator();
       ++it)
    at[(*it)[3]] = {std::stod((*it)[1]), std::stod((*it)[2])};
  ASSERT_EQ(at.size(), 4u);
  EXPECT_NEAR(at["A1"].x, 92.9, 0.051);
  EXPECT_NEAR(at["A1"].y, 519.1, 0.051);
  EXPECT_NEAR(at["A3"].x, 670.7, 0.051);
  EXPECT_NEAR(at["A3"].y, 56.9, 0.051);
  // Equal scale: 10 m across and 8 m up are the same px per metre.
  EXPECT_NEAR((at["A2"].x - at["A1"].x) / 10, (at["A1"].y - at["A4"].y) / 8, 0.02);
  // The axes agree with the markers: tick "0" and "10" on x, "8" on y sit on the anchors.
  auto tick = [&](const std::string& cls, const std::string& label, int group) {
    const std::regex t("<text class=\"" + cls + "\" x=\"([-0-9.]+)\" y=\"([-0-9.]+)\"[^>]*>" +
                       label + "</text>");
    std::smatch m;
    return std::regex_search(svg, m, t) ? std::stod(m[group]) : NAN;
  };
  EXPECT_NEAR(tick("xtick", "0", 1), at["A1"].x, 0.051);
  EXPECT_NEAR(tick("xtick", "10", 1), at["A2"].x, 0.051);
  EXPECT_NEAR(tick("ytick", "8", 2), at["A4"].y, 0.051);
}

TEST(MapFigure, WideSiteKeepsEqualScale) {
  // A 30 m x 2 m corridor: padded by 5 % of 30 m (1.5 m) to x -1.5..31.5, y -1.5..3.5; the width
  // limits the scale, 640 / 33 = 19.39 px/m, so the plot is 640 x 97 px, not 640 x 520.
  ReportInput in;
  in.anchors = {{"A1", 0, 0, true}, {"A2", 30, 0, true}, {"A3", 30, 2, true}, {"A4", 0, 2, true}};
  const PlotFrame f = map_frame(in);
  EXPECT_NEAR(f.width, 640, 1e-9);
  EXPECT_NEAR(f.height, 5 * 640 / 33.0, 1e-9);
  const Point a1 = f.to_px(0, 0), a3 = f.to_px(30, 2);
  EXPECT_NEAR(a1.x, 64 + 1.5 * 640 / 33, 1e-9);
  EXPECT_NEAR(a1.y, 28 + 3.5 * 640 / 33, 1e-9);
  EXPECT_NEAR((a3.x - a1.x) / 30, (a1.y - a3.y) / 2, 1e-9);
}

TEST(Report, OnePolylinePerChannelAndTagInEveryFigure) {
  Evaluator ev;
  for (int i = 0; i <= 10; ++i) {
    ev.add_truth(pose(i * 1'000'000, "T1", i, 1, 1));
    ev.add_truth(pose(i * 1'000'000, "T2", i, 5, 1));
  }
  for (int i = 0; i < 10; ++i) {
    ev.add_estimate("POSE_UWB", pose(i * 1'000'000 + 500'000, "T1", i + 0.5, 1.1, 1));
    ev.add_estimate("POSE_UWB", pose(i * 1'000'000 + 500'000, "T2", i + 0.5, 5.2, 1));
    ev.add_estimate("POSE_FUSED", pose(i * 1'000'000 + 500'000, "T1", i + 0.5, 0.95, 1));
  }
  ReportInput in = input_from(ev);
  in.anchors = lab_anchors();
  const Report r = build_report(in);
  ASSERT_EQ(in.rows.size(), 3u);
  for (const auto* svg : {&r.map_svg, &r.error_time_svg, &r.error_cdf_svg})
    expect_well_formed(*svg);
  EXPECT_EQ(polylines(r.map_svg, "estimate").size(), 3u);
  EXPECT_EQ(polylines(r.map_svg, "truth").size(), 2u);  // one per tag
  EXPECT_EQ(polylines(r.error_time_svg, "error").size(), 3u);
  EXPECT_EQ(polylines(r.error_cdf_svg, "cdf").size(), 3u);
  EXPECT_EQ(count(r.map_svg, "<circle class=\"anchor\""), 4u);
  // Each error line has one point per scored estimate (10), each CDF two per step (20).
  for (const auto& l : polylines(r.error_time_svg, "error")) EXPECT_EQ(l.size(), 10u);
  for (const auto& l : polylines(r.error_cdf_svg, "cdf")) EXPECT_EQ(l.size(), 20u);
  // The page holds every figure inline, byte for byte, and nothing that loads or runs.
  EXPECT_NE(r.index_html.find(r.map_svg), std::string::npos);
  EXPECT_NE(r.index_html.find(r.error_time_svg), std::string::npos);
  EXPECT_NE(r.index_html.find(r.error_cdf_svg), std::string::npos);
  EXPECT_NE(r.index_html.find(r.height_svg), std::string::npos);
  EXPECT_EQ(r.index_html.find("<script"), std::string::npos);
  EXPECT_EQ(r.index_html.find("href="), std::string::npos);
  EXPECT_EQ(r.index_html.find("src="), std::string::npos);
}

TEST(Report, TableAndCepMarkersCarryTheEvaluatorsNumbers) {
  // evaluation_test's case: horizontal errors 0.5, 0.5, 0.5, 2.5 and vertical 0.2 each, so
  // mean 1.0, RMSE sqrt(7 / 4) = 1.323, median 0.5, p95 0.5 + 0.85 * 2 = 2.2, max 2.5.
  Evaluator ev;
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T", i, 0, 1));
  ev.add_estimate("POSE_A", pose(500'000, "T", 0.5 + 0.3, 0.4, 1.2));
  ev.add_estimate("POSE_A", pose(1'500'000, "T", 1.5 - 0.3, -0.4, 0.8));
  ev.add_estimate("POSE_A", pose(2'500'000, "T", 2.5, 0.5, 1.2));
  ev.add_estimate("POSE_A", pose(3'500'000, "T", 3.5 + 1.5, 2.0, 1.2));
  ev.add_estimate("POSE_A", pose(20'000'000, "T", 0, 0, 0));  // after truth: not scored
  const auto series = ev.estimate_series();
  ASSERT_EQ(series.size(), 1u);
  ASSERT_EQ(series[0].estimates.size(), 5u);
  EXPECT_NEAR(series[0].estimates[3].error_h, 2.5, 1e-12);
  EXPECT_TRUE(std::isnan(series[0].estimates[4].error_h));

  const Report r = build_report(input_from(ev));
  EXPECT_NE(r.index_html.find("<td>POSE_A</td><td>T</td><td>4</td><td>1.000</td><td>1.323</td>"
                              "<td>0.500</td><td>2.200</td><td>2.500</td><td>0.200</td>"),
            std::string::npos);
  // CDF frame: x 0..1.05 * 2.5 m on 640 px from 64, y 0..1 on 320 px from 28. CEP50 (0.5 m, 0.5)
  // is at (64 + 0.5 / 2.625 * 640, 28 + 160) = (185.9, 188.0); CEP95 (2.2 m, 0.95) at
  // (600.4, 44.0).
  EXPECT_NE(r.error_cdf_svg.find("<circle class=\"cep50\" cx=\"185.9\" cy=\"188.0\""),
            std::string::npos);
  EXPECT_NE(r.error_cdf_svg.find("<circle class=\"cep95\" cx=\"600.4\" cy=\"44.0\""),
            std::string::npos);
  const auto cdf = polylines(r.error_cdf_svg, "cdf");
  ASSERT_EQ(cdf.size(), 1u);
  ASSERT_EQ(cdf[0].size(), 8u);
  EXPECT_DOUBLE_EQ(cdf[0].front().y, 348.0);  // y = 0
  EXPECT_DOUBLE_EQ(cdf[0].back().y, 28.0);    // y = 1
  for (size_t i = 1; i < cdf[0].size(); ++i) EXPECT_LE(cdf[0][i].y, cdf[0][i - 1].y);
  // Error against time: t = 0 is the first truth sample; the 2.5 m error at 3.5 s.
  const auto err = polylines(r.error_time_svg, "error");
  ASSERT_EQ(err.size(), 1u);
  ASSERT_EQ(err[0].size(), 4u);
  // x 0..20 s on 640 px from 64: 3.5 s -> 176.0; y 0..2.625 m on 320 px: 2.5 m -> 43.2.
  EXPECT_NEAR(err[0][3].x, 176.0, 0.051);
  EXPECT_NEAR(err[0][3].y, 43.2, 0.051);
  EXPECT_NE(r.index_html.find("(20.0 s)"), std::string::npos);
  EXPECT_NE(r.index_html.find("2026-01-01 00:00:00.000 UTC"), std::string::npos);
}

TEST(Report, EscapesNamesFromTheLog) {
  const std::string channel = "a<b&\"c";
  const std::string tag = std::string("t'>\x01\xff") + "]]>";
  Evaluator ev;
  for (int i = 0; i <= 2; ++i) ev.add_truth(pose(i * 1'000'000, tag, i, 0, 0));
  ev.add_estimate(channel, pose(500'000, tag, 0.5, 0.1, 0));
  ReportInput in = input_from(ev);
  in.anchors = {{"<A1 x=\"1\">&", 0, 0, true}};
  in.log_path = "/tmp/<log>&.lcm";
  const Report r = build_report(in);
  for (const auto* svg : {&r.map_svg, &r.error_time_svg, &r.error_cdf_svg}) {
    expect_well_formed(*svg);
    EXPECT_EQ(svg->find(channel), std::string::npos);
    EXPECT_EQ(svg->find("<A1"), std::string::npos);
  }
  EXPECT_NE(r.map_svg.find("a&lt;b&amp;&quot;c / t&#39;&gt;\\x01\\xff]]&gt;"), std::string::npos);
  EXPECT_NE(r.map_svg.find("&lt;A1 x=&quot;1&quot;&gt;&amp;"), std::string::npos);
  EXPECT_EQ(r.index_html.find(channel), std::string::npos);
  EXPECT_NE(r.index_html.find("<td>a&lt;b&amp;&quot;c</td>"), std::string::npos);
  EXPECT_NE(r.index_html.find("<code>/tmp/&lt;log&gt;&amp;.lcm</code>"), std::string::npos);
  EXPECT_EQ(xml_text("x\ny"), "x\\x0ay");
}

TEST(Report, LongSeriesAreDecimatedInEveryFigure) {
  // One hour at 10 Hz of one tag: 36 000 estimates and truth samples.
  Evaluator ev;
  for (int i = 0; i < 36000; ++i) {
    const double a = i * 0.01;
    ev.add_truth(pose(i * 100'000LL, "T1", 5 + 3 * std::cos(a), 4 + 3 * std::sin(a), 1));
    ev.add_estimate("POSE_UWB", pose(i * 100'000LL, "T1", 5 + 3 * std::cos(a) + 0.1 * std::sin(i),
                                     4 + 3 * std::sin(a), 1));
  }
  const Report r = build_report(input_from(ev));
  const auto lines = {polylines(r.map_svg, "estimate"), polylines(r.map_svg, "truth"),
                      polylines(r.error_time_svg, "error"), polylines(r.error_cdf_svg, "cdf")};
  for (const auto& l : lines) {
    ASSERT_EQ(l.size(), 1u);
    EXPECT_LE(l[0].size(), 2000u);
    EXPECT_GE(l[0].size(), 1000u);
  }
  EXPECT_LT(r.index_html.size(), 500'000u);
  ReportOptions small;
  small.max_points_per_series = 100;
  for (const auto& l : polylines(build_report(input_from(ev), small).error_cdf_svg, "cdf"))
    EXPECT_EQ(l.size(), 100u);
}

TEST(Report, WithoutEstimatesThePageSaysSo) {
  ReportInput in;
  in.log_path = "empty.lcm";
  const Report r = build_report(in);
  for (const auto* svg : {&r.map_svg, &r.error_time_svg, &r.error_cdf_svg, &r.height_svg})
    expect_well_formed(*svg);
  EXPECT_NE(r.index_html.find("No pose estimates in this log"), std::string::npos);
  EXPECT_NE(r.error_cdf_svg.find("no pose estimates in this log"), std::string::npos);
  EXPECT_EQ(count(r.map_svg, "<polyline"), 0u);
  EXPECT_EQ(count(r.index_html, "<svg"), 4u);
  EXPECT_NE(r.height_svg.find("no pose estimates in this log"), std::string::npos);

  // Estimates but no truth around them: drawn on the map, nothing scored.
  Evaluator ev;
  ev.add_estimate("POSE_UWB", pose(0, "T1", 1, 2, 0));
  const Report unscored = build_report(input_from(ev));
  EXPECT_NE(unscored.index_html.find("No estimate has truth around it"), std::string::npos);
  EXPECT_EQ(polylines(unscored.map_svg, "estimate").size(), 1u);
  EXPECT_TRUE(polylines(unscored.error_cdf_svg, "cdf").at(0).empty());
}

TEST(Report, StaticPointModeDrawsTheKnownPointInsteadOfTruth) {
  Evaluator ev;
  ev.set_static_point({2.186, 3.369, 0}, false);  // aoa-hall-static-1
  ev.add_truth(pose(0, "T1", 9, 9, 0));
  ev.add_estimate("POSE_AOA", pose(0, "T1", 2.0, 3.0, 0));
  ev.add_estimate("POSE_AOA", pose(100'000, "T1", 2.3, 3.5, 0));
  const ReportInput in = input_from(ev);
  const Report r = build_report(in);
  expect_well_formed(r.map_svg);
  EXPECT_EQ(polylines(r.map_svg, "truth").size(), 0u);
  const Point q = map_frame(in).to_px(2.186, 3.369);
  char want[96];
  std::snprintf(want, sizeof want, "class=\"static-point\" transform=\"translate(%.1f,%.1f)\"", q.x,
                q.y);
  EXPECT_NE(r.map_svg.find(want), std::string::npos) << want;
  EXPECT_NE(r.index_html.find("Static-point mode"), std::string::npos);
  EXPECT_EQ(polylines(r.error_cdf_svg, "cdf").at(0).size(), 4u);
}

TEST(Report, ChannelAndAltitudeTablesInNaturalOrder) {
  Evaluator ev;
  for (int i = 0; i <= 2; ++i)
    for (const char* tag : {"T1-10", "T1-2", "T1"}) ev.add_truth(pose(i * 1'000'000, tag, 0, 0, 1));
  for (const char* tag : {"T1-10", "T1-2", "T1"}) {
    ev.add_estimate("POSE_UWB", pose(1'000'000, tag, 3, 4, 1));  // error 5 for every tag
    ev.add_altitude("ALTITUDE", testing::altitude(1'000'000, tag, 1.25));  // 0.25 above
  }
  ReportInput in = input_from(ev);
  in.channel_rows = ev.rows_by_channel();
  in.altitude_rows = ev.altitude_rows();
  const Report r = build_report(in);
  const std::string& h = r.index_html;
  // The statistics table and the altitude table list T1, T1-2, T1-10 in that order.
  for (const std::string cls : {"<table>", "<table class=\"altitude\">"}) {
    const size_t table = h.find(cls);
    ASSERT_NE(table, std::string::npos) << cls;
    const size_t t1 = h.find("<td>T1</td>", table), t2 = h.find("<td>T1-2</td>", table),
                 t10 = h.find("<td>T1-10</td>", table);
    EXPECT_LT(t1, t2) << cls;
    EXPECT_LT(t2, t10) << cls;
  }
  EXPECT_NE(h.find("<td>POSE_UWB</td><td>3</td><td>3</td><td>5.000</td><td>5.000</td>"),
            std::string::npos);
  EXPECT_NE(h.find("<td>ALTITUDE</td><td>T1</td><td>1</td><td>0.250</td><td>0.250</td>"),
            std::string::npos);
}

// The lab's channels at the quality the issue describes: two good ones a few cm apart and one
// 100 times worse (a drifting PDR). Every estimate of a channel has the same horizontal error.
Evaluator one_channel_far_worse() {
  Evaluator ev;
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T1", i, 0, 1));
  for (int i = 0; i < 10; ++i) {
    const utime_t t = i * 1'000'000 + 500'000;
    const double dz = i % 2 ? 1 : -1;  // heights that move: 0.02 m and 0.03 m off
    ev.add_estimate("POSE_FUSED", pose(t, "T1", i + 0.5, 0.05, 1 + 0.02 * dz));
    ev.add_estimate("POSE_UWB", pose(t, "T1", i + 0.5, 0.08, 1 + 0.03 * dz));
    ev.add_estimate("POSE_PDR", planar_pose(t, "T1", i + 0.5, 6.0, 1));
  }
  return ev;
}

TEST(Report, AChannelFarWorseIsListedOffScaleAndTheCdfAxisIsLogarithmic) {
  const Evaluator ev = one_channel_far_worse();
  const ReportInput in = input_from(ev);
  const ErrorScale scale = error_scale(in);
  ASSERT_EQ(in.series.size(), 3u);  // POSE_FUSED, POSE_PDR, POSE_UWB
  EXPECT_EQ(scale.off_scale, (std::vector<bool>{false, true, false}));
  EXPECT_NEAR(scale.best_rmse, 0.05, 1e-12);
  EXPECT_TRUE(scale.log_cdf);
  const Report r = build_report(in);
  for (const auto* svg : {&r.map_svg, &r.error_time_svg, &r.error_cdf_svg})
    expect_well_formed(*svg);

  // Error against time: only the two good channels drawn, the axis zoomed to them (0.08 m *
  // 1.05: ticks 0 to 0.08 every 0.02), POSE_PDR in the legend with its RMSE and a note.
  const auto err = polylines(r.error_time_svg, "error");
  ASSERT_EQ(err.size(), 2u);
  EXPECT_EQ(r.error_time_svg.find("data-channel=\"POSE_PDR\""), std::string::npos);
  EXPECT_NE(r.error_time_svg.find(">0.08</text>"), std::string::npos);
  EXPECT_EQ(r.error_time_svg.find(">0.10</text>"), std::string::npos);
  EXPECT_NE(r.error_time_svg.find("class=\"off-scale\""), std::string::npos);
  EXPECT_NE(r.error_time_svg.find("POSE_PDR / T1  off scale: RMSE 6.000 m"), std::string::npos);
  EXPECT_NE(r.error_time_svg.find("<text class=\"off-scale-note\""), std::string::npos);
  EXPECT_NE(r.error_time_svg.find("1 series off scale, not drawn (RMSE over 5 x the best, "
                                  "0.050 m)"),
            std::string::npos);
  EXPECT_NE(r.index_html.find("Off scale, not drawn: <code>POSE_PDR / T1</code> (RMSE 6.000 m)"),
            std::string::npos);
  // 0.05 m at y 0.05 / 0.084 of 320 px up from 348.
  EXPECT_NEAR(err[0][0].y, 348 - 0.05 / 0.084 * 320, 0.051);

  // The CDF: every channel, on a log axis from 0.05 m (the best 5th percentile, down to 1, 2 or
  // 5 times a power of ten) to 10 m (6 m up likewise), ticks at 1, 2 and 5 per decade.
  EXPECT_EQ(polylines(r.error_cdf_svg, "cdf").size(), 3u);
  EXPECT_NE(r.error_cdf_svg.find("data-x-scale=\"log\""), std::string::npos);
  EXPECT_NE(r.error_cdf_svg.find("horizontal error (m, log scale)"), std::string::npos);
  EXPECT_EQ(log_ticks(0.05, 10), (std::vector<double>{0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10}));
  for (const char* label :
       {">0.05</text>", ">0.1</text>", ">0.2</text>", ">1</text>", ">10</text>"})
    EXPECT_NE(r.error_cdf_svg.find(label), std::string::npos) << label;
  // CEP50 of each channel where log10(e / 0.05) / log10(10 / 0.05) of the 640 px puts it.
  for (double e : {0.05, 0.08, 6.0}) {
    char want[80];
    std::snprintf(want, sizeof want, "<circle class=\"cep50\" cx=\"%.1f\" cy=\"188.0\"",
                  64 + std::log10(e / 0.05) / std::log10(10 / 0.05) * 640);
    EXPECT_NE(r.error_cdf_svg.find(want), std::string::npos) << want;
  }
  EXPECT_NE(r.index_html.find("The error axis is logarithmic"), std::string::npos);

  // Channels within 5 times of each other: nothing off scale, linear axes.
  Evaluator close;
  for (int i = 0; i <= 2; ++i) close.add_truth(pose(i * 1'000'000, "T1", i, 0, 1));
  close.add_estimate("POSE_FUSED", pose(500'000, "T1", 0.5, 0.05, 1));
  close.add_estimate("POSE_UWB", pose(500'000, "T1", 0.5, 0.24, 1));
  const Report plain = build_report(input_from(close));
  EXPECT_EQ(polylines(plain.error_time_svg, "error").size(), 2u);
  EXPECT_EQ(plain.error_time_svg.find("off-scale"), std::string::npos);
  EXPECT_EQ(plain.error_cdf_svg.find("data-x-scale"), std::string::npos);
  EXPECT_EQ(plain.index_html.find("Off scale"), std::string::npos);
}

TEST(Report, ChannelsHaveTheirSharedColourAndTagsADashPattern) {
  Evaluator ev = one_channel_far_worse();
  for (int i = 0; i < 10; ++i)
    ev.add_estimate("POSE_FUSED", pose(i * 1'000'000 + 500'000, "T2", i, 0, 1));
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T2", i, 0, 1));
  ReportInput in = input_from(ev);
  const Report r = build_report(in);
  // POSE_FUSED red, POSE_UWB blue, POSE_PDR brown, as in ips-view (core/channel_colours).
  EXPECT_EQ(channel_colour("POSE_FUSED"), "#d62728");
  for (const auto* svg : {&r.map_svg, &r.error_cdf_svg}) {
    EXPECT_NE(svg->find("data-channel=\"POSE_FUSED\" data-tag=\"T1\" stroke=\"#d62728\" points"),
              std::string::npos);
    EXPECT_NE(svg->find("data-channel=\"POSE_FUSED\" data-tag=\"T2\" stroke=\"#d62728\" "
                        "stroke-dasharray=\"6 3\""),
              std::string::npos);
    EXPECT_NE(svg->find("data-channel=\"POSE_UWB\" data-tag=\"T1\" stroke=\"#1f77b4\""),
              std::string::npos);
    EXPECT_NE(svg->find("data-channel=\"POSE_PDR\" data-tag=\"T1\" stroke=\"#8c564b\""),
              std::string::npos);
  }
  EXPECT_NE(r.error_time_svg.find("data-channel=\"POSE_UWB\" data-tag=\"T1\" stroke=\"#1f77b4\""),
            std::string::npos);
  EXPECT_NE(r.error_cdf_svg.find("r=\"3.5\" fill=\"#d62728\""), std::string::npos);
  EXPECT_NE(r.index_html.find("<span class=\"swatch\" style=\"background:#d62728\"></span></td>"
                              "<td>POSE_FUSED</td><td>T1</td>"),
            std::string::npos);
  EXPECT_NE(r.index_html.find("<span class=\"swatch\" style=\"background:#d62728\"></span></td>"
                              "<td>POSE_FUSED</td><td>T2</td>"),
            std::string::npos);
  // Truth is TRUTH's black.
  EXPECT_NE(r.map_svg.find("class=\"truth-tracks\" clip-path=\"url(#map-clip)\" fill=\"none\" "
                           "stroke=\"#000\""),
            std::string::npos);
}

TEST(Report, HeightsOfTwoDimensionalAndFixedHeightSeriesAreADash) {
  // POSE_PDR is STATUS_2D; INS_MODULE keeps one z (a fixed height); POSE_FUSED's z moves.
  Evaluator ev = one_channel_far_worse();
  for (int i = 0; i < 10; ++i)
    ev.add_estimate("INS_MODULE", pose(i * 1'000'000 + 500'000, "T1", i + 0.5, 0.1, 1.3));
  ReportInput in = input_from(ev);
  in.channel_rows = ev.rows_by_channel();
  const Report r = build_report(in);
  // The statistics table: vertical RMSE (the 10th cell) "-", then the non-finite count.
  for (const char* channel : {"INS_MODULE", "POSE_PDR"}) {
    const size_t row = r.index_html.find(std::string("<td>") + channel + "</td><td>T1</td>");
    ASSERT_NE(row, std::string::npos) << channel;
    const size_t end = r.index_html.find("</tr>", row);
    EXPECT_NE(r.index_html.substr(row, end - row).find("<td>-</td><td>0</td>"), std::string::npos)
        << r.index_html.substr(row, end - row);
  }
  EXPECT_NE(r.index_html.find("<td>POSE_FUSED</td><td>T1</td><td>10</td><td>0.050</td>"
                              "<td>0.050</td><td>0.050</td><td>0.050</td><td>0.050</td>"
                              "<td>0.020</td><td>0</td>"),
            std::string::npos);
  // The per-channel table likewise.
  const size_t ins = r.index_html.find("<td>INS_MODULE</td><td>1</td><td>10</td>");
  ASSERT_NE(ins, std::string::npos);
  EXPECT_NE(r.index_html.substr(ins, r.index_html.find("</tr>", ins) - ins).find("<td>-</td>"),
            std::string::npos);
}

TEST(Report, HeightFigureDrawsOnlyEstimatedHeights) {
  Evaluator ev;
  for (int i = 0; i <= 10; ++i) ev.add_truth(pose(i * 1'000'000, "T1", i, 0, 1));
  for (int i = 0; i < 10; ++i) {
    const utime_t t = i * 1'000'000 + 500'000;
    ev.add_estimate("POSE_3D", pose(t, "T1", i + 0.5, 0.1, i % 2 ? 1.2 : 1.0));
    ev.add_estimate("POSE_PDR", planar_pose(t, "T1", i + 0.5, 0.2, 1));
    ev.add_estimate("INS_MODULE", pose(t, "T1", i + 0.5, 0.3, 1.3));  // one fixed z
    ev.add_altitude("ALTITUDE", testing::altitude(t, "T1", 1.1));
  }
  ReportInput in = input_from(ev);
  in.altitude_series = ev.altitude_series();
  const Report r = build_report(in);
  expect_well_formed(r.height_svg);
  const auto heights = polylines(r.height_svg, "height");
  ASSERT_EQ(heights.size(), 1u);
  EXPECT_NE(r.height_svg.find("class=\"height\" data-channel=\"POSE_3D\""), std::string::npos);
  EXPECT_EQ(polylines(r.height_svg, "altitude").size(), 1u);
  EXPECT_EQ(polylines(r.height_svg, "truth-height").size(), 1u);
  EXPECT_EQ(r.height_svg.find("data-channel=\"POSE_PDR\""), std::string::npos);
  EXPECT_EQ(r.height_svg.find("data-channel=\"INS_MODULE\""), std::string::npos);
  // They are named in the legend instead.
  EXPECT_EQ(count(r.height_svg, "class=\"no-height\""), 2u);
  EXPECT_NE(r.height_svg.find("POSE_PDR / T1  no height estimated"), std::string::npos);
  EXPECT_NE(r.height_svg.find("INS_MODULE / T1  no height estimated"), std::string::npos);
  // Heights 1.0 to 1.2 m padded to 1 m tall: 0.6 to 1.6 m on 320 px from 28; 1.2 m at 156.0.
  ASSERT_EQ(heights[0].size(), 10u);
  EXPECT_NEAR(heights[0][1].y, 156.0, 0.051);
  EXPECT_NEAR(heights[0][0].y, 28 + 0.6 * 320, 0.051);
  EXPECT_EQ(count(r.index_html, "<svg"), 4u);
}

}  // namespace
}  // namespace ips::eval
