#pragma once
// Scores estimates against ground truth: for every estimate channel and tag, the horizontal error
// to TRUTH linearly interpolated at the estimate's utime (count, mean, RMSE, median, 95th
// percentile, max) and the statistics of the vertical error; for every ALTITUDE channel and tag
// the height error (bias, RMSE, p95, max) and the share on the right floor. The reference is
// TRUTH, or a known static point, or the known points of dwell intervals. Pure: fed messages,
// returns numbers.
#include <Eigen/Core>
#include <cstdint>
#include <ips/altitude_t.hpp>
#include <ips/pose_t.hpp>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/time.hpp"
#include "estimators/altitude/floor_detector.hpp"

namespace ips::eval {

// Natural order of names: runs of digits compare as numbers, so T1 < T1-2 < T1-10 < T2 (plain
// byte order would put T1-10 before T1-2); equal up to that (T01, T1): byte order.
bool natural_less(const std::string& a, const std::string& b);

// The tag of a row that pools every tag of its channel (--by channel).
inline constexpr const char* kAllTags = "*";

// A statistic with nothing to measure ("-" in the table, null in JSON).
inline constexpr double kNotMeasured = std::numeric_limits<double>::quiet_NaN();

struct ErrorRow {
  std::string channel;
  std::string tag;  // kAllTags for a row pooled over tags
  size_t tags = 1;  // tags pooled in this row
  size_t count = 0;
  size_t non_finite = 0;  // estimates with a NaN/inf horizontal position: not scored, counted
  // Horizontal error. CEP50 and CEP95 (circular error probable: the radius holding 50 % and 95 %
  // of the estimates) are the median and the 95th percentile of the horizontal error.
  double mean_h = 0, rmse_h = 0, median_h = 0, p95_h = 0, max_h = 0;
  double cep50() const { return median_h; }
  double cep95() const { return p95_h; }
  // Vertical error |dz|, over 3D estimates with a finite height (not those of a 2D estimator,
  // STATUS_2D, whose height is the site's fixed one, nor those of a series whose z never
  // changes: a fixed height too); NaN when none has one.
  double rmse_v = 0, mean_v = 0, median_v = 0, p95_v = 0, max_v = 0;
  size_t count_v = 0;  // estimates in the vertical statistics
};

// The height error of one ALTITUDE channel and tag: estimate height_m - reference z.
struct AltitudeRow {
  std::string channel;
  std::string tag;  // kAllTags for a row pooled over tags
  size_t tags = 1;
  size_t count = 0;       // scored
  size_t non_finite = 0;  // NaN/inf height_m: not scored, counted
  // bias: the mean signed error; p95 and max of |error|; m.
  double bias = kNotMeasured, rmse = kNotMeasured, p95 = kNotMeasured, max = kNotMeasured;
  // Floors (only when the site lists them, estimators.altitude.floors): of the scored estimates
  // with floor_valid, how many name the floor the reference height is on.
  size_t floor_count = 0, floor_right = 0;
  double floor_share() const {
    return floor_count ? static_cast<double>(floor_right) / static_cast<double>(floor_count)
                       : kNotMeasured;
  }
};

// A known point a tag stood still at from start to end (both inclusive): every estimate of that
// tag in [start, end] is scored against it.
struct DwellInterval {
  utime_t start = 0, end = 0;
  double x = 0, y = 0;
  double z = std::numeric_limits<double>::quiet_NaN();  // NaN: no height known
  std::string tag;                                      // empty: any tag
};

// A timestamped position (truth or estimate), m in the site frame.
struct PositionSample {
  utime_t utime;
  double x, y, z;
};

// One estimate as the report draws it: where it was and how far off horizontally.
struct EstimateError {
  utime_t utime;
  double x, y;     // the estimate's horizontal position, m
  double error_h;  // horizontal error to truth, m; NaN where rows() does not score it
  // The estimate's height, m; NaN where it is not an estimate (STATUS_2D, or a series whose z
  // never changes: the same ones rows() leaves out of the vertical error).
  double z = std::numeric_limits<double>::quiet_NaN();
};

// Every estimate of one channel and tag, in the order they were added.
struct EstimateSeries {
  std::string channel;
  std::string tag;
  std::vector<EstimateError> estimates;
  bool has_height = false;  // some estimate has a finite z
};

// The heights of one ALTITUDE channel and tag, in the order they were added.
struct AltitudeSeries {
  struct Height {
    utime_t utime;
    double height_m;  // may be NaN (counted as non_finite by altitude_rows())
  };
  std::string channel;
  std::string tag;
  std::vector<Height> heights;
};

// Percentile p in [0, 100] of `values` with linear interpolation between order statistics
// (numpy's default). `values` is sorted in place. NaN for an empty set.
double percentile(std::vector<double>& values, double p);

class Evaluator {
 public:
  // Truth further than this from an estimate's time on both sides is not interpolated across.
  explicit Evaluator(double max_truth_gap_s = 1.0) : max_gap_us_(s_to_utime(max_truth_gap_s)) {}

  // Static-point mode, the way the source experiments were scored: every estimate is compared
  // with this known point instead of TRUTH (z compared only when has_height).
  void set_static_point(const Eigen::Vector3d& point, bool has_height);
  // Dwell mode: the reference of an estimate is the point of the first interval (sorted by
  // start) that holds its utime and names its tag or no tag; TRUTH is not used. Estimates
  // outside every interval are unmatched().
  void set_dwell_intervals(std::vector<DwellInterval> intervals);
  bool dwell_mode() const { return dwell_mode_; }
  const std::vector<DwellInterval>& dwell_intervals() const { return dwell_; }
  // Only estimates (poses and altitudes) with from <= utime <= to are kept; the others are
  // counted in outside_window(). Truth further than the truth gap outside the window is dropped.
  // Set before adding anything.
  void set_window(utime_t from, utime_t to);
  // The site's floors, for AltitudeRow's floor share (heights_m empty: none).
  void set_floors(const altitude::FloorParams& floors) { floors_ = floors; }

  void add_truth(const pose_t& truth);
  void add_estimate(const std::string& channel, const pose_t& estimate);
  void add_altitude(const std::string& channel, const altitude_t& altitude);
  // Rows in natural order of channel, then tag.
  std::vector<ErrorRow> rows() const;
  // One row per channel, the errors of all its tags pooled (tag kAllTags), natural order.
  std::vector<ErrorRow> rows_by_channel() const;
  std::vector<AltitudeRow> altitude_rows() const;
  std::vector<AltitudeRow> altitude_rows_by_channel() const;
  // Pose estimates without a reference: no truth around them (before the first, after the last,
  // or across a gap), or, in dwell mode, outside every interval.
  size_t unmatched() const;
  // Altitudes without a reference height (as unmatched(), or a reference without z).
  size_t altitudes_unmatched() const;
  // Estimates (poses and altitudes) left out by set_window().
  size_t outside_window() const { return outside_window_; }
  // Altitudes kept (inside the window).
  size_t altitudes() const;
  // Truth samples with a non-finite position, which are not used.
  size_t bad_truth() const { return bad_truth_; }

  // Per channel and tag, in the order of rows(): every estimate with its horizontal error; the
  // finite errors of a series are exactly the ones rows() summarises.
  std::vector<EstimateSeries> estimate_series() const;
  // Per ALTITUDE channel and tag, in the order of altitude_rows(): every height kept.
  std::vector<AltitudeSeries> altitude_series() const;
  // The usable truth samples per tag, sorted by utime.
  const std::map<std::string, std::vector<PositionSample>>& truth_tracks() const { return truth_; }
  // The known point in static-point mode.
  std::optional<Eigen::Vector3d> static_point() const {
    return static_mode_ ? std::optional<Eigen::Vector3d>(static_point_) : std::nullopt;
  }

 private:
  struct Sample {
    utime_t utime;
    double x, y, z;
    bool planar;  // STATUS_2D: the height is not estimated
  };
  struct AltitudeSample {
    utime_t utime;
    double height_m;
    int32_t floor;
    bool floor_valid;
  };
  struct Accumulator;
  struct AltitudeAccumulator;
  using Key = std::pair<std::string, std::string>;  // channel, tag
  // True when the series' non-2D finite heights are all the same (at least two of them).
  static bool height_is_fixed(const std::vector<Sample>& est);
  bool truth_at(const std::string& tag, utime_t t, double& x, double& y, double& z) const;
  void score(const std::string& tag, const std::vector<Sample>& est, Accumulator& acc) const;
  void score(const std::string& tag, const std::vector<AltitudeSample>& est,
             AltitudeAccumulator& acc) const;
  // The floor index a height is on (as FloorDetector picks it, without the dwell); false
  // without floors.
  bool floor_of(double height_m, int& floor) const;
  bool in_window(utime_t t) const { return t >= window_from_ && t <= window_to_; }

  utime_t max_gap_us_;
  size_t bad_truth_ = 0;
  size_t outside_window_ = 0;
  utime_t window_from_ = std::numeric_limits<utime_t>::min();
  utime_t window_to_ = std::numeric_limits<utime_t>::max();
  bool dwell_mode_ = false;
  std::vector<DwellInterval> dwell_;
  altitude::FloorParams floors_;
  bool static_mode_ = false;
  bool static_has_height_ = false;
  Eigen::Vector3d static_point_ = Eigen::Vector3d::Zero();
  std::map<std::string, std::vector<PositionSample>> truth_;  // per tag
  std::map<Key, std::vector<Sample>> estimates_;
  std::map<Key, std::vector<AltitudeSample>> altitudes_;
};

}  // namespace ips::eval
