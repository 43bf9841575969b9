#include "loggers/eval/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <tuple>
#include <utility>

#include "core/channel_colours.hpp"
#include "core/svg_text.hpp"
#include "core/text_escape.hpp"

namespace ips::eval {
namespace {

// A channel's colour is the same as in ips-view (core/channel_colours); its tags take these dash
// patterns in turn, so every channel and tag is still its own line.
constexpr const char* kDashes[] = {"", "6 3", "2 2", "8 3 2 3"};
constexpr size_t kDashCount = sizeof kDashes / sizeof kDashes[0];
constexpr double kMinBestRmse = 0.01;  // m: see kOffScaleRatio
constexpr size_t kLabelMaxChars = 40;  // legend labels; the table shows the full names

// Figure layout, px.
constexpr double kMarginLeft = 64, kMarginTop = 28, kMarginBottom = 48, kLegendGap = 24;
constexpr double kLegendRow = 18, kCharWidth = 7;
constexpr double kMapMaxWidth = 640, kMapMaxHeight = 520;
constexpr double kPlotWidth = 640, kPlotHeight = 320;

using svg::format;
using svg::px;

// A number for the table: 3 decimals like the text table, "-" where nothing was measured.
std::string table_number(double v) { return std::isfinite(v) ? format("%.3f", v) : "-"; }

std::string tick_label(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, std::abs(v) < step * 1e-6 ? 0.0 : v);
  return buf;
}

std::string series_label(const std::string& channel, const std::string& tag) {
  return svg::short_label(channel + " / " + tag, kLabelMaxChars);
}

struct SeriesStyle {
  std::string colour;
  const char* dash;
};

// Per ReportInput::series: its channel's colour, and a dash pattern by its tag's place among the
// channel's tags (series come sorted by channel, then tag).
// The colour of every channel on the page.
std::map<std::string, std::string> report_colours(const ReportInput& in) {
  std::vector<std::string> channels;
  for (const auto& s : in.series) channels.push_back(s.channel);
  for (const auto& r : in.rows) channels.push_back(r.channel);
  for (const auto& a : in.altitude_series) channels.push_back(a.channel);
  return channel_colours(channels);
}

std::vector<SeriesStyle> series_styles(const ReportInput& in) {
  const auto colours = report_colours(in);
  std::vector<SeriesStyle> styles;
  std::map<std::string, size_t> tags_so_far;
  for (const auto& s : in.series)
    styles.push_back({colours.at(s.channel), kDashes[tags_so_far[s.channel]++ % kDashCount]});
  return styles;
}

std::string stroke_style(const SeriesStyle& st) {
  std::string s = "stroke=\"" + st.colour + "\"";
  if (*st.dash) s += std::string(" stroke-dasharray=\"") + st.dash + "\"";
  return s;
}

// Attributes naming a figure's series, for readers of the SVG (and the tests).
std::string series_attrs(const EstimateSeries& s) {
  return "data-channel=\"" + xml_text(s.channel) + "\" data-tag=\"" + xml_text(s.tag) + "\"";
}

std::string points_attr(const std::vector<Point>& pts, const PlotFrame& f) {
  std::string s;
  s.reserve(pts.size() * 12);
  for (const auto& p : pts) {
    const Point q = f.to_px(p.x, p.y);
    if (!s.empty()) s += ' ';
    s += px(q.x) + "," + px(q.y);
  }
  return s;
}

using TruthTracks = std::map<std::string, std::vector<PositionSample>>;
const TruthTracks& truth_of(const ReportInput& in) {
  static const TruthTracks kNone;
  return in.truth ? *in.truth : kNone;
}

using Bounds = svg::Bounds;

struct LegendEntry {
  std::string label;       // already printable, not yet escaped
  std::string line_style;  // attributes of the sample line, empty for a marker entry
  std::string marker;      // SVG of a marker centred at (0, 0), used when line_style is empty
  std::string text_class = {};  // the label's class, if any
};


// Frame, grid, ticks with labels, axis titles and a clip path `clip_id` for the data.
std::string axes(const PlotFrame& f, const std::vector<double>& xt, const std::vector<double>& yt,
                 const std::string& x_title, const std::string& y_title,
                 const std::string& clip_id) {
  std::string s;
  s += "<defs><clipPath id=\"" + clip_id + "\"><rect x=\"" + px(f.left) + "\" y=\"" + px(f.top) +
       "\" width=\"" + px(f.width) + "\" height=\"" + px(f.height) + "\"/></clipPath></defs>\n";
  s += "<g class=\"grid\" stroke=\"#e4e4e4\" stroke-width=\"1\">\n";
  const double bottom = f.top + f.height, right = f.left + f.width;
  for (double v : xt) {
    const double x = f.to_px(v, f.y_min).x;
    s += "<line x1=\"" + px(x) + "\" y1=\"" + px(f.top) + "\" x2=\"" + px(x) + "\" y2=\"" +
         px(bottom) + "\"/>\n";
  }
  for (double v : yt) {
    const double y = f.to_px(f.x_min, v).y;
    s += "<line x1=\"" + px(f.left) + "\" y1=\"" + px(y) + "\" x2=\"" + px(right) + "\" y2=\"" +
         px(y) + "\"/>\n";
  }
  // data-x-scale tells a reader of the SVG how to map the tick labels' pixels back to values.
  s += "</g>\n<rect class=\"frame\" x=\"" + px(f.left) + "\" y=\"" + px(f.top) + "\" width=\"" +
       px(f.width) + "\" height=\"" + px(f.height) + "\" fill=\"none\" stroke=\"#444\"" +
       (f.log_x ? " data-x-scale=\"log\"" : "") + "/>\n";
  const double x_step = xt.size() > 1 ? xt[1] - xt[0] : 1;
  const double y_step = yt.size() > 1 ? yt[1] - yt[0] : 1;
  // A tick label's x (or y) attribute is exactly the pixel of its value.
  for (double v : xt) {
    const double x = f.to_px(v, f.y_min).x;
    s += "<line x1=\"" + px(x) + "\" y1=\"" + px(bottom) + "\" x2=\"" + px(x) + "\" y2=\"" +
         px(bottom + 5) + "\" stroke=\"#444\"/><text class=\"xtick\" x=\"" + px(x) + "\" y=\"" +
         px(bottom + 18) + "\" text-anchor=\"middle\">" + tick_label(v, f.log_x ? v : x_step) +
         "</text>\n";
  }
  for (double v : yt) {
    const double y = f.to_px(f.x_min, v).y;
    s += "<line x1=\"" + px(f.left - 5) + "\" y1=\"" + px(y) + "\" x2=\"" + px(f.left) +
         "\" y2=\"" + px(y) + "\" stroke=\"#444\"/><text class=\"ytick\" x=\"" + px(f.left - 8) +
         "\" y=\"" + px(y) + "\" dy=\"0.32em\" text-anchor=\"end\">" + tick_label(v, y_step) +
         "</text>\n";
  }
  s += "<text x=\"" + px(f.left + f.width / 2) + "\" y=\"" + px(bottom + 38) +
       "\" text-anchor=\"middle\">" + x_title + "</text>\n";
  s += "<text transform=\"translate(" + px(f.left - 46) + "," + px(f.top + f.height / 2) +
       ") rotate(-90)\" text-anchor=\"middle\">" + y_title + "</text>\n";
  return s;
}

double legend_width(const std::vector<LegendEntry>& entries) {
  size_t chars = 0;
  for (const auto& e : entries) chars = std::max(chars, e.label.size());
  return entries.empty() ? 0 : 40 + kCharWidth * static_cast<double>(chars) + 12;
}

std::string legend(const std::vector<LegendEntry>& entries, double x, double y) {
  if (entries.empty()) return "";
  std::string s = "<g class=\"legend\">\n";
  for (size_t i = 0; i < entries.size(); ++i) {
    const auto& e = entries[i];
    const double row_y = y + kLegendRow * static_cast<double>(i);
    if (!e.line_style.empty())
      s += "<line x1=\"" + px(x) + "\" y1=\"" + px(row_y) + "\" x2=\"" + px(x + 28) + "\" y2=\"" +
           px(row_y) + "\" stroke-width=\"2\" " + e.line_style + "/>";
    else
      s += "<g transform=\"translate(" + px(x + 14) + "," + px(row_y) + ")\">" + e.marker + "</g>";
    s += "<text" + (e.text_class.empty() ? "" : " class=\"" + e.text_class + "\"") + " x=\"" +
         px(x + 36) + "\" y=\"" + px(row_y) + "\" dy=\"0.32em\">" + xml_text(e.label) + "</text>\n";
  }
  return s + "</g>\n";
}

double canvas_height(const PlotFrame& f, size_t legend_rows) {
  return std::max(f.top + f.height + kMarginBottom,
                  kMarginTop + kLegendRow * static_cast<double>(legend_rows) + 10);
}

std::string no_data_note(const PlotFrame& f, const std::string& text) {
  return "<text class=\"no-data\" x=\"" + px(f.left + f.width / 2) + "\" y=\"" +
         px(f.top + f.height / 2) + "\" text-anchor=\"middle\" fill=\"#a00\" font-size=\"16\">" +
         text + "</text>\n";
}

// The end of both error figures: a note when there is nothing to plot, the legend, </svg>.
std::string close_error_figure(const ReportInput& in, const PlotFrame& f,
                               const std::vector<LegendEntry>& entries) {
  std::string s;
  if (in.series.empty())
    s += no_data_note(f, "no pose estimates in this log");
  else if (std::none_of(in.rows.begin(), in.rows.end(),
                        [](const ErrorRow& r) { return r.count > 0; }))
    s += no_data_note(f, "no estimate has truth around it: nothing scored");
  s += legend(entries, f.left + f.width + kLegendGap, kMarginTop + 6);
  return s + "</svg>";
}

// First and last utime over truth and estimates; {0, 0} when there is none.
std::pair<utime_t, utime_t> time_span(const ReportInput& in) {
  utime_t lo = std::numeric_limits<utime_t>::max(), hi = std::numeric_limits<utime_t>::min();
  auto add = [&](utime_t t) {
    if (!plausible_utime(t)) return;
    lo = std::min(lo, t), hi = std::max(hi, t);
  };
  for (const auto& [tag, track] : truth_of(in))
    for (const auto& p : track) add(p.utime);
  for (const auto& s : in.series)
    for (const auto& e : s.estimates) add(e.utime);
  if (lo > hi) return {0, 0};
  return {lo, hi};
}

const ErrorRow* find_row(const ReportInput& in, const EstimateSeries& s) {
  for (const auto& r : in.rows)
    if (r.channel == s.channel && r.tag == s.tag) return &r;
  return nullptr;
}

std::vector<double> finite_errors(const EstimateSeries& s) {
  std::vector<double> e;
  e.reserve(s.estimates.size());
  for (const auto& x : s.estimates)
    if (std::isfinite(x.error_h)) e.push_back(x.error_h);
  return e;
}

std::string map_figure(const ReportInput& in, const ReportOptions& opt) {
  const PlotFrame f = map_frame(in);
  const auto xt = nice_ticks(f.x_min, f.x_max, std::max(2, static_cast<int>(f.width / 80)));
  const auto yt = nice_ticks(f.y_min, f.y_max, std::max(2, static_cast<int>(f.height / 80)));

  std::vector<LegendEntry> entries;
  const std::string anchor_marker =
      "<path d=\"M0,-6 L6,5 L-6,5 Z\" fill=\"#222\"/>";  // a triangle, like a site plan
  if (!in.anchors.empty()) entries.push_back({"anchor", "", anchor_marker});
  if (in.static_point)
    entries.push_back(
        {"known point (static-point mode)", "",
         "<path d=\"M-6,-6 L6,6 M-6,6 L6,-6\" stroke=\"#000\" stroke-width=\"2.5\"/>"});
  else if (!in.dwell.empty())
    entries.push_back(
        {"known points (dwell intervals)", "",
         "<path d=\"M-6,-6 L6,6 M-6,6 L6,-6\" stroke=\"#000\" stroke-width=\"2.5\"/>"});
  else if (!truth_of(in).empty())
    entries.push_back({"truth (" + printable(in.truth_channel) + ")",
                       "stroke=\"#000\" stroke-opacity=\"0.55\"", ""});
  const auto styles = series_styles(in);
  for (size_t i = 0; i < in.series.size(); ++i)
    entries.push_back(
        {series_label(in.series[i].channel, in.series[i].tag), stroke_style(styles[i]), ""});

  const double width = f.left + f.width + kLegendGap + legend_width(entries) + 8;
  const double height = canvas_height(f, entries.size());
  std::string s = svg::open(width, height, "Map: anchors, truth and estimated tracks");
  s += axes(f, xt, yt, "x (m)", "y (m)", "map-clip");

  const bool known_points = in.static_point || !in.dwell.empty();
  s += "<g class=\"truth-tracks\" clip-path=\"url(#map-clip)\" fill=\"none\" stroke=\"#000\" "
       "stroke-opacity=\"0.55\" stroke-width=\"2\">\n";
  if (!known_points) {
    for (const auto& [tag, track] : truth_of(in)) {
      std::vector<Point> pts;
      pts.reserve(track.size());
      for (const auto& p : track) pts.push_back({p.x, p.y});
      pts = decimate_lttb(pts, opt.max_points_per_series);
      s += "<polyline class=\"truth\" points=\"" + points_attr(pts, f) + "\"/>\n";
    }
  }
  s += "</g>\n";

  s += "<g class=\"estimates\" clip-path=\"url(#map-clip)\" fill=\"none\" stroke-width=\"1.2\" "
       "stroke-opacity=\"0.85\">\n";
  for (size_t i = 0; i < in.series.size(); ++i) {
    std::vector<Point> pts;
    pts.reserve(in.series[i].estimates.size());
    for (const auto& e : in.series[i].estimates)
      if (std::isfinite(e.x) && std::isfinite(e.y)) pts.push_back({e.x, e.y});
    pts = decimate_lttb(pts, opt.max_points_per_series);
    s += "<polyline class=\"estimate\" " + series_attrs(in.series[i]) + " " +
         stroke_style(styles[i]) + " points=\"" + points_attr(pts, f) + "\"/>\n";
  }
  s += "</g>\n";

  // Labels last, so the tracks do not hide them.
  if (!in.dwell.empty()) {
    for (const auto& d : in.dwell) {
      if (!std::isfinite(d.x) || !std::isfinite(d.y)) continue;
      const Point q = f.to_px(d.x, d.y);
      s += "<path class=\"dwell-point\" transform=\"translate(" + px(q.x) + "," + px(q.y) +
           ")\" d=\"M-6,-6 L6,6 M-6,6 L6,-6\" stroke=\"#000\" stroke-width=\"2.5\"/>\n";
    }
  } else if (!in.static_point) {
    for (const auto& [tag, track] : truth_of(in)) {
      if (track.empty()) continue;
      const Point q = f.to_px(track.front().x, track.front().y);
      s += "<text class=\"truth-label\" x=\"" + px(q.x + 6) + "\" y=\"" + px(q.y - 6) + "\">" +
           xml_text(tag) + "</text>\n";
    }
  } else {
    const Point q = f.to_px(in.static_point->x(), in.static_point->y());
    s += "<path class=\"static-point\" transform=\"translate(" + px(q.x) + "," + px(q.y) +
         ")\" d=\"M-6,-6 L6,6 M-6,6 L6,-6\" stroke=\"#000\" stroke-width=\"2.5\"/>\n";
  }
  s += "<g class=\"anchors\">\n";
  for (const auto& a : in.anchors) {
    if (!std::isfinite(a.x) || !std::isfinite(a.y)) continue;
    const Point q = f.to_px(a.x, a.y);
    // The marker's (cx, cy) is the anchor's pixel; the triangle is drawn around it.
    s += "<circle class=\"anchor\" cx=\"" + px(q.x) + "\" cy=\"" + px(q.y) + "\" r=\"2\" fill=\"" +
         (a.enabled ? "#222" : "#fff") + "\" stroke=\"#222\"/><path transform=\"translate(" +
         px(q.x) + "," + px(q.y) + ")\" d=\"M0,-6 L6,5 L-6,5 Z\" fill=\"" +
         (a.enabled ? "#222" : "none") + "\" fill-opacity=\"0.6\" stroke=\"#222\"/>";
    s += "<text class=\"anchor-id\" x=\"" + px(q.x + 8) + "\" y=\"" + px(q.y + 14) + "\">" +
         xml_text(a.id) + (a.enabled ? "" : " (disabled)") + "</text>\n";
  }
  s += "</g>\n";
  if (in.anchors.empty() && truth_of(in).empty() && in.series.empty() && !known_points)
    s += no_data_note(f, "no anchors, truth or estimates in this log");
  s += legend(entries, f.left + f.width + kLegendGap, kMarginTop + 6);
  return s + "</svg>";
}

std::string error_time_figure(const ReportInput& in, const ReportOptions& opt,
                              const ErrorScale& scale) {
  const auto [t0, t1] = time_span(in);
  std::vector<std::vector<Point>> lines;
  double e_max = 0;  // over the series drawn
  for (size_t i = 0; i < in.series.size(); ++i) {
    std::vector<Point> pts;
    if (!scale.off_scale[i])
      for (const auto& e : in.series[i].estimates)
        if (std::isfinite(e.error_h) && plausible_utime(e.utime))
          pts.push_back({static_cast<double>(e.utime - t0) * 1e-6, e.error_h});
    for (const auto& p : pts) e_max = std::max(e_max, p.y);
    lines.push_back(decimate_min_max(pts, opt.max_points_per_series));
  }
  PlotFrame f;
  f.left = kMarginLeft, f.top = kMarginTop, f.width = kPlotWidth, f.height = kPlotHeight;
  f.x_max = std::max(1.0, static_cast<double>(t1 - t0) * 1e-6);
  f.y_max = e_max > 0 ? e_max * 1.05 : 1.0;
  const auto xt = nice_ticks(f.x_min, f.x_max, 8);
  const auto yt = nice_ticks(f.y_min, f.y_max, 5);

  const auto styles = series_styles(in);
  std::vector<LegendEntry> entries;
  size_t off = 0;
  for (size_t i = 0; i < in.series.size(); ++i) {
    const std::string label = series_label(in.series[i].channel, in.series[i].tag);
    if (!scale.off_scale[i]) {
      entries.push_back({label, stroke_style(styles[i]), ""});
      continue;
    }
    ++off;
    const ErrorRow* r = find_row(in, in.series[i]);
    entries.push_back({label + format("  off scale: RMSE %.3f m", r ? r->rmse_h : kNotMeasured),
                       stroke_style(styles[i]) + " stroke-opacity=\"0.4\"", "", "off-scale"});
  }
  const double width = f.left + f.width + kLegendGap + legend_width(entries) + 8;
  std::string s =
      svg::open(width, canvas_height(f, entries.size()), "Horizontal error against time");
  s += axes(f, xt, yt, "time since the first truth or estimate (s)", "horizontal error (m)",
            "error-time-clip");
  s += "<g class=\"errors\" clip-path=\"url(#error-time-clip)\" fill=\"none\" "
       "stroke-width=\"1.2\">\n";
  for (size_t i = 0; i < lines.size(); ++i)
    if (!scale.off_scale[i])
      s += "<polyline class=\"error\" " + series_attrs(in.series[i]) + " " +
           stroke_style(styles[i]) + " points=\"" + points_attr(lines[i], f) + "\"/>\n";
  s += "</g>\n";
  if (off > 0)
    s += "<text class=\"off-scale-note\" x=\"" + px(f.left + f.width - 6) + "\" y=\"" +
         px(f.top + 16) + "\" text-anchor=\"end\" fill=\"#a00\">" + std::to_string(off) +
         " series" + format(" off scale, not drawn (RMSE over %g x ", kOffScaleRatio) +
         format("the best, %.3f m): see the legend", scale.best_rmse) + "</text>\n";
  return s + close_error_figure(in, f, entries);
}

// The largest of 1, 2, 5 times a power of ten at or below v (v > 0), or with up the smallest at
// or above it.
double round_125(double v, bool up) {
  const double mag = std::pow(10.0, std::floor(std::log10(v)));
  if (up) {
    for (double m : {1.0, 2.0, 5.0})
      if (m * mag >= v * (1 - 1e-9)) return m * mag;
    return 10 * mag;
  }
  for (double m : {5.0, 2.0, 1.0})
    if (m * mag <= v * (1 + 1e-9)) return m * mag;
  return mag;
}

std::string error_cdf_figure(const ReportInput& in, const ReportOptions& opt,
                             const ErrorScale& scale) {
  std::vector<std::vector<Point>> steps;
  double e_max = 0;
  // Log axis: from the smallest 5th percentile of any series (the few smallest errors of a
  // series say little and would stretch the axis over empty decades; an estimator that starts
  // at truth and drifts has a few near 0), at least 1 mm.
  double e_low = std::numeric_limits<double>::infinity();
  for (const auto& s : in.series) {
    std::vector<double> e = finite_errors(s);
    if (!e.empty()) {
      std::vector<double> sorted = e;
      std::sort(sorted.begin(), sorted.end());
      e_low = std::min(e_low, sorted[sorted.size() / 20]);
    }
    steps.push_back(cdf_steps(std::move(e), opt.max_points_per_series));
    if (!steps.back().empty()) e_max = std::max(e_max, steps.back().back().x);
  }
  PlotFrame f;
  f.left = kMarginLeft, f.top = kMarginTop, f.width = kPlotWidth, f.height = kPlotHeight;
  std::vector<double> xt;
  if (scale.log_cdf && e_max > 0) {
    f.log_x = true;
    f.x_min = round_125(std::clamp(e_low, 1e-3, e_max), false);
    f.x_max = round_125(e_max, true);
    if (f.x_max <= f.x_min) f.x_max = f.x_min * 10;
    xt = log_ticks(f.x_min, f.x_max);
  } else {
    f.x_max = e_max > 0 ? e_max * 1.05 : 1.0;
    xt = nice_ticks(f.x_min, f.x_max, 8);
  }
  const std::vector<double> yt = {0, 0.2, 0.4, 0.6, 0.8, 1.0};

  const auto styles = series_styles(in);
  std::vector<LegendEntry> entries;
  for (size_t i = 0; i < in.series.size(); ++i) {
    std::string label = series_label(in.series[i].channel, in.series[i].tag);
    const ErrorRow* r = find_row(in, in.series[i]);
    if (r && r->count > 0)
      label += format("  CEP50 %.3f m", r->cep50()) + format(", CEP95 %.3f m", r->cep95());
    else
      label += "  (not scored)";
    entries.push_back({label, stroke_style(styles[i]), ""});
  }
  const double width = f.left + f.width + kLegendGap + legend_width(entries) + 8;
  std::string s = svg::open(width, canvas_height(f, entries.size()),
                           "Horizontal error CDF with CEP50 and CEP95");
  s += axes(f, xt, yt, f.log_x ? "horizontal error (m, log scale)" : "horizontal error (m)",
            "fraction of estimates", "error-cdf-clip");
  // CEP50 and CEP95 are where each curve crosses these lines; the dots mark them.
  for (const auto& [level, name] : {std::pair{0.5, "CEP50"}, std::pair{0.95, "CEP95"}}) {
    const double y = f.to_px(0, level).y;
    s += "<line class=\"cep-level\" x1=\"" + px(f.left) + "\" y1=\"" + px(y) + "\" x2=\"" +
         px(f.left + f.width) + "\" y2=\"" + px(y) +
         "\" stroke=\"#888\" stroke-dasharray=\"4 3\"/><text x=\"" + px(f.left + f.width - 4) +
         "\" y=\"" + px(y - 4) + "\" text-anchor=\"end\" fill=\"#555\">" + name + "</text>\n";
  }
  s += "<g class=\"cdfs\" clip-path=\"url(#error-cdf-clip)\" fill=\"none\" stroke-width=\"1.5\">\n";
  for (size_t i = 0; i < steps.size(); ++i)
    s += "<polyline class=\"cdf\" " + series_attrs(in.series[i]) + " " + stroke_style(styles[i]) +
         " points=\"" + points_attr(steps[i], f) + "\"/>\n";
  s += "</g>\n<g class=\"ceps\">\n";
  for (size_t i = 0; i < in.series.size(); ++i) {
    const ErrorRow* r = find_row(in, in.series[i]);
    if (!r || r->count == 0) continue;
    for (const auto& [level, v, cls] :
         {std::tuple{0.5, r->cep50(), "cep50"}, std::tuple{0.95, r->cep95(), "cep95"}}) {
      const Point q = f.to_px(v, level);
      s += std::string("<circle class=\"") + cls + "\" cx=\"" + px(q.x) + "\" cy=\"" + px(q.y) +
           "\" r=\"3.5\" fill=\"" + styles[i].colour + "\" stroke=\"#fff\"/>\n";
    }
  }
  s += "</g>\n";
  return s + close_error_figure(in, f, entries);
}

// Height against time: truth's z per tag, every pose series that estimates a height, every
// ALTITUDE series; the series without a height (2D, or one fixed z) are named in the legend only.
std::string height_figure(const ReportInput& in, const ReportOptions& opt) {
  const auto [t0, t1] = time_span(in);
  auto seconds = [t0 = t0](utime_t t) { return static_cast<double>(t - t0) * 1e-6; };
  Bounds b;  // x: s, y: m
  std::vector<std::vector<Point>> truth_lines, pose_lines, altitude_lines;
  const bool known_points = in.static_point || !in.dwell.empty();
  if (!known_points)
    for (const auto& [tag, track] : truth_of(in)) {
      std::vector<Point> pts;
      for (const auto& p : track)
        if (plausible_utime(p.utime) && std::isfinite(p.z)) pts.push_back({seconds(p.utime), p.z});
      truth_lines.push_back(decimate_min_max(pts, opt.max_points_per_series));
    }
  for (const auto& s : in.series) {
    std::vector<Point> pts;
    for (const auto& e : s.estimates)
      if (plausible_utime(e.utime) && std::isfinite(e.z)) pts.push_back({seconds(e.utime), e.z});
    pose_lines.push_back(decimate_min_max(pts, opt.max_points_per_series));
  }
  for (const auto& a : in.altitude_series) {
    std::vector<Point> pts;
    for (const auto& h : a.heights)
      if (plausible_utime(h.utime) && std::isfinite(h.height_m))
        pts.push_back({seconds(h.utime), h.height_m});
    altitude_lines.push_back(decimate_min_max(pts, opt.max_points_per_series));
  }
  for (const auto* lines : {&truth_lines, &pose_lines, &altitude_lines})
    for (const auto& l : *lines)
      for (const auto& p : l) b.add(0, p.y);
  PlotFrame f;
  f.left = kMarginLeft, f.top = kMarginTop, f.width = kPlotWidth, f.height = kPlotHeight;
  f.x_max = std::max(1.0, static_cast<double>(t1 - t0) * 1e-6);
  if (b.valid()) {
    // At least 1 m tall, so a level walk is a level line and not its noise blown up to the frame.
    const double span = b.y_max - b.y_min;
    const double pad = std::max(0.1 * span, 0.5 * (1.0 - span));
    f.y_min = b.y_min - pad, f.y_max = b.y_max + pad;
  }
  if (!(f.y_max > f.y_min)) f.y_min = 0, f.y_max = 1;
  const auto xt = nice_ticks(f.x_min, f.x_max, 8);
  const auto yt = nice_ticks(f.y_min, f.y_max, 5);

  const auto styles = series_styles(in);
  const auto colours = report_colours(in);
  std::vector<LegendEntry> entries;
  if (!truth_lines.empty())
    entries.push_back({"truth (" + printable(in.truth_channel) + ")",
                       "stroke=\"#000\" stroke-opacity=\"0.55\"", ""});
  for (size_t i = 0; i < in.series.size(); ++i)
    if (in.series[i].has_height)
      entries.push_back(
          {series_label(in.series[i].channel, in.series[i].tag), stroke_style(styles[i]), ""});
  std::vector<std::string> altitude_styles;
  std::map<std::string, size_t> tags_so_far;
  for (const auto& a : in.altitude_series) {
    altitude_styles.push_back(
        stroke_style({colours.at(a.channel), kDashes[tags_so_far[a.channel]++ % kDashCount]}));
    entries.push_back({series_label(a.channel, a.tag), altitude_styles.back(), ""});
  }
  for (size_t i = 0; i < in.series.size(); ++i)
    if (!in.series[i].has_height)
      entries.push_back(
          {series_label(in.series[i].channel, in.series[i].tag) + "  no height estimated", "", "",
           "no-height"});
  const double width = f.left + f.width + kLegendGap + legend_width(entries) + 8;
  std::string s = svg::open(width, canvas_height(f, entries.size()), "Height against time");
  s += axes(f, xt, yt, "time since the first truth or estimate (s)", "height (m)", "height-clip");
  s += "<g class=\"heights\" clip-path=\"url(#height-clip)\" fill=\"none\" "
       "stroke-width=\"1.2\">\n";
  for (const auto& l : truth_lines)
    s += "<polyline class=\"truth-height\" stroke=\"#000\" stroke-opacity=\"0.55\" "
         "stroke-width=\"2\" points=\"" +
         points_attr(l, f) + "\"/>\n";
  for (size_t i = 0; i < pose_lines.size(); ++i)
    if (in.series[i].has_height)
      s += "<polyline class=\"height\" " + series_attrs(in.series[i]) + " " +
           stroke_style(styles[i]) + " points=\"" + points_attr(pose_lines[i], f) + "\"/>\n";
  for (size_t i = 0; i < altitude_lines.size(); ++i)
    s += "<polyline class=\"altitude\" data-channel=\"" + xml_text(in.altitude_series[i].channel) +
         "\" data-tag=\"" + xml_text(in.altitude_series[i].tag) + "\" " + altitude_styles[i] +
         " points=\"" + points_attr(altitude_lines[i], f) + "\"/>\n";
  s += "</g>\n";
  const bool any_height = std::any_of(in.series.begin(), in.series.end(),
                                      [](const EstimateSeries& e) { return e.has_height; }) ||
                          !in.altitude_series.empty();
  if (!any_height)
    s += no_data_note(f, in.series.empty() ? "no pose estimates in this log"
                                           : "no estimate of a height in this log");
  s += legend(entries, f.left + f.width + kLegendGap, kMarginTop + 6);
  return s + "</svg>";
}

std::string utc_time(utime_t t) {
  const std::time_t secs = static_cast<std::time_t>(t / 1'000'000);
  std::tm tm{};
  if (!gmtime_r(&secs, &tm)) return "?";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02d %02d:%02d:%02d.%03d UTC", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>((t % 1'000'000) / 1000));
  return buf;
}

std::string stats_table(const ReportInput& in) {
  std::string s =
      "<table>\n<thead><tr><th></th><th>channel</th><th>tag</th><th>count</th><th>mean</th>"
      "<th>RMSE</th><th>median (CEP50)</th><th>p95 (CEP95)</th><th>max</th>"
      "<th>vertical RMSE</th><th>not scored: non-finite</th></tr></thead>\n<tbody>\n";
  const auto colours = report_colours(in);
  for (const auto& r : in.rows) {
    s += "<tr><td><span class=\"swatch\" style=\"background:" + colours.at(r.channel) +
         "\"></span></td><td>" + xml_text(r.channel) + "</td><td>" + xml_text(r.tag) + "</td><td>" +
         std::to_string(r.count) + "</td>";
    for (double v : {r.mean_h, r.rmse_h, r.median_h, r.p95_h, r.max_h, r.rmse_v})
      s += "<td>" + (r.count ? table_number(v) : std::string("-")) + "</td>";
    s += "<td>" + std::to_string(r.non_finite) + "</td></tr>\n";
  }
  return s + "</tbody>\n</table>\n";
}

// --by channel: one row per channel, all its tags pooled.
std::string channel_table(const ReportInput& in) {
  std::string s =
      "<table class=\"by-channel\">\n<thead><tr><th>channel</th><th>tags</th><th>count</th>"
      "<th>mean</th><th>RMSE</th><th>median (CEP50)</th><th>p95 (CEP95)</th><th>max</th>"
      "<th>vertical RMSE</th><th>not scored: non-finite</th></tr></thead>\n<tbody>\n";
  for (const auto& r : in.channel_rows) {
    s += "<tr><td>" + xml_text(r.channel) + "</td><td>" + std::to_string(r.tags) + "</td><td>" +
         std::to_string(r.count) + "</td>";
    for (double v : {r.mean_h, r.rmse_h, r.median_h, r.p95_h, r.max_h, r.rmse_v})
      s += "<td>" + (r.count ? table_number(v) : std::string("-")) + "</td>";
    s += "<td>" + std::to_string(r.non_finite) + "</td></tr>\n";
  }
  return s + "</tbody>\n</table>\n";
}

std::string altitude_table(const ReportInput& in) {
  std::string s =
      "<table class=\"altitude\">\n<thead><tr><th>channel</th><th>tag</th><th>count</th>"
      "<th>bias</th><th>RMSE</th><th>p95</th><th>max</th><th>on the right floor</th>"
      "<th>not scored: non-finite</th></tr></thead>\n<tbody>\n";
  for (const auto& r : in.altitude_rows) {
    s += "<tr><td>" + xml_text(r.channel) + "</td><td>" + xml_text(r.tag) + "</td><td>" +
         std::to_string(r.count) + "</td>";
    for (double v : {r.bias, r.rmse, r.p95, r.max}) s += "<td>" + table_number(v) + "</td>";
    s += "<td>" + (r.floor_count ? format("%.3f", r.floor_share()) + " of " +
                                       std::to_string(r.floor_count)
                                 : std::string("-")) +
         "</td><td>" + std::to_string(r.non_finite) + "</td></tr>\n";
  }
  return s + "</tbody>\n</table>\n";
}

}  // namespace

std::string svg_document(const std::string& svg_element) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + svg_element + "\n";
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || hi <= lo) return {};
  const double raw = (hi - lo) / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10 * mag;
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * mag) {
      step = m * mag;
      break;
    }
  std::vector<double> ticks;
  // Indices rather than repeated addition, so 0.6 is 3 * 0.2 and not 0.6000000000000001.
  const double first = std::ceil(lo / step - 1e-9);
  for (double k = first; k * step <= hi + step * 1e-9 && ticks.size() < 100; k += 1)
    ticks.push_back(k * step);
  return ticks;
}

std::vector<double> log_ticks(double lo, double hi) {
  if (!(lo > 0) || !std::isfinite(hi) || hi <= lo) return {};
  const bool dense = std::log10(hi / lo) <= 4;
  std::vector<double> ticks;
  for (int k = static_cast<int>(std::floor(std::log10(lo))); k <= std::ceil(std::log10(hi)); ++k)
    for (double m : {1.0, 2.0, 5.0}) {
      if (!dense && m != 1.0) continue;
      const double v = m * std::pow(10.0, k);
      if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) ticks.push_back(v);
    }
  return ticks;
}

ErrorScale error_scale(const ReportInput& in) {
  ErrorScale scale;
  scale.off_scale.assign(in.series.size(), false);
  std::vector<double> rmse(in.series.size(), kNotMeasured);
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < in.series.size(); ++i) {
    const ErrorRow* r = find_row(in, in.series[i]);
    if (!r || r->count == 0 || !std::isfinite(r->rmse_h)) continue;
    rmse[i] = r->rmse_h;
    best = std::min(best, r->rmse_h);
  }
  if (!std::isfinite(best)) return scale;
  scale.best_rmse = best;
  for (size_t i = 0; i < in.series.size(); ++i) {
    scale.off_scale[i] = rmse[i] > kOffScaleRatio * std::max(best, kMinBestRmse);
    scale.log_cdf = scale.log_cdf || scale.off_scale[i];
  }
  return scale;
}

PlotFrame map_frame(const ReportInput& in) {
  Bounds core;
  for (const auto& a : in.anchors) core.add(a.x, a.y);
  if (in.static_point) {
    core.add(in.static_point->x(), in.static_point->y());
  } else if (!in.dwell.empty()) {
    for (const auto& d : in.dwell) core.add(d.x, d.y);
  } else {
    for (const auto& [tag, track] : truth_of(in))
      for (const auto& p : track) core.add(p.x, p.y);
  }
  Bounds est;
  for (const auto& s : in.series)
    for (const auto& e : s.estimates) est.add(e.x, e.y);
  Bounds b = core;
  if (!core.valid()) {
    b = est;
  } else if (est.valid()) {
    // A diverged estimator must not shrink the site to a dot: it may widen the view only so far.
    const double reach =
        std::max(5.0, 0.5 * std::max(core.x_max - core.x_min, core.y_max - core.y_min));
    b.add(std::clamp(est.x_min, core.x_min - reach, core.x_max), core.y_min);
    b.add(std::clamp(est.x_max, core.x_min, core.x_max + reach), core.y_min);
    b.add(core.x_min, std::clamp(est.y_min, core.y_min - reach, core.y_max));
    b.add(core.x_min, std::clamp(est.y_max, core.y_min, core.y_max + reach));
  }
  if (!b.valid()) b = Bounds{-1, 1, -1, 1};
  const double pad = std::max(0.5, 0.05 * std::max(b.x_max - b.x_min, b.y_max - b.y_min));
  PlotFrame f;
  f.x_min = b.x_min - pad, f.x_max = b.x_max + pad;
  f.y_min = b.y_min - pad, f.y_max = b.y_max + pad;
  // One metre is the same number of pixels on both axes.
  const double scale =
      std::min(kMapMaxWidth / (f.x_max - f.x_min), kMapMaxHeight / (f.y_max - f.y_min));
  f.left = kMarginLeft, f.top = kMarginTop;
  f.width = (f.x_max - f.x_min) * scale;
  f.height = (f.y_max - f.y_min) * scale;
  return f;
}

std::vector<Point> decimate_lttb(const std::vector<Point>& pts, size_t max_points) {
  const size_t n = pts.size();
  if (n <= max_points || n < 3) return pts;
  if (max_points < 3) return {pts.front(), pts.back()};
  std::vector<Point> out;
  out.reserve(max_points);
  out.push_back(pts.front());
  const double every = static_cast<double>(n - 2) / static_cast<double>(max_points - 2);
  size_t a = 0;
  for (size_t i = 0; i + 2 < max_points; ++i) {
    const size_t start = static_cast<size_t>(std::floor(static_cast<double>(i) * every)) + 1;
    const size_t end =
        std::min(n - 1, static_cast<size_t>(std::floor(static_cast<double>(i + 1) * every)) + 1);
    const size_t next_end =
        std::min(n, static_cast<size_t>(std::floor(static_cast<double>(i + 2) * every)) + 1);
    double ax = 0, ay = 0;  // mean of the next bucket (the last point for the last bucket)
    for (size_t j = end; j < next_end; ++j) ax += pts[j].x, ay += pts[j].y;
    const double m = static_cast<double>(std::max<size_t>(1, next_end - end));
    if (next_end > end) {
      ax /= m, ay /= m;
    } else {
      ax = pts.back().x, ay = pts.back().y;
    }
    size_t best = start;
    double best_area = -1;
    for (size_t j = start; j < end; ++j) {
      const double area = std::abs((pts[a].x - ax) * (pts[j].y - pts[a].y) -
                                   (pts[a].x - pts[j].x) * (ay - pts[a].y));
      if (area > best_area) best_area = area, best = j;
    }
    out.push_back(pts[best]);
    a = best;
  }
  out.push_back(pts.back());
  return out;
}

std::vector<Point> decimate_min_max(const std::vector<Point>& pts, size_t max_points) {
  const size_t n = pts.size();
  if (n <= max_points) return pts;
  const size_t buckets = std::max<size_t>(1, max_points / 2);
  std::vector<Point> out;
  out.reserve(2 * buckets);
  for (size_t b = 0; b < buckets; ++b) {
    const size_t lo = b * n / buckets, hi = (b + 1) * n / buckets;
    if (lo >= hi) continue;
    size_t i_min = lo, i_max = lo;
    for (size_t j = lo; j < hi; ++j) {
      if (pts[j].y < pts[i_min].y) i_min = j;
      if (pts[j].y > pts[i_max].y) i_max = j;
    }
    if (max_points < 2) {
      out.push_back(pts[i_max]);  // room for one: the worst error
    } else {
      out.push_back(pts[std::min(i_min, i_max)]);
      if (i_min != i_max) out.push_back(pts[std::max(i_min, i_max)]);
    }
  }
  return out;
}

std::vector<Point> cdf_steps(std::vector<double> errors, size_t max_points) {
  errors.erase(
      std::remove_if(errors.begin(), errors.end(), [](double e) { return !std::isfinite(e); }),
      errors.end());
  const size_t n = errors.size();
  if (n == 0) return {};
  std::sort(errors.begin(), errors.end());
  const size_t steps = std::min(n, std::max<size_t>(1, max_points / 2));
  std::vector<Point> out;
  out.reserve(2 * steps);
  size_t prev = 0;
  for (size_t j = 1; j <= steps; ++j) {
    const size_t k = (j * n + steps - 1) / steps;  // ceil(j n / steps): rank reached at step j
    const double e = errors[k - 1];
    out.push_back({e, static_cast<double>(prev) / static_cast<double>(n)});
    out.push_back({e, static_cast<double>(k) / static_cast<double>(n)});
    prev = k;
  }
  return out;
}

Report build_report(const ReportInput& in, const ReportOptions& options) {
  Report r;
  r.map_svg = map_figure(in, options);
  const ErrorScale scale = error_scale(in);
  r.error_time_svg = error_time_figure(in, options, scale);
  r.error_cdf_svg = error_cdf_figure(in, options, scale);
  r.height_svg = height_figure(in, options);

  const auto [t0, t1] = time_span(in);
  std::string h;
  h.reserve(r.map_svg.size() + r.error_time_svg.size() + r.error_cdf_svg.size() +
            r.height_svg.size() + 8192);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>ips-eval: " +
       xml_text(in.log_path) +
       "</title>\n<style>\n"
       "body { font-family: sans-serif; margin: 1.5em; color: #222; }\n"
       "table { border-collapse: collapse; margin: 1em 0; }\n"
       "th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; }\n"
       "td { text-align: right; font-variant-numeric: tabular-nums; }\n"
       "td:nth-child(2), td:nth-child(3) { text-align: left; font-family: monospace; }\n"
       ".swatch { display: inline-block; width: 1.2em; height: 0.8em; }\n"
       ".note { color: #a00; font-weight: bold; }\n"
       "figure { margin: 1em 0 2em 0; }\n"
       "</style>\n</head>\n<body>\n<h1>ips-eval report</h1>\n";
  h += "<p>Log: <code>" + xml_text(in.log_path) + "</code></p>\n<p>";
  if (t0 != 0)
    h += "Time span: " + utc_time(t0) + " to " + utc_time(t1) +
         format(" (%.1f s)", static_cast<double>(t1 - t0) * 1e-6) + ".<br>\n";
  else
    h += "Time span: no truth or estimate with a valid time.<br>\n";
  h += std::to_string(in.events) + " log events, " + std::to_string(in.truth_samples) +
       " truth samples on <code>" + xml_text(in.truth_channel) + "</code>, " +
       std::to_string(in.estimates) + " estimates (" + std::to_string(in.unmatched) +
       " without truth around them) in " + std::to_string(in.rows.size()) +
       " channel/tag series, " + std::to_string(in.anchors.size()) + " anchors, " +
       std::to_string(truth_of(in).size()) + " tags with truth.</p>\n";
  if (in.static_point)
    h += "<p>Static-point mode: every estimate is compared with the known point (" +
         format("%.3f", in.static_point->x()) + ", " + format("%.3f", in.static_point->y()) +
         ") m.</p>\n";
  if (!in.dwell.empty())
    h += "<p>Dwell mode: every estimate inside one of the " + std::to_string(in.dwell.size()) +
         " dwell intervals is compared with that interval's known point; " +
         std::to_string(in.unmatched) + " estimates outside every interval are not scored.</p>\n";
  if (in.series.empty())
    h += "<p class=\"note\">No pose estimates in this log: nothing to score.</p>\n";
  else if (std::none_of(in.rows.begin(), in.rows.end(),
                        [](const ErrorRow& row) { return row.count > 0; }))
    h += "<p class=\"note\">No estimate has truth around it: nothing was scored.</p>\n";
  if (in.anchors.empty()) h += "<p>No SITE message in this log: the map has no anchors.</p>\n";

  h += "<h2>Statistics</h2>\n<p>Horizontal error (distance in x, y) and vertical RMSE, in "
       "metres; the same numbers as the text table.</p>\n" +
       stats_table(in);
  if (!in.channel_rows.empty())
    h += "<h2>Per channel</h2>\n<p>Every tag of a channel pooled (<code>--by channel</code>).</p>\n" +
         channel_table(in);
  if (!in.altitude_rows.empty())
    h += "<h2>Altitude</h2>\n<p>Height error (estimate minus reference), in metres; bias is its "
         "mean, p95 and max are of its absolute value; the share of estimates on the right floor "
         "where the site gives floors.</p>\n" +
         altitude_table(in);
  h += "<h2>Map</h2>\n<figure>\n" + r.map_svg + "\n</figure>\n";
  h += "<h2>Horizontal error against time</h2>\n";
  std::string off;
  for (size_t i = 0; i < in.series.size(); ++i) {
    if (!scale.off_scale[i]) continue;
    const ErrorRow* row = find_row(in, in.series[i]);
    off += std::string(off.empty() ? "" : ", ") + "<code>" +
           xml_text(in.series[i].channel + " / " + in.series[i].tag) + "</code>" +
           format(" (RMSE %.3f m)", row ? row->rmse_h : kNotMeasured);
  }
  if (!off.empty())
    h += "<p class=\"off-scale\">The error axis shows the series within " +
         format("%g", kOffScaleRatio) + " times the best RMSE (" +
         format("%.3f m", scale.best_rmse) + "). Off scale, not drawn: " + off + ".</p>\n";
  h += "<figure>\n" + r.error_time_svg + "\n</figure>\n";
  h += "<h2>Horizontal error CDF</h2>\n";
  if (scale.log_cdf)
    h += "<p>The error axis is logarithmic: the series are more than " +
         format("%g", kOffScaleRatio) + " times apart in RMSE.</p>\n";
  h += "<figure>\n" + r.error_cdf_svg + "\n</figure>\n";
  h += "<h2>Height against time</h2>\n<p>Truth, the pose channels that estimate a height and "
       "ALTITUDE; a 2D estimator's height (<code>STATUS_2D</code>, or one fixed z) is no "
       "estimate and is not drawn.</p>\n<figure>\n" +
       r.height_svg + "\n</figure>\n";
  h += "</body>\n</html>\n";
  r.index_html = std::move(h);
  return r;
}

}  // namespace ips::eval
