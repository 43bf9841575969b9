#include "viewer-headless/svg_render.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <numbers>

#include "core/channels.hpp"
#include "core/svg_text.hpp"
#include "core/text_escape.hpp"

namespace ips::view {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// Layout, px.
constexpr double kMarginLeft = 52, kMarginTop = 28, kMarginBottom = 44, kLegendGap = 24;
constexpr double kLegendRow = 18, kCharWidth = 7, kMinLabelSpacing = 32;
constexpr double kMarkerRadius = 4.5, kAoaArrowLength = 26;
constexpr double kMaxRadiusPx = 1e6;  // a huge covariance is clipped, its number kept short
constexpr size_t kLabelMaxChars = 40;
constexpr double kMaxGridLines = 50;
// Track points further out than this do not extend the map (sites are within 1e6 m).
constexpr double kMaxCoordinateM = 1e9;

using svg::format;
using svg::px;

// Cut, then escaped: an entity is never cut in half.
std::string label_text(std::string_view s) { return xml_text(svg::short_label(s, kLabelMaxChars)); }


std::string ellipse_svg(const Ellipse& e, const Eigen::Vector2d& c, double pixels_per_m,
                        const std::string& colour) {
  const double rx = std::min(e.semi_major_m * pixels_per_m, kMaxRadiusPx);
  const double ry = std::min(e.semi_minor_m * pixels_per_m, kMaxRadiusPx);
  // Counter-clockwise in the site frame is clockwise on the flipped page: rotate by -angle.
  const double angle_deg = -e.angle_rad * kRadToDeg;
  return "<ellipse class=\"cov\" cx=\"" + px(c.x()) + "\" cy=\"" + px(c.y()) + "\" rx=\"" +
         format("%.2f", rx) + "\" ry=\"" + format("%.2f", ry) + "\" transform=\"rotate(" +
         format("%.2f", angle_deg + 0.0) + " " + px(c.x()) + " " + px(c.y()) + ")\" stroke=\"" +
         colour + "\"/>\n";
}

std::string axes(const MapFrame& f) {
  std::string s;
  const double step = grid_step_m(std::max(f.x_max - f.x_min, f.y_max - f.y_min));
  const double bottom = f.top + f.height_px(), right = f.left + f.width_px();
  // Label every n-th line so labels stay kMinLabelSpacing px apart.
  const auto every = static_cast<long long>(
      std::clamp(std::ceil(kMinLabelSpacing / (step * f.pixels_per_m)), 1.0, 1e9));
  const auto first_x = static_cast<long long>(std::ceil(f.x_min / step));
  const auto last_x = static_cast<long long>(std::floor(f.x_max / step));
  const auto first_y = static_cast<long long>(std::ceil(f.y_min / step));
  const auto last_y = static_cast<long long>(std::floor(f.y_max / step));
  const auto label = [&](long long k) {
    return format("%.0f", static_cast<double>(k) * step + 0.0);  // + 0.0: never "-0"
  };

  std::string labels;
  s += "<g class=\"grid\" stroke=\"#e4e4e4\" stroke-width=\"1\">\n";
  for (long long k = first_x; k <= last_x; ++k) {
    const double x = f.to_px(static_cast<double>(k) * step, 0).x();
    s += "<line x1=\"" + px(x) + "\" y1=\"" + px(f.top) + "\" x2=\"" + px(x) + "\" y2=\"" +
         px(bottom) + "\"/>\n";
    if (k % every == 0)
      labels += "<text class=\"xtick\" x=\"" + px(x) + "\" y=\"" + px(bottom + 16) +
                "\" text-anchor=\"middle\">" + label(k) + "</text>\n";
  }
  for (long long k = first_y; k <= last_y; ++k) {
    const double y = f.to_px(0, static_cast<double>(k) * step).y();
    s += "<line x1=\"" + px(f.left) + "\" y1=\"" + px(y) + "\" x2=\"" + px(right) + "\" y2=\"" +
         px(y) + "\"/>\n";
    if (k % every == 0)
      labels += "<text class=\"ytick\" x=\"" + px(f.left - 6) + "\" y=\"" + px(y) +
                "\" dy=\"0.32em\" text-anchor=\"end\">" + label(k) + "</text>\n";
  }
  s += "</g>\n<rect class=\"frame\" x=\"" + px(f.left) + "\" y=\"" + px(f.top) + "\" width=\"" +
       px(f.width_px()) + "\" height=\"" + px(f.height_px()) +
       "\" fill=\"none\" stroke=\"#444\"/>\n";
  s += "<g class=\"axes\" fill=\"#333\">\n" + labels;
  s += "<text x=\"" + px(f.left + f.width_px() / 2) + "\" y=\"" + px(bottom + 34) +
       "\" text-anchor=\"middle\">x (m)</text>\n";
  s += "<text transform=\"translate(" + px(f.left - 38) + "," + px(f.top + f.height_px() / 2) +
       ") rotate(-90)\" text-anchor=\"middle\">y (m)</text>\n</g>\n";
  return s;
}

}  // namespace

double grid_step_m(double extent_m) {
  double step = 1;
  if (!std::isfinite(extent_m)) return step;
  for (double decade = 1; extent_m / step > kMaxGridLines; decade *= 10) {
    for (double m : {2.0, 5.0, 10.0}) {
      step = m * decade;
      if (extent_m / step <= kMaxGridLines) break;
    }
  }
  return step;
}

MapFrame map_frame(const ViewModel& model, const SvgOptions& options) {
  svg::Bounds anchors;
  for (const Anchor& a : model.anchors()) anchors.add(a.position.x(), a.position.y());
  svg::Bounds box = anchors;
  // Track points beyond the anchors' box by more than `reach` are pulled in to it.
  const double reach = anchors.valid()
                           ? std::max(5.0, 0.5 * std::max(anchors.x_max - anchors.x_min,
                                                          anchors.y_max - anchors.y_min))
                           : 0;
  const auto add_track_point = [&](double x, double y) {
    x = std::clamp(x, -kMaxCoordinateM, kMaxCoordinateM);
    y = std::clamp(y, -kMaxCoordinateM, kMaxCoordinateM);
    if (anchors.valid()) {
      x = std::clamp(x, anchors.x_min - reach, anchors.x_max + reach);
      y = std::clamp(y, anchors.y_min - reach, anchors.y_max + reach);
    }
    box.add(x, y);
  };
  // The plans and zones belong to the site: the box holds them whole.
  for (const Floor& fl : model.layout().floors) {
    if (!fl.plan || fl.plan->data_uri.empty()) continue;
    const FloorPlan& p = *fl.plan;
    const Eigen::Rotation2Dd r(p.rotation_rad);
    for (const Eigen::Vector2d& c : {Eigen::Vector2d(0, 0), Eigen::Vector2d(p.size_m.x(), 0),
                                     Eigen::Vector2d(0, p.size_m.y()), p.size_m}) {
      const Eigen::Vector2d w = p.origin + r * c;
      box.add(w.x(), w.y());
    }
  }
  for (const Zone& z : model.layout().zones)
    for (const Eigen::Vector2d& v : z.polygon) box.add(v.x(), v.y());
  for (const auto& [k, t] : model.tracks()) {
    add_track_point(t.position.x(), t.position.y());
    if (options.trails)
      for (const auto& p : t.trail.points()) add_track_point(p.x(), p.y());
  }
  if (!box.valid()) box.add(0, 0);
  // At least 1 m across, then the margin.
  const double margin = std::isfinite(options.margin_m) ? std::max(0.0, options.margin_m) : 0.0;
  const double grow_x = std::max(0.0, 1.0 - (box.x_max - box.x_min)) / 2 + margin;
  const double grow_y = std::max(0.0, 1.0 - (box.y_max - box.y_min)) / 2 + margin;

  MapFrame f;
  f.x_min = box.x_min - grow_x, f.x_max = box.x_max + grow_x;
  f.y_min = box.y_min - grow_y, f.y_max = box.y_max + grow_y;
  f.pixels_per_m =
      std::min({options.max_width_px / (f.x_max - f.x_min),
                options.max_height_px / (f.y_max - f.y_min), options.max_pixels_per_m});
  if (!(f.pixels_per_m > 0) || !std::isfinite(f.pixels_per_m)) f.pixels_per_m = 1;
  f.left = kMarginLeft;
  f.top = kMarginTop;
  return f;
}

std::string render_svg(const ViewModel& model, const SvgOptions& options) {
  const MapFrame f = map_frame(model, options);
  const auto channels = model.pose_channels();
  // A track of another floor is not drawn (one of unknown floor is).
  const auto on_floor = [&](const Track& t) {
    if (options.floor == kNoFloor) return true;
    const int fl = model.track_floor(t);
    return fl == kNoFloor || fl == options.floor;
  };
  const auto colours = channel_colours(channels);
  bool any_aoa = false;
  for (const Anchor& a : model.anchors()) any_aoa = any_aoa || a.kind == "ble_aoa";

  // Legend rows: anchors, then one per channel.
  struct Row {
    std::string marker;  // SVG around (0, 0)
    std::string text;    // escaped
  };
  std::vector<Row> legend;
  const std::string anchor_marker = "<path d=\"M0,-6 L6,5 L-6,5 Z\" fill=\"#222\"/>";
  if (!model.anchors().empty()) legend.push_back({anchor_marker, "anchor"});
  if (any_aoa)
    legend.push_back(
        {"<line x1=\"-8\" y1=\"0\" x2=\"8\" y2=\"0\" stroke=\"#555\" "
         "stroke-width=\"1.5\" marker-end=\"url(#aoa-arrow)\"/>",
         "ble_aoa boresight (yaw)"});
  for (const auto& c : channels)
    legend.push_back({"<line x1=\"-12\" y1=\"0\" x2=\"12\" y2=\"0\" stroke=\"" + colours.at(c) +
                          "\" stroke-width=\"2\"/><circle r=\"" + px(kMarkerRadius) + "\" fill=\"" +
                          colours.at(c) + "\"/>",
                      label_text(c)});
  size_t legend_chars = 0;
  for (const auto& r : legend) legend_chars = std::max(legend_chars, r.text.size());
  const bool has_ellipses = options.ellipse_sigma > 0 && !channels.empty();
  const std::string ellipse_note =
      has_ellipses ? "ellipses: " + format("%g", options.ellipse_sigma) + "-sigma" : "";
  legend_chars = std::max(legend_chars, ellipse_note.size());

  const double legend_x = f.left + f.width_px() + kLegendGap;
  const double width =
      legend_x + (legend.empty() ? 0 : 36 + kCharWidth * static_cast<double>(legend_chars)) + 8;
  const double legend_rows = static_cast<double>(legend.size() + (has_ellipses ? 1 : 0));
  const double height =
      std::max(f.top + f.height_px() + kMarginBottom, kMarginTop + kLegendRow * legend_rows + 10);

  const std::string title =
      options.title.empty()
          ? "ips-view" + (model.site_name().empty() ? "" : ": " + label_text(model.site_name()))
          : xml_text(options.title);

  std::string s;
  s.reserve(8192 + model.tracks().size() * (512 + 16 * model.options().trail_length));
  s += svg::open(width, height, title);
  s += "<defs><clipPath id=\"map-clip\"><rect x=\"" + px(f.left) + "\" y=\"" + px(f.top) +
       "\" width=\"" + px(f.width_px()) + "\" height=\"" + px(f.height_px()) +
       "\"/></clipPath><marker id=\"aoa-arrow\" viewBox=\"0 0 8 8\" refX=\"7\" refY=\"4\" "
       "markerWidth=\"7\" markerHeight=\"7\" orient=\"auto\"><path d=\"M0,0 L8,4 L0,8 Z\" "
       "fill=\"#555\"/></marker></defs>\n";
  // The plan of the floor drawn (or the lowest floor's), under everything.
  const Floor* plan_floor = nullptr;
  for (const Floor& fl : model.layout().floors) {
    if (options.floor != kNoFloor ? fl.index == options.floor
                                  : (plan_floor == nullptr && fl.plan.has_value()))
      plan_floor = &fl;
  }
  if (plan_floor && plan_floor->plan && !plan_floor->plan->data_uri.empty()) {
    const FloorPlan& p = *plan_floor->plan;
    const Eigen::Vector2d q = f.to_px(p.origin.x(), p.origin.y());
    const double w = p.size_m.x() * f.pixels_per_m, h = p.size_m.y() * f.pixels_per_m;
    // data_uri holds only base64 characters after its checked prefix: nothing to escape.
    s += "<image class=\"plan\" clip-path=\"url(#map-clip)\" x=\"" + px(q.x()) + "\" y=\"" +
         px(q.y() - h) + "\" width=\"" + px(w) + "\" height=\"" + px(h) +
         "\" preserveAspectRatio=\"none\" opacity=\"0.55\" transform=\"rotate(" +
         format("%.3f", -p.rotation_rad * kRadToDeg) + " " + px(q.x()) + " " + px(q.y()) +
         ")\" href=\"" + xml_text(p.data_uri) + "\"/>\n";
  }
  s += axes(f);
  if (!model.layout().zones.empty()) {
    s += "<g class=\"zones\" clip-path=\"url(#map-clip)\">\n";
    for (const Zone& z : model.layout().zones) {
      if (options.floor != kNoFloor && z.floor && *z.floor != options.floor) continue;
      std::string points;
      Eigen::Vector2d centre = Eigen::Vector2d::Zero();
      for (const Eigen::Vector2d& v : z.polygon) {
        const Eigen::Vector2d q = f.to_px(v.x(), v.y());
        points += (points.empty() ? "" : " ") + px(q.x()) + "," + px(q.y());
        centre += q / static_cast<double>(z.polygon.size());
      }
      s += "<polygon class=\"zone\" points=\"" + points +
           "\" fill=\"#ffc107\" fill-opacity=\"0.15\" stroke=\"#f9a825\" stroke-width=\"1.5\" "
           "stroke-dasharray=\"5 3\"><title>" + label_text(z.name) + "</title></polygon>"
           "<text class=\"zone-name\" x=\"" + px(centre.x()) + "\" y=\"" + px(centre.y()) +
           "\" text-anchor=\"middle\" fill=\"#8d6e00\" font-size=\"11\">" + label_text(z.name) +
           "</text>\n";
    }
    s += "</g>\n";
  }
  // The title and the time, visible above the map.
  s += "<text class=\"title\" x=\"" + px(f.left) + "\" y=\"18\" font-size=\"14\" "
       "font-weight=\"bold\" fill=\"#222\">" + title + "</text>\n";
  if (!options.time_text.empty())
    s += "<text class=\"map-time\" x=\"" + px(f.left + f.width_px()) + "\" y=\"18\" "
         "text-anchor=\"end\" fill=\"#444\">" + xml_text(options.time_text) + "</text>\n";

  if (options.trails) {
    s += "<g class=\"trails\" clip-path=\"url(#map-clip)\" fill=\"none\" stroke-width=\"1.2\" "
         "stroke-opacity=\"0.6\">\n";
    for (const auto& [k, t] : model.tracks()) {
      if (!on_floor(t)) continue;
      const auto pts = t.trail.points();
      if (pts.size() < 2) continue;
      std::string points;
      points.reserve(pts.size() * 12);
      for (const auto& p : pts) {
        const Eigen::Vector2d q = f.to_px(p.x(), p.y());
        if (!points.empty()) points += ' ';
        points += px(q.x()) + "," + px(q.y());
      }
      s += "<polyline class=\"trail\" stroke=\"" + colours.at(t.channel) + "\" points=\"" + points +
           "\"/>\n";
    }
    s += "</g>\n";
  }

  if (options.ellipse_sigma > 0) {
    s += "<g class=\"ellipses\" clip-path=\"url(#map-clip)\" fill=\"none\" stroke-width=\"1\" "
         "stroke-dasharray=\"4 2\">\n";
    for (const auto& [k, t] : model.tracks())
      if (!on_floor(t)) continue;
      else if (const auto e = covariance_ellipse(t.cov_xy, options.ellipse_sigma))
        s += ellipse_svg(*e, f.to_px(t.position.x(), t.position.y()), f.pixels_per_m,
                         colours.at(t.channel));
    s += "</g>\n";
  }

  s += "<g class=\"anchors\">\n";
  for (const Anchor& a : model.anchors()) {
    if (!a.position.head<2>().allFinite()) continue;
    const Eigen::Vector2d q = f.to_px(a.position.x(), a.position.y());
    // The circle's (cx, cy) is the anchor's pixel; the triangle is drawn around it.
    s += "<circle class=\"anchor\" cx=\"" + px(q.x()) + "\" cy=\"" + px(q.y()) +
         "\" r=\"2\" fill=\"#222\"/><path transform=\"translate(" + px(q.x()) + "," + px(q.y()) +
         ")\" d=\"M0,-6 L6,5 L-6,5 Z\" fill=\"" + (a.enabled ? "#222" : "none") +
         "\" fill-opacity=\"0.6\" stroke=\"#222\"/>";
    if (a.kind == "ble_aoa") {
      // Boresight along the mounting's yaw, counter-clockwise from +x (y flipped on the page).
      const double yaw = a.orientation_rad.z();
      s += "<line class=\"aoa-axis\" x1=\"" + px(q.x()) + "\" y1=\"" + px(q.y()) + "\" x2=\"" +
           px(q.x() + kAoaArrowLength * std::cos(yaw)) + "\" y2=\"" +
           px(q.y() - kAoaArrowLength * std::sin(yaw)) +
           "\" stroke=\"#555\" stroke-width=\"1.5\" marker-end=\"url(#aoa-arrow)\"/>";
    }
    s += "<text class=\"anchor-id\" x=\"" + px(q.x() + 8) + "\" y=\"" + px(q.y() + 15) + "\">" +
         label_text(a.id) + (a.enabled ? "" : " (disabled)") + "</text>\n";
  }
  s += "</g>\n";

  s += "<g class=\"estimates\" clip-path=\"url(#map-clip)\">\n";
  for (const auto& [k, t] : model.tracks()) {
    if (!on_floor(t)) continue;
    const std::string& colour = colours.at(t.channel);
    const Eigen::Vector2d q = f.to_px(t.position.x(), t.position.y());
    // Hollow while the estimator is not OK or coasting: the eye sees which tracks are live.
    const bool solid =
        (t.status & pose_t::STATUS_OK) != 0 && (t.status & pose_t::STATUS_COASTING) == 0;
    s += "<circle class=\"estimate\" cx=\"" + px(q.x()) + "\" cy=\"" + px(q.y()) + "\" r=\"" +
         px(kMarkerRadius) + "\" fill=\"" + (solid ? colour : std::string("#fff")) +
         "\" stroke=\"" + colour + "\" stroke-width=\"1.5\"><title>" + label_text(t.channel) + " " +
         label_text(t.tag) + " (" + label_text(t.source) + ")</title></circle>";
    s += "<text class=\"tag-id\" x=\"" + px(q.x() + 7) + "\" y=\"" + px(q.y() - 7) + "\" fill=\"" +
         colour + "\">" + label_text(t.tag) + "</text>\n";
  }
  s += "</g>\n";

  if (model.anchors().empty() && model.tracks().empty())
    s += "<text class=\"no-data\" x=\"" + px(f.left + f.width_px() / 2) + "\" y=\"" +
         px(f.top + f.height_px() / 2) +
         "\" text-anchor=\"middle\" fill=\"#a00\">no site and no estimates yet</text>\n";

  // A scale bar in the map's bottom left corner.
  // About 80 px long: 1, 2 or 5 times a power of ten metres.
  double bar_m = std::pow(10.0, std::floor(std::log10(80.0 / f.pixels_per_m)));
  for (const double m : {1.0, 2.0, 5.0, 10.0})
    if (m * bar_m * f.pixels_per_m >= 80.0) {
      bar_m *= m;
      break;
    }
  const double bar_px = bar_m * f.pixels_per_m;
  const double bar_x = f.left + 10, bar_y = f.top + f.height_px() - 12;
  s += "<g class=\"scale-bar\"><path d=\"M" + px(bar_x) + " " + px(bar_y) + "h" + px(bar_px) +
       "M" + px(bar_x) + " " + px(bar_y - 5) + "v10M" + px(bar_x + bar_px) + " " +
       px(bar_y - 5) + "v10\" stroke=\"#222\" stroke-width=\"2\" fill=\"none\"/><text x=\"" +
       px(bar_x) + "\" y=\"" + px(bar_y - 8) + "\" fill=\"#222\">" +
       (bar_m >= 1 ? format("%g m", bar_m) : format("%g cm", bar_m * 100)) + "</text></g>\n";

  s += "<g class=\"legend\">\n";
  for (size_t i = 0; i < legend.size(); ++i) {
    const double y = kMarginTop + 6 + kLegendRow * static_cast<double>(i);
    s += "<g transform=\"translate(" + px(legend_x + 14) + "," + px(y) + ")\">" + legend[i].marker +
         "</g><text x=\"" + px(legend_x + 36) + "\" y=\"" + px(y) + "\" dy=\"0.32em\">" +
         legend[i].text + "</text>\n";
  }
  if (has_ellipses)
    s += "<text x=\"" + px(legend_x) + "\" y=\"" +
         px(kMarginTop + 6 + kLegendRow * static_cast<double>(legend.size())) +
         "\" dy=\"0.32em\" fill=\"#555\">" + ellipse_note + "</text>\n";
  s += "</g>\n</svg>";
  return s;
}

}  // namespace ips::view
