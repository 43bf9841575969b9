#pragma once
// ips-uwb-calibrate's core: each tag-anchor pair's constant range offset from ranges with a
// reference position (TRUTH), and the site with the offsets written as
// estimators.uwb_twr.range_offsets_m. Pure: no clock, no file, no bus.
//
// Per pair, residual = range - |truth(t) - anchor|, the truth interpolated at the range's time
// (a range without a truth sample within truth_window_s on each side is skipped). The offset is
// the residuals' median (NLOS ranges are only ever too long: the median moves little, the mean
// much). Optionally (fit_scale) each pair's scale s too, from the least-squares line
// range = (1 + s) d + b, and the offset is then the median of range / (1 + s) - d: the trackers
// divide a range by 1 + s before taking the offset off (estimators.uwb_twr.range_scales). A
// scale needs distances that vary (their spread at least min_scale_spread_m) and a slope off 1 by
// more than scale_min_se standard errors; otherwise the pair keeps scale 0 and says so.
#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/site.hpp"

namespace ips::uwb_twr {

struct RangeSample {
  std::string tag_id, anchor_id;
  int64_t utime = 0;  // us
  double range_m = 0;
};

struct TruthSample {
  int64_t utime = 0;  // us
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};
// Per tag, in any order (sorted by the fit).
using TruthTracks = std::map<std::string, std::vector<TruthSample>>;

struct RangeCalibrationOptions {
  double truth_window_s = 0.2;  // a truth sample within this on each side of a range
  int min_ranges = 20;          // fewer: the pair is refused
  double max_offset_m = 1.0;    // |offset| beyond: refused
  bool force = false;           // keep refused pairs that have at least one range
  bool fit_scale = false;       // also each pair's scale factor (written as range_scales)
  double min_scale_spread_m = 0.5;  // the distances' standard deviation a scale needs
  double max_scale = 0.1;       // |scale| beyond: refused (the site's bound)
  double scale_min_se = 3.0;    // a scale within this many standard errors of 0 is not used
};

struct PairCalibration {
  std::string tag_id, anchor_id;
  int64_t ranges = 0;                                     // the pair's ranges in the log
  int64_t n = 0;                                          // of them with truth: the residuals
  double offset_m = 0;                                    // median residual (what is written)
  double mean_before_m = 0, rms_before_m = 0, std_m = 0;  // raw residuals
  double rms_after_m = 0, median_after_m = 0;             // residual - offset_m
  double scale = 0, scale_bias_m = 0;  // range = (1 + scale) d + scale_bias_m (least squares)
  double scale_se = 0;      // the slope's standard error
  bool scale_used = false;  // fit_scale, the distances vary and the scale is significant:
                            // offset_m is in its terms
  double site_offset_m = 0;            // the input site's offset for the pair (NaN: none)
  double median_site_m = 0;  // median residual with the site's offset taken off (NaN: none)
  std::string refused;       // why it is not written; empty when accepted
};

struct RangeCalibrationStats {
  int64_t ranges_in = 0;
  int64_t unknown_anchor = 0;   // anchor not an enabled uwb anchor of the site
  int64_t between_anchors = 0;  // tag_id is an anchor (anchor-to-anchor ranging)
  int64_t invalid_range = 0;    // NaN, inf or negative
  int64_t no_truth = 0;         // no truth of the tag within truth_window_s on both sides
};

struct RangeCalibration {
  std::vector<PairCalibration> pairs;  // by tag, then anchor
  RangeCalibrationStats stats;
};

// The fit. site_offsets: the input site's estimators.uwb_twr.range_offsets_m (keys "A1" or
// "T1/A1", as the trackers read them), for the median_site_m column.
RangeCalibration fit_range_offsets(const Site& site, const std::vector<RangeSample>& ranges,
                                   const TruthTracks& truth, const RangeCalibrationOptions& opts,
                                   const std::map<std::string, double>& site_offsets = {},
                                   const std::map<std::string, double>& site_scales = {});

// The offsets to write, of the accepted pairs: keyed "A1" when they are all of one tag, else
// "T1/A1".
std::map<std::string, double> offsets_to_write(const std::vector<PairCalibration>& pairs);
// The same pairs' scales, of those whose scale is used (keyed as offsets_to_write).
std::map<std::string, double> scales_to_write(const std::vector<PairCalibration>& pairs);

// The site's YAML with `offsets` merged into estimators.uwb_twr.range_offsets_m and `scales`
// into range_scales (other keys kept; an anchor-only key drops the pair keys "*/ANCHOR" that
// would override it). An offset written without a scale is for unscaled ranges, so its key's
// range_scales entry is dropped. Each header line a leading comment. Checks that the
// text parses back with the values; ConfigError otherwise.
std::string site_with_offsets_yaml(const Site& site, const std::map<std::string, double>& offsets,
                                   const std::vector<std::string>& header,
                                   const std::map<std::string, double>& scales = {});

}  // namespace ips::uwb_twr
