#include "estimators/aoa/calibration_fit.hpp"

#include <spdlog/fmt/fmt.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/site_edit.hpp"

namespace ips::aoa {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
// The polynomial is solved in u = theta / 90 so that the columns 1, u, u^2, u^3 are of one size.
constexpr double kScaleDeg = 90.0;

double median_of(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  const double upper = v[mid];
  if (v.size() % 2 == 1) return upper;
  const double lower = *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid));
  return 0.5 * (lower + upper);
}

// One row of the fit: the centre (median or mean) of the measured angles of a group of samples
// with one reference angle, the group's mean reference angle, its size as the weight.
struct GroupPoint {
  double measured_deg, true_deg, weight;
};

// Weighted least squares Theta = P(theta) of `degree` through the group points; degree 0 is
// Theta = theta + c0. nullopt when the system is rank-deficient.
std::optional<std::array<double, 4>> solve_polynomial(const std::vector<GroupPoint>& g,
                                                      int degree) {
  double wsum = 0;
  for (const auto& p : g) wsum += p.weight;
  if (g.empty() || !(wsum > 0)) return std::nullopt;
  if (degree == 0) {
    double s = 0;
    for (const auto& p : g) s += p.weight * (p.true_deg - p.measured_deg);
    return std::array<double, 4>{s / wsum, 1.0, 0.0, 0.0};
  }
  const int cols = degree + 1;
  if (static_cast<int>(g.size()) < cols) return std::nullopt;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(g.size()), cols);
  Eigen::VectorXd b(static_cast<Eigen::Index>(g.size()));
  for (size_t r = 0; r < g.size(); ++r) {
    const double sw = std::sqrt(g[r].weight / wsum);
    const double u = g[r].measured_deg / kScaleDeg;
    double uk = 1.0;
    for (int k = 0; k < cols; ++k, uk *= u) a(static_cast<Eigen::Index>(r), k) = sw * uk;
    b(static_cast<Eigen::Index>(r)) = sw * g[r].true_deg;
  }
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
  qr.setThreshold(1e-9);
  if (qr.rank() < cols) return std::nullopt;
  const Eigen::VectorXd x = qr.solve(b);
  std::array<double, 4> c{0.0, 0.0, 0.0, 0.0};
  double scale = 1.0;
  for (int k = 0; k < cols; ++k, scale *= kScaleDeg) c[static_cast<size_t>(k)] = x(k) / scale;
  return c;
}

double poly(const std::array<double, 4>& c, double t) {
  return c[0] + t * (c[1] + t * (c[2] + t * c[3]));
}

std::string fmt_deg(double v) { return fmt::format("{:.1f}", v); }

}  // namespace

AngleFit fit_angle_correction(const std::vector<AngleSample>& all,
                              const CalibrationFitOptions& opts) {
  AngleFit out;
  out.degree_requested = std::clamp(opts.degree, 0, 3);
  out.degree = out.degree_requested;
  std::vector<AngleSample> s;
  s.reserve(all.size());
  for (const auto& a : all)
    if (std::isfinite(a.measured_deg) && std::isfinite(a.true_deg)) s.push_back(a);
  out.samples = static_cast<int64_t>(s.size());
  if (static_cast<int>(s.size()) < std::max(1, opts.min_samples)) {
    out.failure = fmt::format("{} samples, fewer than the {} required", s.size(),
                              std::max(1, opts.min_samples));
    return out;
  }

  // Groups: consecutive reference angles (sorted) within group_width_deg of the group's first.
  std::sort(s.begin(), s.end(),
            [](const AngleSample& x, const AngleSample& y) { return x.true_deg < y.true_deg; });
  std::vector<int> group(s.size());
  int n_groups = 0;
  double group_first = 0;
  for (size_t i = 0; i < s.size(); ++i) {
    if (i == 0 || s[i].true_deg - group_first > opts.group_width_deg) {
      ++n_groups;
      group_first = s[i].true_deg;
    }
    group[i] = n_groups - 1;
  }

  std::vector<char> kept(s.size(), 1);
  std::array<double, 4> coef{0.0, 1.0, 0.0, 0.0};
  int degree = out.degree_requested;
  std::string note;
  // One fit on the kept samples: group centres (medians on the first pass, then means), the
  // degree lowered until the data carries it.
  auto fit_kept = [&](bool medians, int leave_out = -1) -> bool {
    std::vector<std::vector<double>> measured(static_cast<size_t>(n_groups));
    std::vector<double> true_sum(static_cast<size_t>(n_groups), 0.0);
    for (size_t i = 0; i < s.size(); ++i) {
      if (!kept[i] || group[i] == leave_out) continue;
      measured[static_cast<size_t>(group[i])].push_back(s[i].measured_deg);
      true_sum[static_cast<size_t>(group[i])] += s[i].true_deg;
    }
    std::vector<GroupPoint> g;
    for (size_t k = 0; k < measured.size(); ++k) {
      const auto& m = measured[k];
      if (m.empty()) continue;
      const double n = static_cast<double>(m.size());
      const double centre = medians ? median_of(m) : std::accumulate(m.begin(), m.end(), 0.0) / n;
      g.push_back({centre, true_sum[k] / n, n});
    }
    if (g.empty()) return false;
    double lo = g.front().true_deg, hi = g.front().true_deg;
    for (const auto& p : g) lo = std::min(lo, p.true_deg), hi = std::max(hi, p.true_deg);
    out.groups = static_cast<int>(g.size());
    out.true_min_deg = lo;
    out.true_max_deg = hi;
    for (;;) {
      std::string why;
      if (degree > 0 && static_cast<int>(g.size()) < degree + 1)
        why = fmt::format("degree {} needs {} distinct reference angles, {} here", degree,
                          degree + 1, g.size());
      else if (degree > 0 && hi - lo < degree * opts.min_span_deg_per_degree)
        why = fmt::format("degree {} needs reference angles spanning {} deg, {} here", degree,
                          fmt_deg(degree * opts.min_span_deg_per_degree), fmt_deg(hi - lo));
      if (why.empty()) {
        if (auto c = solve_polynomial(g, degree)) {
          coef = *c;
          return true;
        }
        if (degree == 0) return false;
        why = fmt::format("degree {}: the system is singular", degree);
      }
      if (note.empty()) note = why;
      --degree;
    }
  };

  if (!fit_kept(true)) {
    out.failure = "singular fit";
    return out;
  }
  // The robust start: the all-group fit or a leave-one-group-out fit, whichever leaves the
  // smallest median absolute residual over ALL samples (the agreeing majority).
  if (n_groups >= out.degree_requested + 2 && out.degree_requested >= 1) {
    auto median_abs = [&](const std::array<double, 4>& c) {
      std::vector<double> r(s.size());
      for (size_t i = 0; i < s.size(); ++i) r[i] = std::abs(poly(c, s[i].measured_deg) - s[i].true_deg);
      return median_of(r);
    };
    const int degree_all = degree;
    const std::array<double, 4> coef_all = coef;
    const std::string note_all = note;
    double best = median_abs(coef);
    std::array<double, 4> best_coef = coef;
    int best_degree = degree, best_out = -1;
    std::string best_note = note;
    for (int g = 0; g < n_groups; ++g) {
      degree = out.degree_requested;
      note.clear();
      if (!fit_kept(true, g)) continue;
      const double m = median_abs(coef);
      if (m < best) best = m, best_coef = coef, best_degree = degree, best_out = g, best_note = note;
    }
    coef = best_out >= 0 ? best_coef : coef_all;
    degree = best_out >= 0 ? best_degree : degree_all;
    note = best_out >= 0 ? best_note : note_all;
    out.start_left_out_group = best_out;
    out.groups = n_groups;
  }
  std::vector<double> resid(s.size());
  std::vector<char> next(s.size());
  bool refit_needed = true;
  for (int pass = 1; pass <= std::max(1, opts.max_iterations); ++pass) {
    out.iterations = pass;
    for (size_t i = 0; i < s.size(); ++i) resid[i] = poly(coef, s[i].measured_deg) - s[i].true_deg;
    const double med = median_of(resid);
    std::vector<double> dev(s.size());
    for (size_t i = 0; i < s.size(); ++i) dev[i] = std::abs(resid[i] - med);
    const double sigma = std::max(1.4826 * median_of(dev), opts.min_sigma_deg);
    for (size_t i = 0; i < s.size(); ++i) next[i] = dev[i] <= opts.reject_k * sigma ? 1 : 0;
    // Pass 1 checks the median start; from pass 2 on, an unchanged kept set means the mean fit
    // on it is the answer.
    if (pass > 1 && next == kept) {
      refit_needed = false;
      break;
    }
    kept = next;
    if (!fit_kept(false)) {
      out.failure = "singular fit";
      return out;
    }
  }
  if (refit_needed && !fit_kept(false)) {
    out.failure = "singular fit";
    return out;
  }

  out.degree = degree;
  out.degree_note = note;
  out.correction.coefficients = coef;
  double lo = 90, hi = -90, before2 = 0, after2 = 0;
  std::vector<double> final_resid;
  std::vector<double> g_before(static_cast<size_t>(n_groups), 0.0),
      g_after(static_cast<size_t>(n_groups), 0.0), g_n(static_cast<size_t>(n_groups), 0.0);
  for (size_t i = 0; i < s.size(); ++i) {
    if (!kept[i]) {
      ++out.rejected;
      continue;
    }
    ++out.used;
    const double m = s[i].measured_deg;
    lo = std::min(lo, m);
    hi = std::max(hi, m);
    const double e = poly(coef, m) - s[i].true_deg;
    before2 += (m - s[i].true_deg) * (m - s[i].true_deg);
    after2 += e * e;
    final_resid.push_back(e);
    const auto k = static_cast<size_t>(group[i]);
    g_before[k] += m - s[i].true_deg;
    g_after[k] += e;
    g_n[k] += 1;
  }
  for (size_t k = 0; k < g_n.size(); ++k) {
    if (g_n[k] == 0) continue;
    out.systematic_before_deg += g_before[k] * g_before[k] / g_n[k];
    out.systematic_after_deg += g_after[k] * g_after[k] / g_n[k];
  }
  if (out.used < std::max(1, opts.min_samples)) {
    out.failure = fmt::format(
        "{} samples left after rejecting {} outliers, fewer than the {} "
        "required",
        out.used, out.rejected, std::max(1, opts.min_samples));
    return out;
  }
  lo = std::max(lo, -90.0);
  hi = std::min(hi, 90.0);
  if (!(lo < hi)) {  // one measured angle only: the interval of the angle resolution around it
    lo = std::max(-90.0, lo - 0.5);
    hi = std::min(90.0, hi + 0.5);
  }
  out.correction.valid_min_deg = lo;
  out.correction.valid_max_deg = hi;
  const double n = static_cast<double>(out.used);
  out.rms_before_deg = std::sqrt(before2 / n);
  out.rms_after_deg = std::sqrt(after2 / n);
  out.systematic_before_deg = std::sqrt(out.systematic_before_deg / n);
  out.systematic_after_deg = std::sqrt(out.systematic_after_deg / n);
  const double med = median_of(final_resid);
  for (auto& e : final_resid) e = std::abs(e - med);
  out.robust_sigma_deg = 1.4826 * median_of(final_resid);
  // The fit's overall slope over the measured angles used, (P(hi) - P(lo)) / (hi - lo): c1 for a
  // line; a cubic's local slope near the edges may exceed it (edge compression) and is not judged.
  const double mean_slope = hi > lo ? (poly(coef, hi) - poly(coef, lo)) / (hi - lo) : coef[1];
  out.slope_min = out.slope_max = mean_slope;
  if (out.degree >= 1 && (out.slope_min < opts.min_slope || out.slope_max > opts.max_slope)) {
    const std::string why = fmt::format(
        "implausible slope {:.2f} (plausible: {:.2f} to {:.2f}; a wrong reference point or "
        "orientation?)",
        mean_slope, opts.min_slope, opts.max_slope);
    if (!opts.force) {
      out.failure = why + "; --force keeps it";
      return out;
    }
    out.slope_note = why + ", kept (--force)";
  }
  out.fitted = true;
  return out;
}

CalibrationCollector::CalibrationCollector(std::vector<ReferencePoint> points, bool use_truth,
                                           CalibrationFitOptions opts)
    : points_(std::move(points)), use_truth_(use_truth), opts_(opts) {
  if (opts_.degree < 0 || opts_.degree > 3)
    throw CalibrationError(fmt::format("degree {}: expected 0 to 3", opts_.degree));
  for (size_t i = 0; i < points_.size(); ++i) {
    const auto& p = points_[i];
    if (p.tag_id.empty()) throw CalibrationError("a point without a tag id");
    if (!p.position.head<2>().allFinite() || std::isinf(p.position.z()))
      throw CalibrationError("point of " + p.tag_id + ": the position must be finite");
    if (std::isnan(p.start_s) || std::isnan(p.end_s) || p.start_s > p.end_s)
      throw CalibrationError("point of " + p.tag_id + ": its window must have START <= END");
    for (size_t j = 0; j < i; ++j) {
      const auto& q = points_[j];
      if (q.tag_id == p.tag_id && p.start_s <= q.end_s && q.start_s <= p.end_s)
        throw CalibrationError("two points of tag " + p.tag_id +
                               " with overlapping windows: give each its own @START-END");
    }
  }
}

void CalibrationCollector::set_site(const Site& site) {
  if (!site_)
    site_ = site;
  else if (site.yaml_text != site_->yaml_text)
    ++sites_ignored_;
}

int CalibrationCollector::intern(std::vector<std::string>& names, std::map<std::string, int>& index,
                                 const std::string& id) {
  auto [it, inserted] = index.try_emplace(id, static_cast<int>(names.size()));
  if (inserted) names.push_back(id);
  return it->second;
}

void CalibrationCollector::add(const ble_aoa_t& m, double t_s) {
  events_.push_back({m.utime, t_s, intern(anchor_names_, anchor_index_, m.anchor_id),
                     intern(tag_names_, tag_index_, m.tag_id), m.azimuth_deg, m.elevation_deg,
                     m.channel});
}

void CalibrationCollector::add_truth(const pose_t& m) {
  ++truth_in_;
  const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
  if (p.allFinite()) truth_[m.tag_id].emplace_back(m.utime, p);
}

CalibrationResult CalibrationCollector::fit() const {
  if (!site_) throw CalibrationError("no site");
  const Site& site = *site_;
  CalibrationResult r;
  r.stats.events_in = static_cast<int64_t>(events_.size());
  r.stats.truth_in = truth_in_;
  r.stats.sites_ignored = sites_ignored_;

  // The points, with z resolved.
  double anchor_z = 0;
  int n_aoa = 0;
  std::vector<const Anchor*> site_anchors;
  for (const auto& a : site.anchors) {
    if (a.kind != "ble_aoa" || !a.enabled) continue;
    site_anchors.push_back(&a);
    anchor_z += a.position.z();
    ++n_aoa;
  }
  if (n_aoa == 0) throw CalibrationError("the site has no enabled ble_aoa anchor");
  anchor_z /= n_aoa;
  for (const auto& p : points_) {
    PointUse u{p, "", 0};
    if (std::isnan(p.position.z())) {
      const Tag* t = site.find_tag(p.tag_id);
      if (t && std::isfinite(t->height_m)) {
        u.point.position.z() = t->height_m;
        u.z_note = "the site's height_m of " + p.tag_id;
      } else {
        u.point.position.z() = anchor_z;
        u.z_note = fmt::format("no height_m for {} in the site: the anchors' mean height {:.3f} m",
                               p.tag_id, anchor_z);
      }
    }
    if (!site.find_tag(p.tag_id) && !tag_index_.count(p.tag_id))
      throw CalibrationError("unknown tag '" + p.tag_id +
                             "': not in the site's tags and no BLE_AOA event from it");
    r.points.push_back(u);
  }

  // TRUTH per tag, in time order.
  std::map<std::string, std::vector<std::pair<int64_t, Eigen::Vector3d>>> truth = truth_;
  for (auto& [tag, track] : truth)
    std::stable_sort(track.begin(), track.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
  const int64_t max_gap_us = static_cast<int64_t>(opts_.truth_max_gap_s * 1e6);
  auto truth_at = [&](const std::string& tag, int64_t t) -> std::optional<Eigen::Vector3d> {
    auto it = truth.find(tag);
    if (it == truth.end() || it->second.empty()) return std::nullopt;
    const auto& tr = it->second;
    auto hi = std::lower_bound(tr.begin(), tr.end(), t,
                               [](const auto& s, int64_t v) { return s.first < v; });
    if (hi != tr.end() && hi->first == t) return hi->second;
    if (hi == tr.begin() || hi == tr.end()) return std::nullopt;
    const auto lo = std::prev(hi);
    if (hi->first - lo->first > max_gap_us) return std::nullopt;
    const double f =
        static_cast<double>(t - lo->first) / static_cast<double>(hi->first - lo->first);
    return lo->second + f * (hi->second - lo->second);
  };

  // Per site anchor: its frame and the events with a reference.
  struct Ref {
    int tag;
    int64_t utime;
    size_t order;
    int16_t channel;
    double az, az_true, el, el_true;  // el NaN when unusable
  };
  std::map<std::string, size_t> anchor_slot;
  std::vector<AnchorFrame> frames;
  std::vector<std::vector<Ref>> refs(site_anchors.size());
  for (size_t i = 0; i < site_anchors.size(); ++i) {
    anchor_slot[site_anchors[i]->id] = i;
    frames.push_back(anchor_frame(*site_anchors[i]));
  }
  std::vector<std::vector<size_t>> points_of_tag(tag_names_.size());
  for (size_t k = 0; k < r.points.size(); ++k) {
    auto it = tag_index_.find(r.points[k].point.tag_id);
    if (it != tag_index_.end()) points_of_tag[static_cast<size_t>(it->second)].push_back(k);
  }
  for (size_t e = 0; e < events_.size(); ++e) {
    const Event& ev = events_[e];
    const std::string& tag = tag_names_[static_cast<size_t>(ev.tag)];
    ++r.events_by_tag[tag];
    auto slot = anchor_slot.find(anchor_names_[static_cast<size_t>(ev.anchor)]);
    if (slot == anchor_slot.end()) {
      ++r.stats.unknown_anchor;
      continue;
    }
    Eigen::Vector3d ref;
    const auto& pts = points_of_tag[static_cast<size_t>(ev.tag)];
    if (!pts.empty()) {
      PointUse* hit = nullptr;
      for (size_t k : pts) {
        const auto& p = r.points[k].point;
        if (ev.t_s >= p.start_s && ev.t_s <= p.end_s) hit = &r.points[k];
      }
      if (!hit) {
        ++r.stats.outside_window;
        continue;
      }
      ++hit->events;
      ref = hit->point.position;
    } else if (use_truth_) {
      const auto p = truth_at(tag, ev.utime);
      if (!p) {
        ++r.stats.no_truth;
        continue;
      }
      ref = *p;
    } else {
      ++r.stats.no_reference;
      continue;
    }
    const double az = ev.azimuth_deg;
    if (!std::isfinite(az) || std::abs(az) > 90) {
      ++r.stats.invalid_angle;
      continue;
    }
    const AnchorFrame& f = frames[slot->second];
    const AnglePrediction pa = predict_angle(f, ref, AngleKind::kAzimuth);
    const double az_true = pa.angle_rad * kRadToDeg;
    if (!pa.valid || std::abs(az_true) > 90) {
      ++r.stats.out_of_view;
      continue;
    }
    double el = ev.elevation_deg, el_true = std::nan("");
    const AnglePrediction pe = predict_angle(f, ref, AngleKind::kElevation);
    if (pe.valid && std::isfinite(el) && std::abs(el) <= 90)
      el_true = pe.angle_rad * kRadToDeg;
    else
      el = std::nan("");
    refs[slot->second].push_back({ev.tag, ev.utime, e, ev.channel, az, az_true, el, el_true});
  }

  const int64_t dup_us = static_cast<int64_t>(opts_.duplicate_window_ms * 1e3);
  auto known_channel = [](int16_t c) { return c >= 37 && c <= 39; };
  for (size_t i = 0; i < site_anchors.size(); ++i) {
    auto& v = refs[i];
    AnchorFit af;
    af.anchor_id = site_anchors[i]->id;
    af.events = static_cast<int64_t>(v.size());
    std::stable_sort(v.begin(), v.end(), [](const Ref& x, const Ref& y) {
      return x.tag != y.tag ? x.tag < y.tag : x.utime < y.utime;
    });
    std::vector<AngleSample> az, el;
    const Ref* last = nullptr;
    for (const Ref& x : v) {
      // A multipath duplicate: a later event of the same advertisement (same tag and channel,
      // within the window of the last event kept).
      if (dup_us > 0 && last && last->tag == x.tag && x.utime - last->utime <= dup_us &&
          (x.channel == last->channel || !known_channel(x.channel) ||
           !known_channel(last->channel))) {
        ++af.duplicates;
        continue;
      }
      last = &x;
      az.push_back({x.az, x.az_true});
      if (std::isfinite(x.el)) el.push_back({x.el, x.el_true});
    }
    af.azimuth = fit_angle_correction(az, opts_);
    if (opts_.elevation) af.elevation = fit_angle_correction(el, opts_);
    r.anchors.push_back(std::move(af));
  }

  for (const auto& u : r.points) {
    if (u.events > 0) continue;
    const auto& p = u.point;
    auto it = r.events_by_tag.find(p.tag_id);
    const int64_t heard = it == r.events_by_tag.end() ? 0 : it->second;
    std::string window = "";
    if (std::isfinite(p.start_s) || std::isfinite(p.end_s))
      window = fmt::format(" between {:g} and {:g} s", p.start_s, p.end_s);
    throw CalibrationError(fmt::format(
        "point {} at ({:.3f}, {:.3f}, {:.3f}){}: no BLE_AOA event of {} from a site anchor in "
        "its window ({} events of {} in all)",
        p.tag_id, p.position.x(), p.position.y(), p.position.z(), window, p.tag_id, heard,
        p.tag_id));
  }
  return r;
}

std::string calibrated_site_yaml(const Site& site, const std::vector<AnchorFit>& fits,
                                 const std::vector<std::string>& header) {
  std::string text;
  try {
    SiteYamlEdit edit(site);
    YAML::Node cal = edit.map_at({"estimators", "aoa", "calibration"});
    for (const auto& f : fits) {
      if (!f.azimuth.fitted && !(f.elevation && f.elevation->fitted)) continue;
      YAML::Node entry = cal[f.anchor_id];
      if (!entry.IsMap()) {
        cal[f.anchor_id] = YAML::Node(YAML::NodeType::Map);
        entry = cal[f.anchor_id];
      }
      if (f.azimuth.fitted)
        entry["azimuth"] = YAML::Load(format_angle_correction(f.azimuth.correction));
      if (f.elevation && f.elevation->fitted)
        entry["elevation"] = YAML::Load(format_angle_correction(f.elevation->correction));
    }
    text = edit.text(header);
    const Site back = parse_site_text(text, "the calibrated site");
    const auto parsed = parse_calibration(back.estimator_params("aoa")["calibration"]);
    for (const auto& f : fits) {
      if (!f.azimuth.fitted) continue;
      auto it = parsed.find(f.anchor_id);
      if (it == parsed.end() || std::abs(it->second.azimuth.coefficients[0] -
                                         f.azimuth.correction.coefficients[0]) > 1e-6)
        throw CalibrationError("the calibrated site lost the calibration of " + f.anchor_id);
    }
  } catch (const ConfigError& e) {
    throw CalibrationError(e.what());
  }
  return text;
}

}  // namespace ips::aoa
