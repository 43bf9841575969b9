// ips-uwb-survey: anchor positions from anchor-to-anchor ranges on UWB_RANGE (a log, or the bus
// for a while); prints the survey and writes the site with the surveyed positions. With --offsets,
// the anchors' antenna delays instead (their positions known: the site's), written as the tag
// trackers' range offsets (estimators.uwb_twr.range_offsets_m).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <optional>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site_source.hpp"
#include "core/text_escape.hpp"
#include "estimators/uwb_survey/anchor_delays.hpp"
#include "estimators/uwb_survey/anchor_survey.hpp"
#include "estimators/uwb_survey/range_collector.hpp"
#include "estimators/uwb_survey/surveyed_site.hpp"
#include "estimators/uwb_twr/offsets_site_file.hpp"
#include "estimators/uwb_twr/range_calibration.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-survey";
namespace us = ips::uwb_survey;
namespace twr = ips::uwb_twr;

// "T1=X,Y" or "T1=X,Y,Z" (Z: NaN when not given).
bool parse_known_point(const std::string& text, std::string& tag, Eigen::Vector3d& p) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0) return false;
  tag = text.substr(0, eq);
  std::vector<double> v;
  size_t at = eq + 1;
  while (at <= text.size()) {
    const auto comma = std::min(text.find(',', at), text.size());
    const std::string num = text.substr(at, comma - at);
    try {
      size_t used = 0;
      v.push_back(std::stod(num, &used));
      if (used != num.size() || !std::isfinite(v.back())) return false;
    } catch (const std::exception&) {
      return false;
    }
    at = comma + 1;
  }
  if (v.size() < 2 || v.size() > 3) return false;
  p = {v[0], v[1], v.size() == 3 ? v[2] : std::nan("")};
  return true;
}

// Below half a millimetre prints as 0, not -0.000.
double tidy(double v) { return std::abs(v) < 5e-4 ? 0.0 : v; }

std::string fixed(double v, int decimals = 3) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

void print_report(const us::SurveyResult& r, const ips::Site& input,
                  const std::optional<Eigen::Vector3d>& known, const std::string& known_tag) {
  std::printf("%-9s %7s %9s %9s %9s %9s\n", "pair", "ranges", "range_m", "horiz_m", "fitted_m",
              "resid_m");
  for (const auto& p : r.pairs)
    std::printf("%-9s %7zu %9.3f %9.3f %9.3f %+9.3f\n", ips::printable(p.a + "-" + p.b).c_str(),
                p.samples, p.range_m, p.horizontal_m, p.fitted_m, p.residual_m);
  std::printf("\n%-8s %9s %9s %7s %8s %8s %7s %9s %5s\n", "anchor", "x", "y", "z", "dx", "dy",
              "moved", "resid_rms", "pairs");
  for (const auto& a : r.anchors) {
    const ips::Anchor* in = input.find_anchor(a.id);
    const Eigen::Vector3d d = a.position - in->position;
    std::printf("%-8s %9.3f %9.3f %7.3f %+8.3f %+8.3f %7.3f %9.3f %5d\n",
                ips::printable(a.id).c_str(), tidy(a.position.x()), tidy(a.position.y()),
                a.position.z(), tidy(d.x()), tidy(d.y()), d.head<2>().norm(), a.residual_rms_m,
                a.pairs_used);
  }
  // The change columns compare frames: say so when the input site's is not the survey's.
  const Eigen::Vector3d o = input.find_anchor(r.anchors[0].id)->position;
  const Eigen::Vector3d x = input.find_anchor(r.anchors[1].id)->position;
  if (o.head<2>().norm() > 0.5 || std::abs(x.y() - o.y()) > 0.5 || x.x() < o.x())
    std::printf(
        "note: in the input site %s is not at the origin with %s on +x, so dx, dy and "
        "moved compare two different frames\n",
        ips::printable(r.anchors[0].id).c_str(), ips::printable(r.anchors[1].id).c_str());
  std::printf(
      "\n%zu pairs, redundancy %d, range residual RMS %.3f m (%d iterations); frame: %s "
      "at the origin, %s on +x\n",
      r.pairs.size(), r.redundancy, r.residual_rms_m, r.iterations,
      ips::printable(r.anchors[0].id).c_str(), ips::printable(r.anchors[1].id).c_str());
  const std::string third = ips::printable(r.anchors[2].id);
  switch (r.mirror) {
    case us::MirrorChoice::kConvention:
      std::printf(
          "mirror: no known point, so %s is put at +y by convention (the true layout may "
          "be this one's reflection in the x axis; --known-point decides)\n",
          third.c_str());
      break;
    case us::MirrorChoice::kKept:
    case us::MirrorChoice::kReflected:
      std::printf(
          "mirror: %s at %s, chosen by tag %s at (%s, %s, %s): range residual RMS %.3f m "
          "over %d anchors, %.3f m reflected\n",
          third.c_str(), r.mirror == us::MirrorChoice::kKept ? "+y" : "-y",
          ips::printable(known_tag).c_str(), fixed(known->x()).c_str(), fixed(known->y()).c_str(),
          fixed(known->z()).c_str(), r.known_point_rms_m, r.known_point_anchors,
          r.known_point_mirror_rms_m);
      break;
  }
}

// The anchors' delays (--offsets): the pairs, then each anchor's delay and the offset seeded.
// site_offsets: the input site's range_offsets_m, for the site_m column.
void print_delays(const us::DelayResult& r, const std::map<std::string, double>& site_offsets) {
  std::printf("%-9s %7s %9s %9s %9s %9s\n", "pair", "ranges", "range_m", "dist_m", "offset_m",
              "resid_m");
  for (const auto& p : r.pairs) {
    const std::string name = ips::printable(p.a + "-" + p.b);
    if (!p.refused.empty())
      std::printf("%-9s %7zu %9.3f %9.3f %+9.3f   refused: %s\n", name.c_str(), p.samples,
                  p.range_m, p.distance_m, p.offset_m, p.refused.c_str());
    else
      std::printf("%-9s %7zu %9.3f %9.3f %+9.3f %+9.3f\n", name.c_str(), p.samples, p.range_m,
                  p.distance_m, p.offset_m, p.residual_m);
  }
  auto or_dash = [](double v) { return std::isfinite(v) ? fixed(v) : std::string("-"); };
  std::printf("\n%-8s %9s %9s %5s %9s %9s %9s\n", "anchor", "delay_m", "sigma_m", "pairs", "seed_m",
              "seed_sig", "site_m");
  for (const auto& a : r.anchors) {
    const auto it = site_offsets.find(a.id);
    std::printf("%-8s %9.3f %9s %5d %9.3f %9s %9s\n", ips::printable(a.id).c_str(), a.delay_m,
                or_dash(a.sigma_m).c_str(), a.pairs_used, a.seed_m, or_dash(a.seed_sigma_m).c_str(),
                it == site_offsets.end() ? "-" : fixed(it->second).c_str());
  }
  std::printf(
      "\n%zu pairs used, redundancy %d, residual RMS %.3f m; offset = range - distance = "
      "d_a + d_b\n",
      r.pairs.size() - static_cast<size_t>(std::count_if(
                           r.pairs.begin(), r.pairs.end(),
                           [](const us::DelayPairReport& p) { return !p.refused.empty(); })),
      r.redundancy, r.residual_rms_m);
  std::printf(
      "seed_m = delay_m + %.3f m, the tags' delay taken as the anchors' mean (no anchor pair "
      "sees a tag's own delay: a tag's seeded offsets are off by its delay's difference from "
      "this mean, which ips-uwb-twr and ips-fuse then learn)\n",
      r.tag_delay_m);
  if (r.redundancy == 0)
    std::printf("note: no redundancy (a lone triangle fits exactly): sigma unknown\n");
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-survey: surveys the UWB anchors from anchor-to-anchor ranges on UWB_RANGE "
      "(first anchor at the origin, second on +x, third in the +y half-plane, the rest "
      "by least squares; a tag at a known point resolves the mirror ambiguity), prints "
      "the result and writes the site with the surveyed anchor positions. With --offsets, "
      "estimates the anchors' antenna delays instead (their positions: the site's) and writes "
      "them as the tags' range offsets (estimators.uwb_twr.range_offsets_m).",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts);
  std::string log_path, out_path, known_text;
  double duration_s = 0;
  bool force = false, offsets_mode = false;
  std::vector<std::string> order;
  std::vector<double> window;
  us::SurveyOptions sopt;
  auto* log_opt =
      app.add_option("--log", log_path, "read the ranges (and the SITE) from this LCM log")
          ->type_name("FILE");
  auto* duration_opt =
      app.add_option("--duration", duration_s,
                     "listen to the bus for S seconds instead of reading a log, then survey")
          ->type_name("S");
  app.add_option("--order", order,
                 "survey order: the anchor at the origin, the one on +x, the one in the +y "
                 "half-plane, then optionally more (default: the site's enabled uwb anchors in "
                 "site order)")
      ->type_name("A,B,C[,...]")
      ->delimiter(',');
  app.add_option("--known-point", known_text,
                 "a tag standing at a known point of the survey frame (Z default: the tag's "
                 "height_m in the site); its ranges decide the mirror ambiguity")
      ->type_name("TAG=X,Y[,Z]");
  auto* window_opt =
      app.add_option("--known-window", window,
                     "when the tag stood at the known point: seconds from the start of the input "
                     "(the log's first event, or the start of listening); default: all of it")
          ->type_name("START_S,END_S")
          ->delimiter(',')
          ->expected(2);
  app.add_option("--out", out_path,
                 "write the site with the surveyed anchor positions here (YAML); without it, "
                 "only print the survey")
      ->type_name("SITE.yaml");
  app.add_flag("--force", force, "overwrite --out when it exists");
  app.add_flag("--offsets", offsets_mode,
               "instead of surveying positions: the anchors' antenna delays from their ranges "
               "and the site's anchor positions (range - distance = d_a + d_b, least squares); "
               "--out gets estimators.uwb_twr.range_offsets_m with each anchor's delay plus the "
               "tags' (taken as the anchors' mean)");
  app.add_option("--min-samples", sopt.min_samples_per_pair,
                 "ranges a pair needs to be used, at least 1")
      ->capture_default_str();
  app.add_option("--range-quantile", sopt.range_quantile,
                 "per-pair range: this quantile of its samples (0.5: the median, which ignores "
                 "NLOS ranges while they are fewer than half), in (0, 1]")
      ->capture_default_str();
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  auto usage = [](const std::string& what) {
    ips::print_fatal(kProgram, what);
    return 2;
  };
  const bool live = duration_opt->count() > 0;
  if (live == (log_opt->count() > 0))
    return usage("give either --log FILE or --duration S (see --help)");
  if (!live && !opts.lcm_url.empty())
    return usage("--lcm-url is for live mode (--duration), not --log");
  if (live && !(duration_s > 0 && duration_s <= 1e6))
    return usage("--duration: expected seconds in (0, 1e6]");
  if (sopt.min_samples_per_pair < 1) return usage("--min-samples: expected at least 1");
  if (!(sopt.range_quantile > 0 && sopt.range_quantile <= 1))
    return usage("--range-quantile: expected a number in (0, 1]");
  if (offsets_mode && (!order.empty() || !known_text.empty() || window_opt->count() > 0))
    return usage(
        "--offsets uses the site's anchor positions: --order, --known-point and --known-window "
        "do not apply");
  std::string known_tag;
  Eigen::Vector3d known_point = Eigen::Vector3d::Zero();
  if (!known_text.empty() && !parse_known_point(known_text, known_tag, known_point))
    return usage("--known-point: expected TAG=X,Y or TAG=X,Y,Z in metres, got '" +
                 ips::printable(known_text) + "'");
  us::CollectorOptions copt;
  copt.known_tag = known_tag;
  if (window_opt->count() > 0) {
    if (known_tag.empty()) return usage("--known-window needs --known-point");
    if (!(std::isfinite(window[0]) && std::isfinite(window[1]) && window[0] <= window[1]))
      return usage("--known-window: expected START_S,END_S with START_S <= END_S");
    copt.window_start_s = window[0];
    copt.window_end_s = window[1];
  }
  std::error_code ec;
  if (!out_path.empty() && std::filesystem::exists(out_path, ec) && !force)
    return usage("--out: '" + ips::printable(out_path) + "' exists (--force overwrites it)");
  if (!out_path.empty()) {
    // Before reading a long log or listening for minutes: the directory must be there.
    const std::filesystem::path dir = std::filesystem::path(out_path).parent_path();
    if (!std::filesystem::is_directory(dir.empty() ? "." : dir, ec))
      return usage("--out: no directory '" + ips::printable(dir.string()) + "'");
  }

  return ips::run_reporting_errors(kProgram, [&]() -> int {
    us::RangeCollector collector(copt);
    std::optional<ips::Site> file_site;
    if (!opts.site_path.empty()) {
      file_site = ips::load_site_file(opts.site_path);  // ConfigError: one line, status 2
      collector.set_site(*file_site);
    }
    const std::string range_channel = opts.channel(ips::channel::kUwbRange);
    const std::string site_channel = opts.channel(ips::channel::kSite);
    int64_t bad_messages = 0, bad_sites = 0;
    std::string source;
    if (!live) {
      source = log_path;
      const auto log = ips::LogInput::open(kProgram, log_path);
      if (!log) return 2;
      int64_t first_us = 0;
      bool first = true;
      while (const ips::LogEvent* e = log->next()) {
        if (first) first_us = e->timestamp_us, first = false;
        if (e->channel == range_channel) {
          ips::uwb_range_t m;
          if (!ips::decode_message(m, e->data, e->size)) {
            ++bad_messages;
            continue;
          }
          collector.add(m, ips::utime_to_s(e->timestamp_us - first_us));
        } else if (e->channel == site_channel && !file_site) {
          ips::site_t m;
          if (!ips::decode_message(m, e->data, e->size)) {
            ++bad_messages;
            continue;
          }
          try {
            collector.set_site(ips::site_from_msg(m));
          } catch (const ips::SiteError& err) {
            if (bad_sites++ == 0) spdlog::warn("{}: skipped a bad SITE: {}", kProgram, err.what());
          }
        }
      }
      if (!log->finish("surveying from what was read")) return 2;
    } else {
      source = "the bus (" + ips::printable(range_channel) + ", " + fixed(duration_s, 1) + " s)";
      ips::Node node(kProgram, opts);
      const auto start = std::chrono::steady_clock::now();
      if (!file_site) ips::provide_site(node, [&](const ips::Site& s) { collector.set_site(s); });
      node.subscribe<ips::uwb_range_t>(
          range_channel, [&](const ips::uwb_range_t& m, const std::string&) {
            const std::chrono::duration<double> t = std::chrono::steady_clock::now() - start;
            collector.add(m, t.count());
          });
      node.add_timer(duration_s, [&] { node.stop(); });
      spdlog::info("{}: listening on {} for {} s", kProgram, ips::printable(range_channel),
                   duration_s);
      if (const int status = node.run(); status != 0) return status;
      if (node.stop_signal() != 0) {
        ips::print_fatal(kProgram, "interrupted before the end of --duration; nothing surveyed");
        return 1;
      }
      bad_messages = node.counters().parse_errors;
    }

    const auto& st = collector.stats();
    if (bad_messages > 0)
      std::fprintf(stderr, "%s: warning: %lld messages did not decode and were skipped\n", kProgram,
                   static_cast<long long>(bad_messages));
    if (st.invalid > 0)
      std::fprintf(stderr, "%s: warning: %lld invalid ranges (NaN, negative or > %g m) skipped\n",
                   kProgram, static_cast<long long>(st.invalid), copt.max_range_m);
    if (st.sites_ignored > 0)
      std::fprintf(stderr,
                   "%s: warning: %lld later SITE messages differ from the first; the first is "
                   "used\n",
                   kProgram, static_cast<long long>(st.sites_ignored));
    if (!collector.has_site()) {
      ips::print_fatal(
          kProgram, "no site: " + source + " has no SITE message; give the site with --site FILE");
      return 2;
    }
    const ips::Site& site = collector.site();
    if (offsets_mode) {
      std::printf("%s: %lld ranges read: %lld between anchors, %lld others\n", kProgram,
                  static_cast<long long>(st.ranges_in), static_cast<long long>(st.anchor_pair),
                  static_cast<long long>(st.other));
      std::vector<us::KnownAnchor> known_anchors;
      std::vector<us::SurveyAnchor> ids;
      for (const auto& a : site.anchors)
        if (a.kind == "uwb" && a.enabled) {
          known_anchors.push_back({a.id, a.position});
          ids.push_back({a.id, a.position.z()});
        }
      us::DelayResult delays;
      try {
        delays = us::solve_anchor_delays(known_anchors, collector.input(ids, std::nullopt).pairs,
                                         {.range_quantile = sopt.range_quantile,
                                          .min_samples_per_pair = sopt.min_samples_per_pair});
      } catch (const us::SurveyError& err) {
        ips::print_fatal(kProgram, std::string("offsets failed: ") + err.what());
        return 1;
      }
      print_delays(delays, twr::parse_twr_params(site.estimator_params("uwb_twr")).range_offsets_m);
      if (out_path.empty()) {
        std::printf("(no --out: nothing written)\n");
        return 0;
      }
      const auto offsets = us::seeded_range_offsets(delays);
      const std::vector<std::string> header = {
          "Range offsets seeded by ips-uwb-survey --offsets from " + ips::printable(source) +
              ": each anchor's antenna delay from anchor-to-anchor ranges, plus the tags' "
              "taken as the anchors' mean (" +
              fixed(delays.tag_delay_m) + " m); residual RMS " + fixed(delays.residual_rms_m) +
              " m.",
          "Comments of the input site are not kept."};
      return twr::write_offsets_site(kProgram, site, offsets, header, out_path);
    }
    std::vector<us::SurveyAnchor> anchors;
    std::optional<Eigen::Vector3d> known;
    try {
      anchors = us::survey_order(site, order);
    } catch (const us::SurveyError& err) {
      ips::print_fatal(kProgram, err.what());
      return 2;
    }
    if (!known_tag.empty()) {
      if (std::isnan(known_point.z())) {
        const ips::Tag* t = site.find_tag(known_tag);
        if (!t || !std::isfinite(t->height_m)) {
          ips::print_fatal(kProgram,
                           "--known-point: give Z (TAG=X,Y,Z): the site has no height_m "
                           "for tag '" +
                               ips::printable(known_tag) + "'");
          return 2;
        }
        known_point.z() = t->height_m;
      }
      known = known_point;
    }
    const std::string from_known = known_tag.empty() ? std::string()
                                                     : std::to_string(st.known_point) + " from " +
                                                           ips::printable(known_tag) +
                                                           " in the known-point window, ";
    std::printf("%s: %lld ranges read: %lld between anchors, %s%lld others\n", kProgram,
                static_cast<long long>(st.ranges_in), static_cast<long long>(st.anchor_pair),
                from_known.c_str(), static_cast<long long>(st.other));
    us::SurveyResult result;
    try {
      result = us::survey_anchors(collector.input(anchors, known), sopt);
    } catch (const us::SurveyError& err) {
      ips::print_fatal(kProgram, std::string("survey failed: ") + err.what());
      return 1;
    }
    for (const auto& w : result.warnings)
      std::fprintf(stderr, "%s: warning: %s\n", kProgram, ips::printable(w).c_str());
    print_report(result, site, known, known_tag);
    if (out_path.empty()) {
      std::printf("(no --out: nothing written)\n");
      return 0;
    }
    std::vector<std::string> header = {
        "Surveyed by ips-uwb-survey from " + ips::printable(source) + ": " +
            std::to_string(result.pairs.size()) + " anchor pairs, range residual RMS " +
            fixed(result.residual_rms_m) + " m.",
        "Frame: " + ips::printable(anchors[0].id) + " at the origin, " +
            ips::printable(anchors[1].id) + " on +x, " + ips::printable(anchors[2].id) +
            (result.mirror == us::MirrorChoice::kReflected ? " at -y" : " at +y") +
            (result.mirror == us::MirrorChoice::kConvention ? " (by convention: no known point)."
                                                            : " (decided by a known point)."),
        "Heights are the input site's; comments of the input site are not kept."};
    std::string text;
    try {
      text = us::surveyed_site_yaml(site, result.anchors, header);
    } catch (const us::SurveyError& err) {
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
