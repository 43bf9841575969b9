#include "estimators/uwb_twr/range_calibration.hpp"

#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "core/site_edit.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"

namespace ips::uwb_twr {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double hi = v[mid];
  if (v.size() % 2 == 1) return hi;
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + mid));
}

double rms(const std::vector<double>& v, double minus) {
  double s = 0;
  for (double x : v) s += (x - minus) * (x - minus);
  return v.empty() ? kNaN : std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

RangeCalibration fit_range_offsets(const Site& site, const std::vector<RangeSample>& ranges,
                                   const TruthTracks& truth_in, const RangeCalibrationOptions& opts,
                                   const std::map<std::string, double>& site_offsets,
                                   const std::map<std::string, double>& site_scales) {
  RangeCalibration r;
  TruthTracks truth = truth_in;
  for (auto& [tag, track] : truth)
    std::stable_sort(track.begin(), track.end(),
                     [](const auto& x, const auto& y) { return x.utime < y.utime; });
  const auto window_us = static_cast<int64_t>(std::llround(opts.truth_window_s * 1e6));
  auto truth_at = [&](const std::string& tag, int64_t t) -> std::optional<Eigen::Vector3d> {
    const auto it = truth.find(tag);
    if (it == truth.end() || it->second.empty()) return std::nullopt;
    const auto& tr = it->second;
    auto hi = std::lower_bound(tr.begin(), tr.end(), t,
                               [](const TruthSample& s, int64_t v) { return s.utime < v; });
    if (hi != tr.end() && hi->utime == t) return hi->position;
    if (hi == tr.begin() || hi == tr.end()) return std::nullopt;
    const auto lo = std::prev(hi);
    if (t - lo->utime > window_us || hi->utime - t > window_us) return std::nullopt;
    const double f =
        static_cast<double>(t - lo->utime) / static_cast<double>(hi->utime - lo->utime);
    return lo->position + f * (hi->position - lo->position);
  };

  struct Collected {
    int64_t ranges = 0;
    std::vector<double> residual, distance, range;
  };
  std::map<std::pair<std::string, std::string>, Collected> pairs;
  for (const auto& s : ranges) {
    ++r.stats.ranges_in;
    const Anchor* a = site.find_anchor(s.anchor_id);
    if (!a || a->kind != "uwb" || !a->enabled) {
      ++r.stats.unknown_anchor;
      continue;
    }
    if (site.find_anchor(s.tag_id)) {
      ++r.stats.between_anchors;
      continue;
    }
    if (!std::isfinite(s.range_m) || s.range_m < 0) {
      ++r.stats.invalid_range;
      continue;
    }
    Collected& c = pairs[{s.tag_id, s.anchor_id}];
    ++c.ranges;
    const auto p = truth_at(s.tag_id, s.utime);
    if (!p) {
      ++r.stats.no_truth;
      continue;
    }
    const double d = (*p - a->position).norm();
    c.residual.push_back(s.range_m - d);
    c.distance.push_back(d);
    c.range.push_back(s.range_m);
  }

  for (const auto& [key, c] : pairs) {
    PairCalibration p;
    p.tag_id = key.first;
    p.anchor_id = key.second;
    p.ranges = c.ranges;
    p.n = static_cast<int64_t>(c.residual.size());
    // range / (1 + scale) - d - offset for each range with truth: what a tracker with that
    // scale and offset leaves.
    const Collected& pair = c;  // a structured binding cannot be captured (clang, C++20)
    const auto residuals = [&pair](double scale, double offset) {
      std::vector<double> res(pair.range.size());
      for (size_t i = 0; i < res.size(); ++i)
        res[i] = pair.range[i] / (1.0 + scale) - pair.distance[i] - offset;
      return res;
    };
    p.offset_m = median(c.residual);
    double mean = 0;
    for (double x : c.residual) mean += x;
    mean = p.n > 0 ? mean / static_cast<double>(p.n) : kNaN;
    p.mean_before_m = mean;
    p.rms_before_m = rms(c.residual, 0.0);
    p.std_m = rms(c.residual, mean);
    p.rms_after_m = rms(c.residual, p.offset_m);
    p.median_after_m = median(residuals(0.0, p.offset_m));
    // Least squares range = slope d + b.
    p.scale = p.scale_bias_m = kNaN;
    double distance_spread_m = 0;  // the distances' standard deviation
    if (p.n >= 2) {
      double md = 0, mr = 0;
      for (int64_t i = 0; i < p.n; ++i) md += c.distance[i], mr += c.range[i];
      md /= static_cast<double>(p.n);
      mr /= static_cast<double>(p.n);
      double sdd = 0, sdr = 0;
      for (int64_t i = 0; i < p.n; ++i)
        sdd += (c.distance[i] - md) * (c.distance[i] - md),
            sdr += (c.distance[i] - md) * (c.range[i] - mr);
      distance_spread_m = std::sqrt(sdd / static_cast<double>(p.n));
      if (sdd > 1e-9) {
        const double slope = sdr / sdd;
        p.scale = slope - 1.0;
        p.scale_bias_m = mr - slope * md;
        // The slope's standard error from the line's residual scatter.
        double sse = 0;
        for (int64_t i = 0; i < p.n; ++i) {
          const double e = c.range[i] - (slope * c.distance[i] + p.scale_bias_m);
          sse += e * e;
        }
        if (p.n > 2) p.scale_se = std::sqrt(sse / static_cast<double>(p.n - 2) / sdd);
      }
    }
    // With the scale: the offset in the terms of the unscaled ranges the trackers use.
    // Only a scale the data show: distances that vary, and a slope off 1 by more than
    // scale_min_se standard errors (NLOS and noise tilt a short line; a wrong scale costs more at
    // long range than none).
    if (opts.fit_scale && std::isfinite(p.scale) && distance_spread_m >= opts.min_scale_spread_m &&
        std::abs(p.scale) > opts.scale_min_se * p.scale_se) {
      p.scale_used = true;
      const std::vector<double> res = residuals(p.scale, 0.0);
      p.offset_m = median(res);
      p.rms_after_m = rms(res, p.offset_m);
      p.median_after_m = median(residuals(p.scale, p.offset_m));
    }
    p.site_offset_m = pair_setting(site_offsets, p.tag_id, p.anchor_id);
    p.median_site_m = kNaN;
    if (std::isfinite(p.site_offset_m) && p.n > 0) {
      // As the trackers take them off: divided by the site's 1 + scale, then its offset.
      const double site_scale = pair_setting(site_scales, p.tag_id, p.anchor_id);
      p.median_site_m =
          median(residuals(std::isfinite(site_scale) ? site_scale : 0.0, p.site_offset_m));
    }
    if (p.n == 0) {
      p.refused = fmt::format("no range with truth ({} ranges)", p.ranges);
    } else if (!opts.force && p.n < opts.min_ranges) {
      p.refused =
          fmt::format("{} ranges with truth, fewer than the {} required", p.n, opts.min_ranges);
    } else if (!opts.force && std::abs(p.offset_m) > opts.max_offset_m) {
      p.refused = fmt::format("offset {:+.3f} m outside [-{:g}, {:g}] m", p.offset_m,
                              opts.max_offset_m, opts.max_offset_m);
    } else if (p.scale_used && std::abs(p.scale) > opts.max_scale) {
      // Beyond the site's bound even with --force: the trackers would refuse the site.
      p.refused = fmt::format("scale {:+.4f} outside [-{:g}, {:g}]", p.scale, opts.max_scale,
                              opts.max_scale);
    }
    r.pairs.push_back(p);
  }
  return r;
}

namespace {
// Each accepted pair's value, keyed "A1" when they are all of one tag, else "T1/A1".
template <typename Value>
std::map<std::string, double> pair_values(const std::vector<PairCalibration>& pairs,
                                          Value value) {
  std::map<std::string, double> out;
  std::string one_tag;
  bool several = false;
  for (const auto& p : pairs) {
    if (!p.refused.empty()) continue;
    if (one_tag.empty())
      one_tag = p.tag_id;
    else if (p.tag_id != one_tag)
      several = true;
  }
  for (const auto& p : pairs)
    if (p.refused.empty()) out[several ? p.tag_id + "/" + p.anchor_id : p.anchor_id] = value(p);
  return out;
}
}  // namespace

std::map<std::string, double> offsets_to_write(const std::vector<PairCalibration>& pairs) {
  return pair_values(pairs, [](const PairCalibration& p) { return p.offset_m; });
}

std::map<std::string, double> scales_to_write(const std::vector<PairCalibration>& pairs) {
  // Keyed as offsets_to_write keys all the accepted pairs (one tag or several).
  std::map<std::string, double> out;
  const auto values = pair_values(pairs, [](const PairCalibration& p) {
    return p.scale_used ? p.scale : std::numeric_limits<double>::quiet_NaN();
  });
  for (const auto& [key, value] : values)
    if (std::isfinite(value)) out[key] = value;
  return out;
}

std::string site_with_offsets_yaml(const Site& site, const std::map<std::string, double>& offsets,
                                   const std::vector<std::string>& header,
                                   const std::map<std::string, double>& scales) {
  SiteYamlEdit edit(site);
  // Into a map of the site's estimators.uwb_twr, each value's overriding pair keys dropped.
  const auto merge = [&edit](const char* name, const std::map<std::string, double>& values,
                             int decimals) {
    YAML::Node section = edit.map_at({"estimators", "uwb_twr", name});
    for (const auto& [key, value] : values) {
      if (key.find('/') == std::string::npos) {
        // A pair key of this anchor would override the anchor's value in the trackers.
        std::vector<std::string> drop;
        for (const auto& kv : section) {
          const std::string k = kv.first.Scalar();
          if (k.size() > key.size() + 1 &&
              k.compare(k.size() - key.size() - 1, std::string::npos, "/" + key) == 0)
            drop.push_back(k);
        }
        for (const auto& k : drop) section.remove(k);
      }
      section[key] = YAML::Load(fmt::format("{:.{}f}", value, decimals));
    }
  };
  merge("range_offsets_m", offsets, 4);
  // An offset written without a scale is for unscaled ranges: a scale left for its key would now
  // be wrong.
  YAML::Node twr = edit.map_at({"estimators", "uwb_twr"});
  if (YAML::Node old = twr["range_scales"]; old && old.IsMap()) {
    for (const auto& kv : offsets)
      if (!scales.count(kv.first)) old.remove(kv.first);
    if (old.size() == 0) twr.remove("range_scales");
  }
  if (!scales.empty()) merge("range_scales", scales, 6);
  const std::string text = edit.text(header);
  const Site back = parse_site_text(text, "the calibrated site");
  const TwrParams parsed = parse_twr_params(back.estimator_params("uwb_twr"));
  const auto check = [](const std::map<std::string, double>& want,
                        const std::map<std::string, double>& got, const char* what,
                        double tolerance) {
    for (const auto& [key, value] : want) {
      const auto it = got.find(key);
      if (it == got.end() || std::abs(it->second - value) > tolerance)
        throw ConfigError(std::string("the calibrated site lost the range ") + what + " of " + key);
    }
  };
  check(offsets, parsed.range_offsets_m, "offset", 1e-4);
  check(scales, parsed.range_scales, "scale", 1e-6);
  return text;
}

}  // namespace ips::uwb_twr
