#pragma once
// The page behind `ips-eval --report DIR`: four figures as SVG (the map with anchors, truth and
// every estimator's track; horizontal error against time; the error CDF with CEP50/CEP95; height
// against time, without the series that estimate no height) and the
// statistics table, as one self-contained HTML page (no script, no external asset). Pure: it
// takes the Evaluator's numbers and returns strings; main.cpp writes the files. Each channel has
// its colour from core/channel_colours (the same as in ips-view); the tags of one channel differ
// by their dash pattern.
//
// Every text that came from the log (channel names, tag and anchor ids) or the command line (the
// log path) goes through xml_text(), so the output is well-formed XML/HTML whatever the bytes.
// Long series are decimated to at most ReportOptions::max_points_per_series points, so a one-hour
// 10-tag log gives a page of a few MB.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/text_escape.hpp"
#include "loggers/eval/evaluation.hpp"

namespace ips::eval {

using ips::xml_text;

struct ReportAnchor {
  std::string id;
  double x = 0, y = 0;  // m, site frame
  bool enabled = true;
};

struct ReportInput {
  std::string log_path;
  std::string truth_channel = "TRUTH";
  std::vector<ErrorRow> rows;          // Evaluator::rows()
  // Evaluator::rows_by_channel() with --by channel (a table of its own), else empty.
  std::vector<ErrorRow> channel_rows;
  std::vector<AltitudeRow> altitude_rows;  // Evaluator::altitude_rows() (or _by_channel())
  std::vector<EstimateSeries> series;  // Evaluator::estimate_series(), the same channels and tags
  std::vector<AltitudeSeries> altitude_series;  // Evaluator::altitude_series()
  // Evaluator::truth_tracks(), not copied (an hour of 10 tags at 50 Hz is 1.8 M samples); must
  // outlive build_report(). Null: no truth.
  const std::map<std::string, std::vector<PositionSample>>* truth = nullptr;
  std::vector<ReportAnchor> anchors;            // the log's last SITE message
  std::optional<Eigen::Vector3d> static_point;  // static-point mode: drawn instead of truth
  std::vector<DwellInterval> dwell;             // dwell mode: the known points, drawn likewise
  // For the header.
  int64_t events = 0, truth_samples = 0, estimates = 0;
  size_t unmatched = 0;
};

struct ReportOptions {
  size_t max_points_per_series = 2000;  // per polyline, in every figure
};

struct Report {
  // Each figure is one complete <svg> element; the standalone file is svg_document(figure).
  std::string map_svg;
  std::string error_time_svg;
  std::string error_cdf_svg;
  std::string height_svg;
  std::string index_html;  // holds the four <svg> elements inline, byte for byte
};

Report build_report(const ReportInput& in, const ReportOptions& options = {});

// A standalone .svg file: the XML declaration, then the element.
std::string svg_document(const std::string& svg_element);

// ---- Building blocks (exposed for tests) ----


struct Point {
  double x, y;
};

// A data-to-pixel map onto a plot rectangle (y up in data, down in pixels): linear, or on x
// logarithmic (log_x, x_min > 0), where values at or below x_min are drawn at x_min.
struct PlotFrame {
  double left = 0, top = 0, width = 1, height = 1;    // px
  double x_min = 0, x_max = 1, y_min = 0, y_max = 1;  // data
  bool log_x = false;
  Point to_px(double x, double y) const {
    const double fx = log_x ? std::log10(std::max(x, x_min) / x_min) / std::log10(x_max / x_min)
                            : (x - x_min) / (x_max - x_min);
    return {left + fx * width, top + (y_max - y) / (y_max - y_min) * height};
  }
};

// The map's frame: the box around anchors, truth (or the static point) and the estimates (an
// estimate far off extends it by at most max(5 m, half the site); the rest is clipped), padded
// by 5 %, drawn with one scale on x and y.
PlotFrame map_frame(const ReportInput& in);

// Tick values at 1, 2 or 5 times a power of ten inside [lo, hi], about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target);

// Ticks of a log axis over [lo, hi] (0 < lo < hi): 1, 2 and 5 times each power of ten inside, or
// only the powers of ten when the axis spans more than four decades.
std::vector<double> log_ticks(double lo, double hi);

// How the error figures compare series of very different quality. A series is off scale when its
// horizontal RMSE is more than kOffScaleRatio times the best series' (the best taken as at least
// 1 cm, so a perfect series does not push every other one off): the error-against-time figure
// is zoomed to the others and lists it in its legend with its RMSE instead of drawing it, and
// the CDF's error axis is logarithmic whenever any series is off scale.
inline constexpr double kOffScaleRatio = 5;
struct ErrorScale {
  std::vector<bool> off_scale;  // per ReportInput::series
  double best_rmse = 0;         // m; 0 when nothing was scored
  bool log_cdf = false;
};
ErrorScale error_scale(const ReportInput& in);

// Largest-Triangle-Three-Buckets (Steinarsson 2013): at most max_points points of a polyline,
// first and last kept, each bucket represented by the point that keeps the most area; for tracks.
std::vector<Point> decimate_lttb(const std::vector<Point>& points, size_t max_points);

// At most max_points points of a time series: per bucket of consecutive points, the smallest and
// the largest y in their original order, so spikes (the worst errors) survive.
std::vector<Point> decimate_min_max(const std::vector<Point>& points, size_t max_points);

// The empirical CDF of the finite `errors` as a staircase in data units, from (e_min, 0) to
// (e_max, 1): two points per step, one step per sample, or max_points / 2 steps at evenly spaced
// ranks when there are more samples.
std::vector<Point> cdf_steps(std::vector<double> errors, size_t max_points);

}  // namespace ips::eval
