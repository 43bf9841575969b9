#pragma once
// The floor map of ips-view as one SVG element, for the live page and for offline rendering: the
// site in metres with y up (the SVG's y axis flipped), a grid every metre (coarser when the map
// is large) with labelled axes, anchors with their ids (ble_aoa ones with an arrow along their
// boresight, the anchor's yaw), and per channel and tag the latest estimate in the channel's
// colour (channel_colours(): TRUTH black) with its covariance ellipse and its trail, and a legend
// of channels; the site's floor plan under it all, its zones, a visible title, the time and a
// scale bar. Pure: a ViewModel in, a string out; the same model gives the same bytes (tracks
// in sorted order, anchors in the site's order, fixed number formatting).
//
// Every string that came off the air (tag, anchor and channel ids, sources, the site name) goes
// through xml_text(), so a tag named <script> is text, never markup.
#include <Eigen/Core>
#include <string>

#include "core/text_escape.hpp"
#include <string_view>
#include <vector>

#include "viewer-headless/view_model.hpp"

namespace ips::view {

using ips::xml_text;

struct SvgOptions {
  double margin_m = 1.0;      // around the anchors and tracks
  double max_width_px = 900;  // the map (legend aside) fits in this box
  double max_height_px = 700;
  double max_pixels_per_m = 120;  // a small scene is not blown up further
  double ellipse_sigma = 2.0;     // covariance ellipses at this many sigmas; 0: none
  bool trails = true;
  std::string title;  // empty: "ips-view" and the site's name
  std::string time_text;  // drawn at the top right ("at 30.0 s of the log"); empty: none
  // The floor drawn: its plan, its zones and the tracks on it (tracks of unknown floor too);
  // kNoFloor: the lowest floor's plan, every zone and every track.
  int floor = kNoFloor;
};

// The map's extent in metres and its mapping to pixels (one scale for x and y).
struct MapFrame {
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;  // m, site frame
  double pixels_per_m = 1;
  double left = 0, top = 0;  // px of the corner (x_min, y_max)
  double width_px() const { return (x_max - x_min) * pixels_per_m; }
  double height_px() const { return (y_max - y_min) * pixels_per_m; }
  // y up in metres, down in pixels.
  Eigen::Vector2d to_px(double x, double y) const {
    return {left + (x - x_min) * pixels_per_m, top + (y_max - y) * pixels_per_m};
  }
};

// The box around every anchor and every track position (latest and trail), each track point
// limited to max(5 m, half the anchors' extent) beyond the anchors' box (a wild estimate must not
// shrink the site to a dot: it is drawn clipped) and to 1e9 m from the origin, then widened to
// at least 1 m and padded by margin_m; scaled to fit max_width_px x max_height_px.
MapFrame map_frame(const ViewModel& model, const SvgOptions& options);

// Grid spacing for an extent: 1 m, or the next 2, 5 or 10 times a power of ten that keeps the
// grid to at most 50 lines.
double grid_step_m(double extent_m);

std::string render_svg(const ViewModel& model, const SvgOptions& options = {});


}  // namespace ips::view
