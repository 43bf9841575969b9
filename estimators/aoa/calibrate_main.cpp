// ips-aoa-calibrate: per-anchor angle correction polynomials (estimators.aoa.calibration) from a
// log of BLE_AOA events of tags at known points (--point) or with a reference system (--truth);
// prints the fit and writes the site with the calibration block.
#include <spdlog/spdlog.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ips/ble_aoa_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <optional>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"
#include "estimators/aoa/calibration_fit.hpp"

namespace {

constexpr const char* kProgram = "ips-aoa-calibrate";
namespace aoa = ips::aoa;

bool parse_number(const std::string& text, double& v) {
  try {
    size_t used = 0;
    v = std::stod(text, &used);
    return used == text.size() && std::isfinite(v);
  } catch (const std::exception&) {
    return false;
  }
}

// "T1=X,Y", "T1=X,Y,Z", either followed by "@START-END" (seconds after the log's first event).
bool parse_point(const std::string& text, aoa::ReferencePoint& p) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) return false;
  p.tag_id = text.substr(0, eq);
  std::string coords = text.substr(eq + 1);
  const auto at = coords.find('@');
  if (at != std::string::npos) {
    const std::string window = coords.substr(at + 1);
    coords.resize(at);
    size_t used = 0;
    try {
      p.start_s = std::stod(window, &used);
    } catch (const std::exception&) {
      return false;
    }
    if (used >= window.size() || window[used] != '-' || !std::isfinite(p.start_s)) return false;
    if (!parse_number(window.substr(used + 1), p.end_s)) return false;
  }
  std::vector<double> v;
  size_t from = 0;
  while (from <= coords.size()) {
    const auto comma = std::min(coords.find(',', from), coords.size());
    double x = 0;
    if (!parse_number(coords.substr(from, comma - from), x)) return false;
    v.push_back(x);
    from = comma + 1;
  }
  if (v.size() < 2 || v.size() > 3) return false;
  p.position = {v[0], v[1], v.size() == 3 ? v[2] : std::nan("")};
  return true;
}

std::string window_text(const aoa::ReferencePoint& p) {
  if (!std::isfinite(p.start_s) && !std::isfinite(p.end_s)) return "all";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g-%g", p.start_s, p.end_s);
  return buf;
}

void print_fit_row(const std::string& anchor, const char* angle, const aoa::AngleFit& f,
                   int64_t duplicates) {
  const std::string id = ips::printable(anchor);
  if (!f.fitted) {
    std::printf("%-8s %-5s %3s %4d %7lld %6s %5s %5lld  not fitted: %s\n", id.c_str(), angle, "-",
                f.groups, static_cast<long long>(f.samples), "-", "-",
                static_cast<long long>(duplicates), f.failure.c_str());
    return;
  }
  const auto& c = f.correction.coefficients;
  char span[32], valid[32], c2[16] = "-", c3[16] = "-";
  std::snprintf(span, sizeof span, "%.1f..%.1f", f.true_min_deg, f.true_max_deg);
  std::snprintf(valid, sizeof valid, "%.0f..%.0f", f.correction.valid_min_deg,
                f.correction.valid_max_deg);
  if (f.degree >= 2) std::snprintf(c2, sizeof c2, "%+.3e", c[2]);
  if (f.degree >= 3) std::snprintf(c3, sizeof c3, "%+.3e", c[3]);
  std::printf(
      "%-8s %-5s %3d %4d %7lld %6lld %5lld %5lld %13s %10s %+8.3f %8.5f %10s %10s %7.2f %7.2f "
      "%7.2f %7.2f\n",
      id.c_str(), angle, f.degree, f.groups, static_cast<long long>(f.samples),
      static_cast<long long>(f.used), static_cast<long long>(f.rejected),
      static_cast<long long>(duplicates), span, valid, c[0], c[1], c2, c3, f.systematic_before_deg,
      f.systematic_after_deg, f.rms_before_deg, f.rms_after_deg);
}

void print_report(const aoa::CalibrationResult& r, bool use_truth) {
  if (!r.points.empty()) {
    std::printf("%-5s %-8s %8s %8s %7s %13s %7s\n", "point", "tag", "x", "y", "z", "window_s",
                "events");
    for (size_t i = 0; i < r.points.size(); ++i) {
      const auto& u = r.points[i];
      std::printf("%-5zu %-8s %8.3f %8.3f %7.3f %13s %7lld\n", i + 1,
                  ips::printable(u.point.tag_id).c_str(), u.point.position.x(),
                  u.point.position.y(), u.point.position.z(), window_text(u.point).c_str(),
                  static_cast<long long>(u.events));
    }
    for (size_t i = 0; i < r.points.size(); ++i)
      if (r.points[i].z_note.rfind("no height_m", 0) == 0)
        std::printf("note: point %zu: z from %s\n", i + 1,
                    ips::printable(r.points[i].z_note).c_str());
    std::printf("\n");
  }
  if (use_truth)
    std::printf("reference: TRUTH (%lld poses)\n\n", static_cast<long long>(r.stats.truth_in));
  std::printf("%-8s %-5s %3s %4s %7s %6s %5s %5s %13s %10s %8s %8s %10s %10s %7s %7s %7s %7s\n",
              "anchor", "angle", "deg", "refs", "samples", "used", "rej", "dup", "ref_span_deg",
              "valid_deg", "c0", "c1", "c2", "c3", "sys_raw", "sys_cal", "rms_raw", "rms_cal");
  for (const auto& a : r.anchors) {
    print_fit_row(a.anchor_id, "az", a.azimuth, a.duplicates);
    if (a.elevation) print_fit_row(a.anchor_id, "el", *a.elevation, a.duplicates);
  }
  for (const auto& a : r.anchors) {
    auto note = [&](const char* angle, const aoa::AngleFit& f) {
      if (f.fitted && !f.degree_note.empty())
        std::printf("note: %s %s: degree %d instead of %d: %s\n",
                    ips::printable(a.anchor_id).c_str(), angle, f.degree, f.degree_requested,
                    f.degree_note.c_str());
      if (f.fitted && !f.slope_note.empty())
        std::printf("warning: %s %s: %s\n", ips::printable(a.anchor_id).c_str(), angle,
                    f.slope_note.c_str());
      if (f.start_left_out_group >= 0)
        std::printf("note: %s %s: one reference group disagreed with the rest and was left out of "
                    "the start\n",
                    ips::printable(a.anchor_id).c_str(), angle);
    };
    note("az", a.azimuth);
    if (a.elevation) note("el", *a.elevation);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-aoa-calibrate: fits per-anchor angle correction polynomials (Theta_true = c0 + c1 "
      "theta + c2 theta^2 + c3 theta^3 of the measured angle, degrees) from the BLE_AOA events "
      "of tags standing at known points (--point) or carried with a reference system "
      "(--truth), prints the fit and writes the site with an estimators.aoa.calibration block.",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, ips::CommonFlags{.lcm = false});
  std::string log_path, out_path;
  std::vector<std::string> point_texts;
  bool use_truth = false, force = false;
  aoa::CalibrationFitOptions fopt;
  app.add_option("--log", log_path, "read BLE_AOA, SITE (and TRUTH) from this LCM log")
      ->type_name("FILE")
      ->required();
  app.add_option("--point", point_texts,
                 "tag TAG stood at site position (X, Y, Z) in m, optionally only between START "
                 "and END seconds after the log's first event; Z default: the tag's height_m "
                 "in the site, else the anchors' mean height. Repeatable")
      ->type_name("TAG=X,Y[,Z][@START-END]");
  app.add_flag("--truth", use_truth,
               "use the tags' TRUTH poses (interpolated at each event's time) as the reference, "
               "for tags without --point");
  app.add_option("--degree", fopt.degree,
                 "polynomial degree 0..3 (0: a constant offset, the mounting-yaw error); lower "
                 "when the data cannot carry it, with the reason")
      ->capture_default_str();
  app.add_flag("--elevation", fopt.elevation, "also fit the elevation correction");
  app.add_option("--out", out_path,
                 "write the site with the estimators.aoa.calibration block here (YAML); without "
                 "it, only print the fit")
      ->type_name("SITE.yaml");
  app.add_flag("--force", force,
               "overwrite --out when it exists, and keep fits whose slope is outside "
               "--min-slope..--max-slope");
  app.add_option("--min-slope", fopt.min_slope,
                 "smallest plausible overall slope of a fit of degree >= 1 ((P(hi) - P(lo)) / "
                 "(hi - lo) over the angles used); a fit outside is refused unless --force")
      ->capture_default_str();
  app.add_option("--max-slope", fopt.max_slope, "largest plausible slope (see --min-slope)")
      ->capture_default_str();
  app.add_option("--reject-k", fopt.reject_k,
                 "reject samples beyond K robust sigmas (1.4826 MAD) of the residuals, K > 0")
      ->capture_default_str();
  app.add_option("--duplicate-window-ms", fopt.duplicate_window_ms,
                 "drop a later event of the same anchor, tag and channel within this many ms "
                 "(multipath duplicate); 0 keeps them")
      ->capture_default_str();
  app.add_option("--min-samples", fopt.min_samples,
                 "samples an anchor's angle needs to be fitted, at least 1")
      ->capture_default_str();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  fopt.force = force;
  if (!(fopt.min_slope > 0 && fopt.min_slope <= 1 && fopt.max_slope >= 1 &&
        std::isfinite(fopt.max_slope))) {
    ips::print_fatal(kProgram, "--min-slope must be in (0, 1] and --max-slope finite and >= 1");
    return 2;
  }

  auto usage = [](const std::string& what) {
    ips::print_fatal(kProgram, what);
    return 2;
  };
  if (fopt.degree < 0 || fopt.degree > 3) return usage("--degree: expected 0, 1, 2 or 3");
  if (!(fopt.reject_k > 0 && fopt.reject_k < 1e6)) return usage("--reject-k: expected K > 0");
  if (!(fopt.duplicate_window_ms >= 0 && fopt.duplicate_window_ms <= 1000))
    return usage("--duplicate-window-ms: expected 0 to 1000");
  if (fopt.min_samples < 1) return usage("--min-samples: expected at least 1");
  std::vector<aoa::ReferencePoint> points;
  for (const auto& t : point_texts) {
    aoa::ReferencePoint p;
    if (!parse_point(t, p))
      return usage("--point: expected TAG=X,Y[,Z][@START-END] (m, s), got '" + ips::printable(t) +
                   "'");
    points.push_back(p);
  }
  if (points.empty() && !use_truth)
    return usage("give the reference: --point TAG=X,Y[,Z][@START-END] (repeatable) and/or --truth");
  std::error_code ec;
  if (!out_path.empty() && std::filesystem::exists(out_path, ec) && !force)
    return usage("--out: '" + ips::printable(out_path) + "' exists (--force overwrites it)");
  if (!out_path.empty()) {
    const std::filesystem::path dir = std::filesystem::path(out_path).parent_path();
    if (!std::filesystem::is_directory(dir.empty() ? "." : dir, ec))
      return usage("--out: no directory '" + ips::printable(dir.string()) + "'");
  }

  return ips::run_reporting_errors(kProgram, [&]() -> int {
    std::optional<aoa::CalibrationCollector> collector;
    try {
      collector.emplace(points, use_truth, fopt);
    } catch (const aoa::CalibrationError& err) {
      ips::print_fatal(kProgram, std::string("--point: ") + err.what());
      return 2;
    }
    std::optional<ips::Site> file_site;
    if (!opts.site_path.empty()) {
      file_site = ips::load_site_file(opts.site_path);  // ConfigError: one line, status 2
      collector->set_site(*file_site);
    }
    const std::string aoa_channel = opts.channel(ips::channel::kBleAoa);
    const std::string site_channel = opts.channel(ips::channel::kSite);
    const std::string truth_channel = opts.channel(ips::channel::kTruth);
    int64_t bad_messages = 0, bad_sites = 0, truth_messages = 0;
    const auto log = ips::LogInput::open(kProgram, log_path);
    if (!log) return 2;
    int64_t first_us = 0;
    bool first = true;
    while (const ips::LogEvent* e = log->next()) {
      if (first) first_us = e->timestamp_us, first = false;
      if (e->channel == aoa_channel) {
        ips::ble_aoa_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        collector->add(m, ips::utime_to_s(e->timestamp_us - first_us));
      } else if (use_truth && e->channel == truth_channel) {
        ips::pose_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        ++truth_messages;
        collector->add_truth(m);
      } else if (e->channel == site_channel && !file_site) {
        ips::site_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        try {
          collector->set_site(ips::site_from_msg(m));
        } catch (const ips::SiteError& err) {
          if (bad_sites++ == 0) spdlog::warn("{}: skipped a bad SITE: {}", kProgram, err.what());
        }
      }
    }
    if (!log->finish("calibrating from what was read")) return 2;
    if (bad_messages > 0)
      std::fprintf(stderr, "%s: warning: %lld messages did not decode and were skipped\n", kProgram,
                   static_cast<long long>(bad_messages));
    if (!collector->has_site()) {
      ips::print_fatal(kProgram, "no site: " + ips::printable(log_path) +
                                     " has no SITE message; give the site with --site FILE");
      return 2;
    }
    if (collector->events() == 0) {
      ips::print_fatal(kProgram, "no BLE_AOA events in " + ips::printable(log_path) + " (channel " +
                                     ips::printable(aoa_channel) + ")");
      return 2;
    }
    if (use_truth && truth_messages == 0) {
      ips::print_fatal(kProgram, "--truth: no TRUTH messages in " + ips::printable(log_path) +
                                     " (channel " + ips::printable(truth_channel) + ")");
      return 2;
    }
    aoa::CalibrationResult result;
    try {
      result = collector->fit();
    } catch (const aoa::CalibrationError& err) {
      ips::print_fatal(kProgram, err.what());
      return 2;
    }
    const auto& st = result.stats;
    int64_t with_ref = 0, dups = 0;
    for (const auto& a : result.anchors) with_ref += a.events, dups += a.duplicates;
    std::printf(
        "%s: %lld BLE_AOA events read: %lld with a reference angle, %lld of them dropped "
        "as multipath duplicates\n",
        kProgram, static_cast<long long>(st.events_in), static_cast<long long>(with_ref),
        static_cast<long long>(dups));
    const std::pair<int64_t, const char*> skipped[] = {
        {st.unknown_anchor, "from anchors that are not enabled ble_aoa anchors of the site"},
        {st.no_reference, "from tags without a --point (and no --truth)"},
        {st.outside_window, "outside their tag's point windows"},
        {st.no_truth, "without TRUTH of their tag around their time"},
        {st.invalid_angle, "with a NaN or out-of-range azimuth"},
        {st.out_of_view, "whose reference position is behind the anchor"}};
    for (const auto& [n, what] : skipped)
      if (n > 0) std::printf("skipped: %lld events %s\n", static_cast<long long>(n), what);
    if (st.sites_ignored > 0)
      std::fprintf(stderr,
                   "%s: warning: %lld later SITE messages differ from the first; the first is "
                   "used\n",
                   kProgram, static_cast<long long>(st.sites_ignored));
    std::printf("\n");
    print_report(result, use_truth);

    std::string failed;
    int fitted = 0;
    for (const auto& a : result.anchors) {
      if (a.azimuth.fitted)
        ++fitted;
      else
        failed +=
            (failed.empty() ? "" : "; ") + ips::printable(a.anchor_id) + ": " + a.azimuth.failure;
    }
    if (fitted == 0) {
      ips::print_fatal(kProgram, "no anchor could be fitted (" + failed + ")");
      return 2;
    }
    if (!failed.empty())
      std::fprintf(stderr, "%s: warning: not fitted, left as they were: %s\n", kProgram,
                   failed.c_str());
    const ips::Site& site = collector->site();
    const auto existing = aoa::parse_calibration(site.estimator_params("aoa")["calibration"]);
    for (const auto& a : result.anchors)
      if (a.azimuth.fitted && existing.count(a.anchor_id))
        std::printf(
            "note: %s: the input site's calibration is replaced (fitted on the raw "
            "angles of the log)\n",
            ips::printable(a.anchor_id).c_str());
    if (out_path.empty()) {
      std::printf("(no --out: nothing written)\n");
      return 0;
    }
    const std::string reference = result.points.empty()
                                      ? std::string("TRUTH")
                                      : std::to_string(result.points.size()) + " known points" +
                                            (use_truth ? " and TRUTH" : "");
    const std::vector<std::string> header = {
        "Calibrated by ips-aoa-calibrate from " + ips::printable(log_path) + ": " +
            std::to_string(fitted) + " anchors, " + reference + ", degree " +
            std::to_string(fopt.degree) +
            (fopt.elevation ? ", azimuth and elevation." : ", azimuth."),
        "Comments of the input site are not kept."};
    std::string text;
    try {
      text = aoa::calibrated_site_yaml(site, result.anchors, header);
    } catch (const aoa::CalibrationError& err) {
      ips::print_fatal(kProgram, err.what());
      return 1;
    }
    if (std::string error; !ips::write_text_file(out_path, text, error)) {
      ips::print_fatal(kProgram, error);
      return 1;
    }
    std::printf("wrote %s\n", ips::printable(out_path).c_str());
    return 0;
  });
}
