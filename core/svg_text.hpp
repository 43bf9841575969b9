#pragma once
// Pieces shared by the SVG figures (ips-eval's report, ips-view's floor map): number formatting,
// the document head, a bounding box, and labels from the air cut to a length. Escaping itself
// is xml_text() (core/text_escape.hpp).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <string_view>

#include "core/text_escape.hpp"

namespace ips::svg {

// One number through a printf format ("%.2f", "%g", ...).
inline std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

// A pixel coordinate with one decimal. Far off-figure points keep their direction but not a
// 300-digit coordinate (they are clipped anyway).
inline std::string px(double v) { return format("%.1f", std::clamp(v, -1e7, 1e7)); }

// The SVG head: size, the figure's title (already escaped), a white background.
inline std::string open(double width, double height, const std::string& title_escaped) {
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + px(width) + "\" height=\"" +
         px(height) + "\" viewBox=\"0 0 " + px(width) + " " + px(height) +
         "\" font-family=\"sans-serif\" font-size=\"12\">\n<title>" + title_escaped +
         "</title>\n<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n";
}

// The box around the finite points added.
struct Bounds {
  double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min;
  double y_min = x_min, y_max = -x_min;
  void add(double x, double y) {
    if (!std::isfinite(x) || !std::isfinite(y)) return;
    x_min = std::min(x_min, x), x_max = std::max(x_max, x);
    y_min = std::min(y_min, y), y_max = std::max(y_max, y);
  }
  bool valid() const { return x_min <= x_max && y_min <= y_max; }
};

// printable(), then cut to max_chars with "..." (not yet XML-escaped: escape after cutting, so
// that an entity is never cut in half).
inline std::string short_label(std::string_view s, size_t max_chars) {
  std::string p = printable(s);
  if (p.size() > max_chars) p = p.substr(0, max_chars - 3) + "...";
  return p;
}

}  // namespace ips::svg
