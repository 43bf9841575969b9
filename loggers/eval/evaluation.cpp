#include "loggers/eval/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ips::eval {

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

void Evaluator::add_truth(const pose_t& m) {
  if (!plausible_utime(m.utime) || !std::isfinite(m.position[0]) || !std::isfinite(m.position[1]) ||
      !std::isfinite(m.position[2])) {
    ++bad_truth_;
    return;
  }
  // Kept sorted by time; a log delivers truth in order, so this is almost always an append.
  auto& s = truth_[m.tag_id];
  const Sample sample{m.utime, m.position[0], m.position[1], m.position[2]};
  auto pos = std::upper_bound(s.begin(), s.end(), m.utime,
                              [](utime_t u, const Sample& a) { return u < a.utime; });
  s.insert(pos, sample);
}

void Evaluator::add_estimate(const std::string& channel, const pose_t& m) {
  estimates_[{channel, m.tag_id}].push_back({m.utime, m.position[0], m.position[1], m.position[2]});
}

void Evaluator::set_static_point(const Eigen::Vector3d& point, bool has_height) {
  static_mode_ = true;
  static_point_ = point;
  static_has_height_ = has_height;
}

bool Evaluator::truth_at(const std::string& tag, utime_t t, double& x, double& y,
                         double& z) const {
  if (!plausible_utime(t)) return false;
  if (static_mode_) {
    x = static_point_.x();
    y = static_point_.y();
    z = static_has_height_ ? static_point_.z() : std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  auto it = truth_.find(tag);
  if (it == truth_.end() || it->second.empty()) return false;
  const auto& s = it->second;
  auto hi = std::lower_bound(s.begin(), s.end(), t,
                             [](const Sample& a, utime_t u) { return a.utime < u; });
  if (hi != s.end() && hi->utime == t) {
    x = hi->x, y = hi->y, z = hi->z;
    return true;
  }
  if (hi == s.begin() || hi == s.end()) return false;
  auto lo = hi - 1;
  if (hi->utime - lo->utime > max_gap_us_) return false;
  const double f = static_cast<double>(t - lo->utime) / static_cast<double>(hi->utime - lo->utime);
  x = lo->x + f * (hi->x - lo->x);
  y = lo->y + f * (hi->y - lo->y);
  z = lo->z + f * (hi->z - lo->z);
  return true;
}

std::vector<ErrorRow> Evaluator::rows() const {
  std::vector<ErrorRow> rows;
  for (const auto& [key, est] : estimates_) {
    ErrorRow row;
    row.channel = key.first;
    row.tag = key.second;
    std::vector<double> h, v;
    double sum = 0, sum_sq = 0, sum_sq_v = 0;
    for (const auto& e : est) {
      double x, y, z;
      if (!truth_at(row.tag, e.utime, x, y, z)) continue;
      const double eh = std::hypot(e.x - x, e.y - y);
      const double ev = e.z - z;
      if (!std::isfinite(eh)) {
        ++row.non_finite;  // an estimator publishing NaN must not score better for it
        continue;
      }
      h.push_back(eh);
      sum += eh;
      sum_sq += eh * eh;
      if (std::isfinite(ev)) {
        sum_sq_v += ev * ev;
        v.push_back(std::abs(ev));
      }
    }
    row.count = h.size();
    if (row.count > 0) {
      const double n = static_cast<double>(row.count);
      row.mean_h = sum / n;
      row.rmse_h = std::sqrt(sum_sq / n);
      const double nv = static_cast<double>(v.size());
      row.rmse_v = v.empty() ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(sum_sq_v / nv);
      double sum_v = 0;
      for (double x : v) sum_v += x;
      row.mean_v = v.empty() ? std::numeric_limits<double>::quiet_NaN() : sum_v / nv;
      row.median_v = percentile(v, 50);
      row.p95_v = percentile(v, 95);
      row.max_v = v.empty() ? std::numeric_limits<double>::quiet_NaN() : v.back();
      row.median_h = percentile(h, 50);
      row.p95_h = percentile(h, 95);
      row.max_h = h.back();
    }
    rows.push_back(row);
  }
  return rows;
}

std::vector<EstimateSeries> Evaluator::estimate_series() const {
  std::vector<EstimateSeries> out;
  out.reserve(estimates_.size());
  for (const auto& [key, est] : estimates_) {
    EstimateSeries series{key.first, key.second, {}};
    series.estimates.reserve(est.size());
    for (const auto& e : est) {
      double x, y, z;
      // The same error as rows(): NaN where rows() skips the estimate.
      double eh = std::numeric_limits<double>::quiet_NaN();
      if (truth_at(key.second, e.utime, x, y, z)) eh = std::hypot(e.x - x, e.y - y);
      if (!std::isfinite(eh)) eh = std::numeric_limits<double>::quiet_NaN();
      series.estimates.push_back({e.utime, e.x, e.y, eh});
    }
    out.push_back(std::move(series));
  }
  return out;
}

size_t Evaluator::unmatched() const {
  size_t n = 0;
  for (const auto& [key, est] : estimates_)
    for (const auto& e : est) {
      double x, y, z;
      if (!truth_at(key.second, e.utime, x, y, z)) ++n;
    }
  return n;
}

}  // namespace ips::eval
