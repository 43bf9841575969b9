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

std::optional<DetectedStep> StepDetector::add(utime_t t, double signal) {
  if (!primed_) {
    filter_.reset(signal);
    y0_ = y1_ = y2_ = signal;
    primed_ = true;
  }
  y2_ = y1_;
  y1_ = y0_;
  y0_ = filter_.step(signal);
  max_ = std::max(max_, y0_);
  min_ = std::min(min_, y0_);
  sum_ += y0_;
  sum_abs_ += std::abs(y0_);
  ++n_;
  const bool spaced =
      last_step_ == 0 || utime_to_s(t - last_step_) >= p_.min_step_interval_s;
  std::optional<DetectedStep> out;
  if (p_.kind == StepDetectorKind::kPeak) {
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
