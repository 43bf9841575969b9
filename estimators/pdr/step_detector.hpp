#pragma once
// Step detection on the low-passed vertical (or norm) linear acceleration (source 002 section
// 2.2): a 9th-order 3 Hz Butterworth, then
//   - peak detection, fixed (002): a local maximum above peak_threshold (a_th = 2 m/s^2) at
//     least min_step_interval_s (0.33 s: cadence <= 3 Hz) after the previous step (002 prints
//     (t_{p-1} - t_p) > 0.33, a typo for t_p - t_{p-1});
//   - peak detection, adaptive (the default): the threshold follows the trace's own dynamics.
//     The filtered signal's running mean mu and standard deviation sd (exponential, time
//     constant adaptive_window_s) describe how this phone, in this position, moves now. A step
//     is a local maximum above mu + max(adaptive_k sd, adaptive_floor_mps2), and the next one
//     needs the signal to have fallen below mu - adaptive_hysteresis_k sd in between (a peak
//     and its valley: a double hump of one impact is one step). Fixed 2 m/s^2 misses 30 to
//     90 % of gentle hand-held steps (issue 22); a pocket's swing is 10 m/s^2. The floor keeps
//     a phone at rest, where sd is only sensor noise, from counting its noise. mu also takes
//     out any offset left in the signal (a gravity estimate slightly off).
//   - or zero crossing: a step at each upward zero crossing that follows a trough below
//     -zero_crossing_threshold, at least min_step_interval_s after the previous one (002 gives no
//     numbers for this detector; the threshold is ours).
// Each step reports the extremes of the filtered signal since the previous step (a_max, a_min,
// a_avg: the inputs of the step-length models) and its time.
#include <optional>

#include "core/time.hpp"
#include "estimators/pdr/butterworth.hpp"

namespace ips::pdr {

enum class StepDetectorKind { kPeak, kZeroCrossing };

struct StepDetectorParams {
  StepDetectorKind kind = StepDetectorKind::kPeak;
  int filter_order = 9;              // 002: 9th-order Butterworth
  double filter_cutoff_hz = 3.0;     // 002: fc = 3 Hz
  double peak_threshold = 2.0;       // m/s^2, 002's a_th (adaptive = false)
  bool adaptive = true;              // threshold from the signal's running mean and spread
  double adaptive_k = 0.4;           // peak above mu + k sd ...
  double adaptive_hysteresis_k = 0.6;  // ... and a valley below mu - k_h sd before the next
  double adaptive_floor_mps2 = 0.4;  // peak at least this far above mu
  double adaptive_window_s = 4.0;    // time constant of mu and sd (a few strides)
  double zero_crossing_threshold = 1.0;  // m/s^2, trough depth before an upward crossing
  double min_step_interval_s = 0.33;     // 002
  double max_step_interval_s = 2.0;      // a longer gap starts a new walk: no cadence across it
};

struct DetectedStep {
  utime_t utime = 0;
  double a_max = 0, a_min = 0, a_avg = 0;  // filtered signal since the previous step, m/s^2
  double abs_avg = 0;                      // mean |filtered signal| (Kim's model)
  double interval_s = 0;                   // since the previous step; 0 for the first of a walk
};

class StepDetector {
 public:
  StepDetector(const StepDetectorParams& p, double sample_rate_hz);
  // One sample of the linear acceleration signal (gravity removed), m/s^2.
  std::optional<DetectedStep> add(utime_t t, double signal);
  double filtered() const { return y0_; }
  // The adaptive detector's running mean and spread of the filtered signal.
  double mean() const { return mu_; }
  double spread() const;

 private:
  std::optional<DetectedStep> emit(utime_t t);
  StepDetectorParams p_;
  ButterworthLowPass filter_;
  bool primed_ = false;
  double y0_ = 0, y1_ = 0, y2_ = 0;  // newest first
  utime_t t1_ = 0;
  utime_t last_step_ = 0;
  double max_ = -1e300, min_ = 1e300, sum_ = 0, sum_abs_ = 0;
  int n_ = 0;
  double trough_ = 0;  // zero crossing: the lowest value since the last downward crossing
  double mu_ = 0, var_ = 0;  // adaptive: running mean and variance of the filtered signal
  bool armed_ = true;        // adaptive: a valley since the last step
};

}  // namespace ips::pdr
