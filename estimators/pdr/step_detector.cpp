#include "estimators/pdr/step_detector.hpp"

#include <algorithm>
#include <cmath>

namespace ips::pdr {

StepDetector::StepDetector(const StepDetectorParams& p, double sample_rate_hz)
    : p_(p), filter_(p.filter_order, p.filter_cutoff_hz, sample_rate_hz) {}

std::optional<DetectedStep> StepDetector::emit(utime_t t) {
  DetectedStep s;
  s.utime = t;
  s.a_max = max_;
  s.a_min = min_;
  s.a_avg = n_ > 0 ? sum_ / n_ : 0.0;
  s.abs_avg = n_ > 0 ? sum_abs_ / n_ : 0.0;
  const double interval = last_step_ ? utime_to_s(t - last_step_) : 0.0;
  s.interval_s = interval <= p_.max_step_interval_s ? interval : 0.0;
  last_step_ = t;
  max_ = -1e300;
  min_ = 1e300;
  sum_ = 0;
  sum_abs_ = 0;
  n_ = 0;
  return s;
}

double StepDetector::spread() const { return std::sqrt(std::max(var_, 0.0)); }

std::optional<DetectedStep> StepDetector::add(utime_t t, double signal) {
  if (!primed_) {
    filter_.reset(signal);
    y0_ = y1_ = y2_ = signal;
    mu_ = signal;
    var_ = 0;
    primed_ = true;
  }
  const double dt = t1_ && t > t1_ ? utime_to_s(t - t1_) : 0.0;
  y2_ = y1_;
  y1_ = y0_;
  y0_ = filter_.step(signal);
  // Exponential running mean and variance (West's incremental form).
  const double alpha = std::min(1.0, dt / p_.adaptive_window_s);
  const double d = y0_ - mu_;
  mu_ += alpha * d;
  var_ = (1 - alpha) * (var_ + alpha * d * d);
  max_ = std::max(max_, y0_);
  min_ = std::min(min_, y0_);
  sum_ += y0_;
  sum_abs_ += std::abs(y0_);
  ++n_;
  const bool spaced =
      last_step_ == 0 || utime_to_s(t - last_step_) >= p_.min_step_interval_s;
  std::optional<DetectedStep> out;
  if (p_.kind == StepDetectorKind::kPeak && p_.adaptive) {
    const double sd = spread();
    if (!armed_ && y0_ < mu_ - p_.adaptive_hysteresis_k * sd) armed_ = true;
    const double threshold = std::max(p_.adaptive_k * sd, p_.adaptive_floor_mps2);
    if (y1_ > y2_ && y1_ >= y0_ && y1_ - mu_ > threshold && armed_ && spaced) {
      out = emit(t1_);
      armed_ = false;
    }
  } else if (p_.kind == StepDetectorKind::kPeak) {
    // y1 is a local maximum: rising into it, not rising out of it.
    if (y1_ > y2_ && y1_ >= y0_ && y1_ > p_.peak_threshold && spaced) out = emit(t1_);
  } else {
    if (y0_ < 0) trough_ = std::min(trough_, y0_);
    if (y1_ < 0 && y0_ >= 0) {
      if (trough_ < -p_.zero_crossing_threshold && spaced) out = emit(t);
      trough_ = 0;
    }
  }
  t1_ = t;
  return out;
}

}  // namespace ips::pdr
