#include "estimators/altitude/offset_calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/barometric.hpp"
#include "core/site_edit.hpp"
#include "core/text_escape.hpp"

namespace ips::altitude {

namespace {
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr size_t kMaxReadings = 20'000'000;  // about 23 days of 10 Hz from one sensor
}  // namespace

OffsetCalibration::OffsetCalibration(OffsetCalibrationOptions options)
    : opt_(std::move(options)) {}

void OffsetCalibration::on_baro(const baro_t& m) {
  if (m.sensor_id.empty() || !plausible_utime(m.utime) ||
      !(m.pressure_pa >= 30000 && m.pressure_pa <= 125000)) {
    ++dropped_;
    return;
  }
  Series& s = sensors_[m.sensor_id];
  if ((!s.readings.empty() && m.utime <= s.readings.back().utime) ||
      s.readings.size() >= kMaxReadings) {
    ++dropped_;
    return;
  }
  if (m.is_reference) {
    s.is_reference = true;
    if (std::isfinite(m.known_height_m)) s.known_height_m = m.known_height_m;
  }
  s.readings.push_back({m.utime, m.pressure_pa, m.temperature_c, m.humidity_pct});
}

std::vector<SensorOffset> OffsetCalibration::finish() const {
  std::vector<std::string> references;
  for (const auto& [id, s] : sensors_)
    if (s.is_reference) references.push_back(id);
  auto list = [](const std::vector<std::string>& ids) {
    std::string out;
    for (const auto& id : ids) out += (out.empty() ? "" : ", ") + printable(id);
    return out.empty() ? std::string("none") : out;
  };
  std::string ref_id = opt_.reference;
  if (ref_id.empty()) {
    if (references.empty())
      throw OffsetCalibrationError(
          "no reference station in the log (no BARO reading marked is_reference): name the "
          "sensor the others sat beside with --reference ID");
    if (references.size() > 1)
      throw OffsetCalibrationError("several reference stations in the log (" + list(references) +
                                   "): choose one with --reference ID");
    ref_id = references.front();
  }
  const auto ref_it = sensors_.find(ref_id);
  if (ref_it == sensors_.end()) {
    std::vector<std::string> heard;
    for (const auto& kv : sensors_) heard.push_back(kv.first);
    throw OffsetCalibrationError("reference '" + printable(ref_id) +
                                 "' has no reading in the log (sensors heard: " + list(heard) +
                                 ")");
  }
  chosen_reference_ = ref_id;
  const auto own = opt_.site_offsets_pa.find(ref_id);
  const double ref_offset = own == opt_.site_offsets_pa.end() ? 0.0 : own->second;
  const std::vector<Reading>& ref = ref_it->second.readings;
  double ref_height = ref_it->second.known_height_m;
  if (!std::isfinite(ref_height) && site_)
    for (const auto& st : site_->baro_stations)
      if (st.id == ref_id) ref_height = st.position.z();

  utime_t t0 = std::numeric_limits<utime_t>::max();
  for (const auto& kv : sensors_)
    if (!kv.second.readings.empty()) t0 = std::min(t0, kv.second.readings.front().utime);
  const utime_t max_gap = s_to_utime(opt_.max_pair_gap_s);

  std::vector<SensorOffset> out;
  for (const auto& [id, s] : sensors_) {
    if (id == ref_id) continue;
    SensorOffset r;
    r.sensor_id = id;
    r.readings = static_cast<int64_t>(s.readings.size());
    const auto height = opt_.heights_m.find(id);
    if (height != opt_.heights_m.end() && !std::isfinite(ref_height))
      throw OffsetCalibrationError(
          "a height is given for " + printable(id) + " but the reference " + printable(ref_id) +
          " has no known height (neither in its readings nor in the site's baro_stations)");
    const utime_t start = std::max(s.readings.front().utime, ref.front().utime) +
                          s_to_utime(opt_.settle_s);
    const utime_t end = opt_.span_s > 0 ? start + s_to_utime(opt_.span_s)
                                        : std::numeric_limits<utime_t>::max();
    r.window_start_s = utime_to_s(start - t0);
    r.window_end_s = r.window_start_s;
    // Sums for the mean, the spread and the slope of the differences (times in minutes from
    // the window's start, for conditioning).
    double n = 0, sum = 0, sum_sq = 0, sum_t = 0, sum_tt = 0, sum_td = 0, sum_p = 0, sum_k = 0;
    for (const Reading& x : s.readings) {
      if (x.utime < start || x.utime > end) continue;
      const auto after = std::lower_bound(
          ref.begin(), ref.end(), x.utime,
          [](const Reading& a, utime_t t) { return a.utime < t; });
      double p_ref = kNaN, t_ref = kNaN;
      if (after != ref.end() && after->utime == x.utime) {
        p_ref = after->pressure_pa;
        t_ref = after->temperature_c;
      } else if (after != ref.end() && after != ref.begin() &&
                 after->utime - (after - 1)->utime <= 2 * max_gap) {
        const Reading& a = *(after - 1);
        const double f = static_cast<double>(x.utime - a.utime) /
                         static_cast<double>(after->utime - a.utime);
        p_ref = a.pressure_pa + f * (after->pressure_pa - a.pressure_pa);
        t_ref = a.temperature_c + f * (after->temperature_c - a.temperature_c);
      } else if (after == ref.end() && x.utime - ref.back().utime <= max_gap) {
        p_ref = ref.back().pressure_pa;
        t_ref = ref.back().temperature_c;
      }
      if (std::isnan(p_ref)) continue;
      p_ref -= ref_offset;
      const double temperature =
          std::isfinite(t_ref) ? t_ref : std::isfinite(x.temperature_c) ? x.temperature_c
                                                                        : opt_.temperature_c;
      const double k = barometric::inverse_scale_height_per_m(temperature, opt_.humidity_pct,
                                                              p_ref, opt_.gravity_mps2);
      const double expected =
          height == opt_.heights_m.end()
              ? 0.0
              : barometric::pressure_above_pa(p_ref, height->second - ref_height, k) - p_ref;
      const double d = x.pressure_pa - p_ref - expected;
      const double t_min = utime_to_s(x.utime - start) / 60.0;
      n += 1;
      sum += d;
      sum_sq += d * d;
      sum_t += t_min;
      sum_tt += t_min * t_min;
      sum_td += t_min * d;
      sum_p += x.pressure_pa;
      sum_k += k;
      r.expected_difference_pa = expected;
      r.window_end_s = utime_to_s(x.utime - t0);
    }
    r.used = static_cast<int64_t>(n);
    if (n > 0) {
      r.offset_pa = sum / n;
      r.sigma_pa = std::sqrt(std::max(0.0, sum_sq / n - r.offset_pa * r.offset_pa));
      const double var_t = sum_tt / n - (sum_t / n) * (sum_t / n);
      r.drift_pa_per_min = var_t > 0 ? (sum_td / n - (sum_t / n) * r.offset_pa) / var_t : 0.0;
      r.offset_height_m = -r.offset_pa / ((sum_k / n) * (sum_p / n));
    }
    out.push_back(r);
  }
  return out;
}

std::string site_with_offsets(const Site& site, const std::vector<SensorOffset>& offsets,
                              const std::vector<std::string>& header) {
  SiteYamlEdit edit(site);
  YAML::Node table = edit.map_at({"estimators", "altitude", "offsets_pa"});
  for (const auto& o : offsets) {
    if (o.used == 0) continue;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f", o.offset_pa);
    table[o.sensor_id] = YAML::Load(buf);
  }
  return edit.text(header);
}

}  // namespace ips::altitude
