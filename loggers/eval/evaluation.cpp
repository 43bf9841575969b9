#include "loggers/eval/evaluation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ips::eval {

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// -1, 0, 1 as a < b, a == b, a > b in natural order (digit runs as numbers).
int natural_compare(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (is_digit(a[i]) && is_digit(b[j])) {
      size_t ie = i, je = j;
      while (ie < a.size() && is_digit(a[ie])) ++ie;
      while (je < b.size() && is_digit(b[je])) ++je;
      // Compare without leading zeros: the longer run is the larger number, else digit by digit
      // (no overflow however long the run).
      size_t iz = i, jz = j;
      while (iz + 1 < ie && a[iz] == '0') ++iz;
      while (jz + 1 < je && b[jz] == '0') ++jz;
      if (ie - iz != je - jz) return ie - iz < je - jz ? -1 : 1;
      const int c = a.compare(iz, ie - iz, b, jz, je - jz);
      if (c != 0) return c < 0 ? -1 : 1;
      i = ie, j = je;
      continue;
    }
    if (a[i] != b[j])
      return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]) ? -1 : 1;
    ++i, ++j;
  }
  if (i < a.size()) return 1;
  if (j < b.size()) return -1;
  return 0;
}

template <class Row>
void sort_rows(std::vector<Row>& rows) {
  std::sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
    if (a.channel != b.channel) return natural_less(a.channel, b.channel);
    return natural_less(a.tag, b.tag);
  });
}

}  // namespace

bool natural_less(const std::string& a, const std::string& b) {
  const int c = natural_compare(a, b);
  return c != 0 ? c < 0 : a < b;
}

double percentile(std::vector<double>& v, double p) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const double pos = std::clamp(p, 0.0, 100.0) / 100.0 * static_cast<double>(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

struct Evaluator::Accumulator {
  std::vector<double> h, v;
  double sum = 0, sum_sq = 0, sum_sq_v = 0;
  size_t non_finite = 0;

  ErrorRow finish(const std::string& channel, const std::string& tag, size_t tags) {
    ErrorRow row;
    row.channel = channel;
    row.tag = tag;
    row.tags = tags;
    row.non_finite = non_finite;
    row.count = h.size();
    row.count_v = v.size();
    if (row.count == 0) return row;
    const double n = static_cast<double>(row.count);
    row.mean_h = sum / n;
    row.rmse_h = std::sqrt(sum_sq / n);
    const double nv = static_cast<double>(v.size());
    row.rmse_v = v.empty() ? kNotMeasured : std::sqrt(sum_sq_v / nv);
    double sum_v = 0;
    for (double x : v) sum_v += x;
    row.mean_v = v.empty() ? kNotMeasured : sum_v / nv;
    row.median_v = percentile(v, 50);
    row.p95_v = percentile(v, 95);
    row.max_v = v.empty() ? kNotMeasured : v.back();
    row.median_h = percentile(h, 50);
    row.p95_h = percentile(h, 95);
    row.max_h = h.back();
    return row;
  }
};

struct Evaluator::AltitudeAccumulator {
  std::vector<double> abs_err;
  double sum = 0, sum_sq = 0;
  size_t non_finite = 0, floor_count = 0, floor_right = 0;

  AltitudeRow finish(const std::string& channel, const std::string& tag, size_t tags) {
    AltitudeRow row;
    row.channel = channel;
    row.tag = tag;
    row.tags = tags;
    row.non_finite = non_finite;
    row.count = abs_err.size();
    row.floor_count = floor_count;
    row.floor_right = floor_right;
    if (row.count == 0) return row;
    const double n = static_cast<double>(row.count);
    row.bias = sum / n;
    row.rmse = std::sqrt(sum_sq / n);
    row.p95 = percentile(abs_err, 95);
    row.max = abs_err.back();
    return row;
  }
};

void Evaluator::set_window(utime_t from, utime_t to) {
  window_from_ = from;
  window_to_ = to;
}

void Evaluator::add_truth(const pose_t& m) {
  if (!plausible_utime(m.utime) || !std::isfinite(m.position[0]) || !std::isfinite(m.position[1]) ||
      !std::isfinite(m.position[2])) {
    ++bad_truth_;
    return;
  }
  // Truth more than the gap outside the window cannot be interpolated at a time inside it.
  if (window_from_ != std::numeric_limits<utime_t>::min() && m.utime < window_from_ - max_gap_us_)
    return;
  if (window_to_ != std::numeric_limits<utime_t>::max() && m.utime > window_to_ + max_gap_us_)
    return;
  // Kept sorted by time; a log delivers truth in order, so this is almost always an append.
  auto& s = truth_[m.tag_id];
  const PositionSample sample{m.utime, m.position[0], m.position[1], m.position[2]};
  auto pos = std::upper_bound(s.begin(), s.end(), m.utime,
                              [](utime_t u, const PositionSample& a) { return u < a.utime; });
  s.insert(pos, sample);
}

void Evaluator::add_estimate(const std::string& channel, const pose_t& m) {
  if (!in_window(m.utime)) {
    ++outside_window_;
    return;
  }
  estimates_[{channel, m.tag_id}].push_back({m.utime, m.position[0], m.position[1], m.position[2],
                                             (m.status & pose_t::STATUS_2D) != 0});
}

void Evaluator::add_altitude(const std::string& channel, const altitude_t& m) {
  if (!in_window(m.utime)) {
    ++outside_window_;
    return;
  }
  altitudes_[{channel, m.tag_id}].push_back({m.utime, m.height_m, m.floor, m.floor_valid != 0});
}

void Evaluator::set_static_point(const Eigen::Vector3d& point, bool has_height) {
  static_mode_ = true;
  static_point_ = point;
  static_has_height_ = has_height;
}

void Evaluator::set_dwell_intervals(std::vector<DwellInterval> intervals) {
  std::stable_sort(intervals.begin(), intervals.end(),
                   [](const DwellInterval& a, const DwellInterval& b) { return a.start < b.start; });
  dwell_ = std::move(intervals);
  dwell_mode_ = true;
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
  if (dwell_mode_) {
    // Intervals are few (tens): a scan is fast enough and keeps "first by start" obvious.
    for (const auto& d : dwell_) {
      if (d.start > t) break;
      if (t <= d.end && (d.tag.empty() || d.tag == tag)) {
        x = d.x, y = d.y, z = d.z;
        return true;
      }
    }
    return false;
  }
  auto it = truth_.find(tag);
  if (it == truth_.end() || it->second.empty()) return false;
  const auto& s = it->second;
  auto hi = std::lower_bound(s.begin(), s.end(), t,
                             [](const PositionSample& a, utime_t u) { return a.utime < u; });
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

bool Evaluator::floor_of(double height_m, int& floor) const {
  const auto& h = floors_.heights_m;
  if (h.empty() || !std::isfinite(height_m)) return false;
  size_t nearest = 0;
  for (size_t i = 1; i < h.size(); ++i)
    if (std::abs(height_m - floors_.carry_height_m - h[i]) <
        std::abs(height_m - floors_.carry_height_m - h[nearest]))
      nearest = i;
  floor = floors_.first_index + static_cast<int>(nearest);
  return true;
}

bool Evaluator::height_is_fixed(const std::vector<Sample>& est) {
  size_t n = 0;
  double z0 = 0;
  for (const auto& e : est) {
    if (e.planar || !std::isfinite(e.z)) continue;
    if (n++ == 0)
      z0 = e.z;
    else if (e.z != z0)
      return false;
  }
  return n >= 2;
}

void Evaluator::score(const std::string& tag, const std::vector<Sample>& est,
                      Accumulator& acc) const {
  // A series whose z never changes (every estimate at one height, at least two of them) carries a
  // fixed height, not an estimate of it, even without STATUS_2D (a module that reports its
  // configured height; the simulated INS module on the lab's level walk): its vertical error is
  // not scored either.
  const bool fixed_height = height_is_fixed(est);
  for (const auto& e : est) {
    double x, y, z;
    if (!truth_at(tag, e.utime, x, y, z)) continue;
    const double eh = std::hypot(e.x - x, e.y - y);
    if (!std::isfinite(eh)) {
      ++acc.non_finite;  // an estimator publishing NaN must not score better for it
      continue;
    }
    acc.h.push_back(eh);
    acc.sum += eh;
    acc.sum_sq += eh * eh;
    // A 2D estimate's z is the site's fixed tag height, not an estimate: not scored.
    const double ev = e.z - z;
    if (!e.planar && !fixed_height && std::isfinite(ev)) {
      acc.sum_sq_v += ev * ev;
      acc.v.push_back(std::abs(ev));
    }
  }
}

void Evaluator::score(const std::string& tag, const std::vector<AltitudeSample>& est,
                      AltitudeAccumulator& acc) const {
  for (const auto& e : est) {
    double x, y, z;
    if (!truth_at(tag, e.utime, x, y, z) || !std::isfinite(z)) continue;
    const double err = e.height_m - z;
    if (!std::isfinite(err)) {
      ++acc.non_finite;
      continue;
    }
    acc.abs_err.push_back(std::abs(err));
    acc.sum += err;
    acc.sum_sq += err * err;
    int truth_floor = 0;
    if (e.floor_valid && floor_of(z, truth_floor)) {
      ++acc.floor_count;
      if (e.floor == truth_floor) ++acc.floor_right;
    }
  }
}

std::vector<ErrorRow> Evaluator::rows() const {
  std::vector<ErrorRow> rows;
  for (const auto& [key, est] : estimates_) {
    Accumulator acc;
    score(key.second, est, acc);
    rows.push_back(acc.finish(key.first, key.second, 1));
  }
  sort_rows(rows);
  return rows;
}

std::vector<ErrorRow> Evaluator::rows_by_channel() const {
  std::vector<ErrorRow> rows;
  auto it = estimates_.begin();
  while (it != estimates_.end()) {
    const std::string& channel = it->first.first;
    Accumulator acc;
    size_t tags = 0;
    for (; it != estimates_.end() && it->first.first == channel; ++it, ++tags)
      score(it->first.second, it->second, acc);
    rows.push_back(acc.finish(channel, kAllTags, tags));
  }
  sort_rows(rows);
  return rows;
}

std::vector<AltitudeRow> Evaluator::altitude_rows() const {
  std::vector<AltitudeRow> rows;
  for (const auto& [key, est] : altitudes_) {
    AltitudeAccumulator acc;
    score(key.second, est, acc);
    rows.push_back(acc.finish(key.first, key.second, 1));
  }
  sort_rows(rows);
  return rows;
}

std::vector<AltitudeRow> Evaluator::altitude_rows_by_channel() const {
  std::vector<AltitudeRow> rows;
  auto it = altitudes_.begin();
  while (it != altitudes_.end()) {
    const std::string& channel = it->first.first;
    AltitudeAccumulator acc;
    size_t tags = 0;
    for (; it != altitudes_.end() && it->first.first == channel; ++it, ++tags)
      score(it->first.second, it->second, acc);
    rows.push_back(acc.finish(channel, kAllTags, tags));
  }
  sort_rows(rows);
  return rows;
}

std::vector<EstimateSeries> Evaluator::estimate_series() const {
  std::vector<EstimateSeries> out;
  out.reserve(estimates_.size());
  for (const auto& [key, est] : estimates_) {
    EstimateSeries series{key.first, key.second, {}};
    series.estimates.reserve(est.size());
    const bool fixed_height = height_is_fixed(est);
    for (const auto& e : est) {
      double x, y, z;
      // The same error as rows(): NaN where rows() skips the estimate.
      double eh = std::numeric_limits<double>::quiet_NaN();
      if (truth_at(key.second, e.utime, x, y, z)) eh = std::hypot(e.x - x, e.y - y);
      if (!std::isfinite(eh)) eh = std::numeric_limits<double>::quiet_NaN();
      const double height = e.planar || fixed_height || !std::isfinite(e.z)
                                ? std::numeric_limits<double>::quiet_NaN()
                                : e.z;
      series.has_height = series.has_height || std::isfinite(height);
      series.estimates.push_back({e.utime, e.x, e.y, eh, height});
    }
    out.push_back(std::move(series));
  }
  sort_rows(out);
  return out;
}

std::vector<AltitudeSeries> Evaluator::altitude_series() const {
  std::vector<AltitudeSeries> out;
  out.reserve(altitudes_.size());
  for (const auto& [key, est] : altitudes_) {
    AltitudeSeries series{key.first, key.second, {}};
    series.heights.reserve(est.size());
    for (const auto& e : est) series.heights.push_back({e.utime, e.height_m});
    out.push_back(std::move(series));
  }
  sort_rows(out);
  return out;
}

size_t Evaluator::unmatched() const {
  size_t n = 0;
  double x, y, z;
  for (const auto& [key, est] : estimates_)
    for (const auto& e : est)
      if (!truth_at(key.second, e.utime, x, y, z)) ++n;
  return n;
}

size_t Evaluator::altitudes_unmatched() const {
  size_t n = 0;
  double x, y, z;
  for (const auto& [key, est] : altitudes_)
    for (const auto& e : est)
      if (!truth_at(key.second, e.utime, x, y, z) || !std::isfinite(z)) ++n;
  return n;
}

size_t Evaluator::altitudes() const {
  size_t n = 0;
  for (const auto& [key, est] : altitudes_) n += est.size();
  return n;
}

}  // namespace ips::eval
