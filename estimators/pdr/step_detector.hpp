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
//   The running mean starts at 0, not at the first sample: the signal has gravity removed, and
//   a walk that starts before the alignment ends replays its first sample mid-swing (a mean
//   started there biased the threshold for seconds).
// Each step reports the extremes of the filtered signal since the previous step (a_max, a_min,
// a_avg: the inputs of the step-length models) and its time.
//
// Cadence (adaptive peak detector, cadence_fill): a peak detector misses a step now and then
// inside a steady walk, and some carrying positions show one clear peak per stride for a while
// (a swinging arm at the start of a walk: the arm's pendulum swing at half the step frequency
// dominates the footfalls; the valley between the two steps of a stride is too shallow to re-arm
// the hysteresis). The walk's own step period P is measured from the autocorrelation of the
// filtered signal over the last cadence_window_s (resampled at 50 Hz): the shortest lag
// between min_step_interval_s and max_step_interval_s whose peak is at least 0.85 of the
// highest (a steady walk correlates as well at two or three steps as at one); when that lag is
// a stride (two steps that look different, as in a pocket or a swinging arm), its half: the
// half lag also has a positive autocorrelation peak (>= 0.2), or the recent detected intervals
// are near it.
// When a step comes two periods after the previous one (|gap / P - 2| <= cadence_tolerance)
// and the window is clearly periodic (autocorrelation at P's lag >= cadence_min_corr), the
// step between them is counted too (DetectedStep::missed = 1, half-way in time; both get the
// interval gap / 2). At most one per gap: a longer gap is a pause, a turn, a stop, not a walk
// at its cadence. The detector's misses then matter little: on steps-oxford, over adaptive_k
// 0.4 to 0.8 and adaptive_hysteresis_k 0.6 to 0.8, the mean count error stays within 1.8 to
// 2.3 % (without: 2.2 to 7.1 %, worst trace up to 33 %).
#include <cstdint>
#include <optional>
#include <vector>

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
  bool cadence_fill = true;              // count the step missed inside a periodic walk
  double cadence_window_s = 5.0;         // autocorrelation window (a few strides)
  double cadence_min_corr = 0.5;         // autocorrelation at the step period: a steady walk
  double cadence_tolerance = 0.25;       // |gap / period - 2| for one missed step
};

struct DetectedStep {
  utime_t utime = 0;
  double a_max = 0, a_min = 0, a_avg = 0;  // filtered signal since the previous step, m/s^2
  double abs_avg = 0;                      // mean |filtered signal| (Kim's model)
  double interval_s = 0;                   // since the previous step; 0 for the first of a walk
  // Steps the walk's cadence says the peaks missed just before this one (0 or 1), each
  // interval_s before the next; they share this step's a_max, a_min, a_avg, abs_avg.
  int missed = 0;
};

// The step and the missed ones before it, oldest first, each with its own time.
std::vector<DetectedStep> with_missed(const DetectedStep& step);

class StepDetector {
 public:
  StepDetector(const StepDetectorParams& p, double sample_rate_hz);
  // One sample of the linear acceleration signal (gravity removed), m/s^2.
  std::optional<DetectedStep> add(utime_t t, double signal);
  double filtered() const { return y0_; }
  // The adaptive detector's running mean and spread of the filtered signal.
  double mean() const { return mu_; }
  double spread() const;
  // The walk's step period (s) from the autocorrelation of the last cadence_window_s, and that
  // autocorrelation (0 when the window is too short or shows no period).
  double step_period(double* corr) const;
  int64_t missed_steps() const { return missed_total_; }  // counted from the cadence

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
  // Cadence: the filtered signal on a 50 Hz grid (newest last), the next grid time, the
  // recent detected intervals.
  std::vector<double> grid_;
  double grid_t_ = 0;
  std::vector<double> recent_;
  int64_t missed_total_ = 0;
};

}  // namespace ips::pdr
