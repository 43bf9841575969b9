#pragma once
// ips-aoa-calibrate's core: per-anchor angle correction polynomials (aoa_calibration.hpp) fitted
// from BLE_AOA events of tags at known positions. Pure: the caller hands over the site, the
// events (with their time in seconds since the start of the input) and, for a walk with a
// reference system, the tags' TRUTH poses; fit() resolves everything at the end.
//
// Each event is paired with the angle the anchor should have reported, Theta = predict_angle()
// at the tag's reference position (a --point whose window holds the event, or TRUTH interpolated
// at the event's utime), and the correction Theta = P(theta) of the measured theta is fitted per
// anchor by least squares, as source 000 section 4 fits its chamber data (inverted there, direct
// here). The fit is on the MEAN measured angle of each group of samples with the same reference
// angle (within group_width_deg), weighted by its size, not on single samples: regressing the
// exact Theta on the noisy theta would shrink the slope by sigma^2 / var(Theta) (regression
// dilution; 5 deg of noise over a +-20 deg spread of reference angles: ~6 %), whereas mapping the
// mean response back to Theta makes the corrected angle unbiased at every reference angle.
//
// Robustness: a multipath duplicate (a later event of the same anchor, tag and BLE channel within
// duplicate_window_ms, source 000 7.2.1 "extra delayed messages with wrong directions") is
// dropped before the fit; the fit then iterates: start from the group medians, reject samples
// whose residual P(theta) - Theta is beyond reject_k * 1.4826 * MAD (at least reject_k *
// min_sigma_deg) from the median residual, refit on the group means of the rest, until the kept
// set no longer changes.
//
// The start of the iteration keeps the agreeing majority: besides the fit through every group's
// median, the fits leaving out one group each (with at least degree + 2 groups) are tried, and the
// one with the smallest median absolute residual over all samples starts the rejection; so one
// reference point spoiled by multipath is rejected, not the groups that agree with each other.
//
// Plausibility: a fit's overall slope ((P(hi) - P(lo)) / (hi - lo) over the measured angles used)
// outside
// [min_slope, max_slope] is refused (not fitted, the reason given) unless `force`: an array
// compresses or stretches its angles by some percent to some tens of percent towards the edges
// (the chamber fit's slope is 0.8 to 1.2), never by a factor of two; a slope like 0.26 or 1.61
// from four stop points is a wrong point or a wrong orientation, and applying it would make every
// angle worse.
//
// Degree: 0 is a constant offset (Theta = theta + c0: a mounting-yaw error); 1 adds a scale;
// 2 and 3 bend towards the edges like the chamber fits. Default 1: five points give five
// reference angles per anchor, enough for a line checked by three redundant ones; the chamber's
// edge compression (cubic (6.10): -1.7 deg at +40 deg, +4.2 deg at -40 deg) is followed by a line
// to about 1 deg there, and a curve from five points would chase their noise. A degree the data
// cannot carry falls back to a lower one with the reason:
// fewer than degree + 1 distinct reference angles, a span of reference angles narrower than
// degree * min_span_deg_per_degree, or a rank-deficient system.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <ips/ble_aoa_t.hpp>
#include <ips/pose_t.hpp>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "estimators/aoa/aoa_calibration.hpp"
#include "estimators/aoa/models/aoa_bearing.hpp"

namespace ips::aoa {

// A problem with the calibration's input that the user must fix (a bad point, a tag that sent
// nothing): ips-aoa-calibrate reports it in one line with status 2.
class CalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CalibrationFitOptions {
  int degree = 1;              // 0..3, the requested degree (lower when the data cannot carry it)
  bool elevation = false;      // also fit elevation (azimuth always)
  double reject_k = 3.0;       // outliers: beyond reject_k robust sigmas of the residuals
  double min_sigma_deg = 0.5;  // floor of the robust sigma (integer angles: MAD can be 0)
  int max_iterations = 20;
  double duplicate_window_ms = 50;  // 0: keep duplicates (then only the MAD test removes them)
  double group_width_deg = 1.0;     // reference angles this close form one group
  double min_span_deg_per_degree = 10.0;
  int min_samples = 10;          // per anchor and angle, after duplicates and rejection
  double truth_max_gap_s = 0.5;  // TRUTH samples further apart are not interpolated across
  double min_slope = 0.7;        // plausible slopes of a fit of degree >= 1 (see above)
  double max_slope = 1.4;
  bool force = false;            // keep a fit with an implausible slope (flagged in `slope_note`)
};

// A tag standing at a known site position between start_s and end_s (seconds since the start of
// the input, inclusive). z NaN: the site's height_m of the tag, else the anchors' mean height.
struct ReferencePoint {
  std::string tag_id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double start_s = -std::numeric_limits<double>::infinity();
  double end_s = std::numeric_limits<double>::infinity();
};

// One measured angle and the angle the anchor should have reported, in degrees.
struct AngleSample {
  double measured_deg;
  double true_deg;
};

struct AngleFit {
  bool fitted = false;
  std::string failure;  // why not, when not fitted
  int degree_requested = 1;
  int degree = 1;              // the degree fitted
  std::string degree_note;     // why it is lower than requested (empty otherwise)
  double slope_min = 1, slope_max = 1;  // the overall slope over the measured angles used
  std::string slope_note;      // a forced fit's implausible slope (empty otherwise)
  int start_left_out_group = -1;  // the group the robust start left out (-1: none)
  AngleCorrection correction;  // valid interval: the span of the measured angles used
  int64_t samples = 0;         // given to the fit
  int64_t used = 0;
  int64_t rejected = 0;                       // by the MAD test
  int groups = 0;                             // distinct reference angles among the samples used
  double true_min_deg = 0, true_max_deg = 0;  // span of the reference angles used
  double rms_before_deg = 0;  // RMS of theta - Theta over the samples used (no correction)
  double rms_after_deg = 0;   // RMS of P(theta) - Theta over the same samples
  // The systematic part, which is what a calibration removes: the RMS over the groups (weighted by
  // size) of each group's mean error. The per-sample RMS above also holds the noise, which a
  // slope above 1 (an edge-compression correction) scales up.
  double systematic_before_deg = 0;
  double systematic_after_deg = 0;
  double robust_sigma_deg = 0;  // 1.4826 MAD of the final residuals
  int iterations = 0;
};

// The fit of one angle of one anchor. Samples with a non-finite angle are ignored (not counted).
AngleFit fit_angle_correction(const std::vector<AngleSample>& samples,
                              const CalibrationFitOptions& opts);

struct AnchorFit {
  std::string anchor_id;
  int64_t events = 0;      // with a reference angle (before duplicates)
  int64_t duplicates = 0;  // dropped as multipath duplicates
  AngleFit azimuth;
  std::optional<AngleFit> elevation;  // with opts.elevation
};

struct PointUse {
  ReferencePoint point;  // z resolved
  std::string z_note;    // how z was chosen when not given (empty when given)
  int64_t events = 0;    // events of its tag in its window, from site anchors
};

struct CalibrationStats {
  int64_t events_in = 0;
  int64_t unknown_anchor = 0;  // not an enabled ble_aoa anchor of the site
  int64_t no_reference = 0;    // a tag with no --point and (without --truth) no truth
  int64_t outside_window = 0;  // a tag with points, at a time in none of their windows
  int64_t no_truth = 0;        // --truth: no TRUTH of the tag around the event's time
  int64_t invalid_angle = 0;   // azimuth NaN, infinite or beyond +-90 deg
  int64_t out_of_view = 0;     // the reference position behind the anchor or on its axis
  int64_t truth_in = 0;        // TRUTH poses received
  int64_t sites_ignored = 0;   // later SITEs whose text differs from the first
};

struct CalibrationResult {
  std::vector<AnchorFit> anchors;  // every enabled ble_aoa anchor of the site, site order
  std::vector<PointUse> points;
  std::map<std::string, int64_t> events_by_tag;  // every tag heard, with a reference or not
  CalibrationStats stats;
};

class CalibrationCollector {
 public:
  // Throws CalibrationError on a bad point (empty tag, non-finite position, start after end,
  // or a window overlapping another of the same tag).
  CalibrationCollector(std::vector<ReferencePoint> points, bool use_truth,
                       CalibrationFitOptions opts);

  // The first site is used; a later one with different text is counted and ignored.
  void set_site(const Site& site);
  bool has_site() const { return site_.has_value(); }
  const Site& site() const { return *site_; }

  void add(const ble_aoa_t& m, double t_s);
  void add_truth(const pose_t& m);
  int64_t events() const { return static_cast<int64_t>(events_.size()); }

  // Needs the site. Throws CalibrationError: a point's tag neither in the site nor heard, a point
  // with no events in its window.
  CalibrationResult fit() const;

 private:
  struct Event {
    int64_t utime;
    double t_s;
    int anchor, tag;  // interned ids
    float azimuth_deg, elevation_deg;
    int16_t channel;
  };
  int intern(std::vector<std::string>& names, std::map<std::string, int>& index,
             const std::string& id);

  std::vector<ReferencePoint> points_;
  bool use_truth_;
  CalibrationFitOptions opts_;
  std::optional<Site> site_;
  int64_t sites_ignored_ = 0;
  std::vector<std::string> anchor_names_, tag_names_;
  std::map<std::string, int> anchor_index_, tag_index_;
  std::vector<Event> events_;
  std::map<std::string, std::vector<std::pair<int64_t, Eigen::Vector3d>>> truth_;
  int64_t truth_in_ = 0;
};

// The site YAML (site.yaml_text) with `estimators.aoa.calibration` set for every fitted anchor:
// its azimuth (and elevation when fitted) replaced, any other entry of the block, any other
// estimators section and every other field kept. YAML comments are not kept: `header` lines go
// first, each as a comment. The result parses back (parse_site_text, parse_calibration; checked:
// throws CalibrationError if it would not).
std::string calibrated_site_yaml(const Site& site, const std::vector<AnchorFit>& fits,
                                 const std::vector<std::string>& header);

}  // namespace ips::aoa
