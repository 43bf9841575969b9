#pragma once
// Scores estimates against ground truth: for every estimate channel and tag, the horizontal error
// to TRUTH linearly interpolated at the estimate's utime (count, mean, RMSE, median, 95th
// percentile, max) and the RMSE of the vertical error. Pure: fed messages, returns numbers.
#include <Eigen/Core>
#include <ips/pose_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/time.hpp"

namespace ips::eval {

struct ErrorRow {
  std::string channel;
  std::string tag;
  size_t count = 0;
  size_t non_finite = 0;  // estimates with a NaN/inf horizontal position: not scored, counted
  // Horizontal error. CEP50 and CEP95 (circular error probable: the radius holding 50 % and 95 %
  // of the estimates) are the median and the 95th percentile of the horizontal error.
  double mean_h = 0, rmse_h = 0, median_h = 0, p95_h = 0, max_h = 0;
  double cep50() const { return median_h; }
  double cep95() const { return p95_h; }
  // Vertical error |dz|, over estimates with a finite height; NaN when none has one.
  double rmse_v = 0, mean_v = 0, median_v = 0, p95_v = 0, max_v = 0;
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
};

// Every estimate of one channel and tag, in the order they were added.
struct EstimateSeries {
  std::string channel;
  std::string tag;
  std::vector<EstimateError> estimates;
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

  void add_truth(const pose_t& truth);
  void add_estimate(const std::string& channel, const pose_t& estimate);
  // Rows sorted by channel then tag.
  std::vector<ErrorRow> rows() const;
  // Estimates without truth around them (before the first, after the last, or across a gap).
  size_t unmatched() const;
  // Truth samples with a non-finite position, which are not used.
  size_t bad_truth() const { return bad_truth_; }

  // Per channel and tag, sorted like rows(): every estimate with its horizontal error; the
  // finite errors of a series are exactly the ones rows() summarises.
  std::vector<EstimateSeries> estimate_series() const;
  // The usable truth samples per tag, sorted by utime.
  const std::map<std::string, std::vector<PositionSample>>& truth_tracks() const { return truth_; }
  // The known point in static-point mode.
  std::optional<Eigen::Vector3d> static_point() const {
    return static_mode_ ? std::optional<Eigen::Vector3d>(static_point_) : std::nullopt;
  }

 private:
  using Sample = PositionSample;
  bool truth_at(const std::string& tag, utime_t t, double& x, double& y, double& z) const;

  utime_t max_gap_us_;
  size_t bad_truth_ = 0;
  bool static_mode_ = false;
  bool static_has_height_ = false;
  Eigen::Vector3d static_point_ = Eigen::Vector3d::Zero();
  std::map<std::string, std::vector<Sample>> truth_;  // per tag
  std::map<std::pair<std::string, std::string>, std::vector<Sample>> estimates_;
};

}  // namespace ips::eval
