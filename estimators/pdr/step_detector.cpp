#include "estimators/pdr/step_detector.hpp"

#include <algorithm>
#include <cmath>

namespace ips::pdr {

namespace {
constexpr double kGridDt = 0.02;           // s: the cadence's 50 Hz grid (3 Hz filtered signal)
constexpr double kHalfLagMinCorr = 0.2;    // a stride's half lag still a (positive) step peak
constexpr double kRecentRatio = 0.25;      // recent intervals within 25 % of the half lag
constexpr size_t kRecentSteps = 8;         // detected intervals kept for that check
constexpr double kNearTop = 0.85;          // a shorter lag's peak this close to the highest
}  // namespace

std::vector<DetectedStep> with_missed(const DetectedStep& step) {
  std::vector<DetectedStep> out;
  for (int i = step.missed; i >= 1; --i) {
    DetectedStep m = step;
    m.missed = 0;
    m.utime = step.utime - static_cast<utime_t>(std::llround(i * step.interval_s * 1e6));
    out.push_back(m);
  }
  out.push_back(step);
  out.back().missed = 0;
  return out;
}

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

double StepDetector::step_period(double* corr) const {
  *corr = 0;
  const int n = std::min(static_cast<int>(grid_.size()),
                         static_cast<int>(std::lround(p_.cadence_window_s / kGridDt)));
  const int lmin = std::max(2, static_cast<int>(std::floor(p_.min_step_interval_s / kGridDt)));
  const int lmax =
      std::min(static_cast<int>(std::ceil(p_.max_step_interval_s / kGridDt)), n / 2);
  if (lmax <= lmin + 1) return 0;
  const size_t off = grid_.size() - static_cast<size_t>(n);
  double mean = 0;
  for (int i = 0; i < n; ++i) mean += grid_[off + static_cast<size_t>(i)];
  mean /= n;
  // The window less its mean, once (not per lag: the same numbers).
  std::vector<double> c(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i)
    c[static_cast<size_t>(i)] = grid_[off + static_cast<size_t>(i)] - mean;
  // Normalised autocorrelation over the overlap, lags lmin - 1 .. lmax + 1.
  std::vector<double> r(static_cast<size_t>(lmax + 2), 0.0);
  for (int lag = lmin - 1; lag <= lmax + 1; ++lag) {
    double sxy = 0, sxx = 0, syy = 0;
    for (int i = 0; i + lag < n; ++i) {
      const double a = c[static_cast<size_t>(i)];
      const double b = c[static_cast<size_t>(i + lag)];
      sxy += a * b;
      sxx += a * a;
      syy += b * b;
    }
    r[static_cast<size_t>(lag)] = sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
  }
  const auto peak = [&r](int lag) {
    const auto l = static_cast<size_t>(lag);
    return r[l] > r[l - 1] && r[l] >= r[l + 1];
  };
  int top = -1;
  for (int lag = lmin; lag <= lmax; ++lag)
    if (peak(lag) && (top < 0 || r[static_cast<size_t>(lag)] > r[static_cast<size_t>(top)]))
      top = lag;
  if (top < 0) return 0;
  // The shortest lag whose peak is nearly as high: a steady walk correlates about as well at
  // two and three steps as at one, and a multiple of the period is not the period.
  int best = top;
  for (int lag = lmin; lag < top; ++lag)
    if (peak(lag) && r[static_cast<size_t>(lag)] >= kNearTop * r[static_cast<size_t>(top)]) {
      best = lag;
      break;
    }
  *corr = r[static_cast<size_t>(best)];
  // Is the best lag a stride? Its half is then a step: a positive peak there too (the two steps
  // of a stride alike enough), or the detector's own recent intervals near it.
  const double half = best / 2.0;
  int half_peak = -1;
  for (int lag = lmin; lag <= lmax; ++lag)
    if (std::abs(lag - half) <= 0.15 * half + 1 && peak(lag) &&
        r[static_cast<size_t>(lag)] >= kHalfLagMinCorr &&
        (half_peak < 0 || r[static_cast<size_t>(lag)] > r[static_cast<size_t>(half_peak)]))
      half_peak = lag;
  if (half_peak > 0) return half_peak * kGridDt;
  if (half >= lmin && !recent_.empty()) {
    std::vector<double> v = recent_;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    const double median = v[v.size() / 2];
    if (std::abs(median / (half * kGridDt) - 1) < kRecentRatio) return half * kGridDt;
  }
  return best * kGridDt;
}

std::optional<DetectedStep> StepDetector::add(utime_t t, double signal) {
  if (!primed_) {
    filter_.reset(signal);
    y0_ = y1_ = y2_ = signal;
    mu_ = 0;  // gravity removed: the signal's mean is 0, whatever the first sample is
    var_ = 0;
    primed_ = true;
    grid_t_ = utime_to_s(t);
  }
  const double dt = t1_ && t > t1_ ? utime_to_s(t - t1_) : 0.0;
  y2_ = y1_;
  y1_ = y0_;
  y0_ = filter_.step(signal);
  if (p_.cadence_fill) {
    // The filtered signal on the cadence's grid, linear between samples.
    const double ts = utime_to_s(t);
    const double t1s = t1_ ? utime_to_s(t1_) : ts;
    while (grid_t_ <= ts) {
      const double f = ts > t1s ? std::clamp((grid_t_ - t1s) / (ts - t1s), 0.0, 1.0) : 1.0;
      grid_.push_back(y1_ + f * (y0_ - y1_));
      grid_t_ += kGridDt;
    }
    const auto keep = static_cast<size_t>(std::ceil(p_.cadence_window_s / kGridDt)) + 1;
    if (grid_.size() > 2 * keep)
      grid_.erase(grid_.begin(), grid_.end() - static_cast<long>(keep));
  }
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
      const double gap = out->interval_s;
      if (p_.cadence_fill && gap > 0) {
        double corr = 0;
        const double period = gap >= 1.5 * p_.min_step_interval_s ? step_period(&corr) : 0.0;
        if (period > 0 && corr >= p_.cadence_min_corr &&
            std::abs(gap / period - 2) <= p_.cadence_tolerance) {
          out->missed = 1;
          out->interval_s = gap / 2;
          ++missed_total_;
        }
        recent_.push_back(gap);
        if (recent_.size() > kRecentSteps) recent_.erase(recent_.begin());
      } else if (gap == 0) {
        recent_.clear();  // a new walk
      }
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
