// ips-uwb-calibrate: each tag-anchor pair's constant range offset (antenna delays) from a log of
// UWB_RANGE with the tags' TRUTH; prints the fit per pair and writes the site with the offsets as
// estimators.uwb_twr.range_offsets_m (read by ips-uwb-twr and ips-fuse).
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <optional>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"
#include "estimators/uwb_twr/offsets_site_file.hpp"
#include "estimators/uwb_twr/range_calibration.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"

namespace {

constexpr const char* kProgram = "ips-uwb-calibrate";
namespace twr = ips::uwb_twr;

std::string cell(double v, const char* format) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

void print_table(const twr::RangeCalibration& r, bool scale) {
  std::printf("%-8s %-8s %6s %6s %9s %9s %9s %9s %9s %9s", "tag", "anchor", "ranges", "n",
              "offset_m", "std_m", "rms_raw", "rms_cal", "med_cal", "med_site");
  if (scale) std::printf(" %10s %9s %9s", "scale", "scale_se", "line_b_m");
  std::printf("\n");
  for (const auto& p : r.pairs) {
    std::printf("%-8s %-8s %6lld %6lld %9s %9s %9s %9s %9s %9s", ips::printable(p.tag_id).c_str(),
                ips::printable(p.anchor_id).c_str(), static_cast<long long>(p.ranges),
                static_cast<long long>(p.n), cell(p.offset_m, "%+.4f").c_str(),
                cell(p.std_m, "%.4f").c_str(), cell(p.rms_before_m, "%.4f").c_str(),
                cell(p.rms_after_m, "%.4f").c_str(), cell(p.median_after_m, "%+.4f").c_str(),
                cell(p.median_site_m, "%+.4f").c_str());
    if (scale)
      std::printf(" %10s %9s %9s", cell(p.scale, "%+.6f").c_str(),
                  cell(p.scale_se, "%.6f").c_str(), cell(p.scale_bias_m, "%+.4f").c_str());
    std::printf("%s\n", p.refused.empty() ? "" : ("  refused: " + p.refused).c_str());
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "ips-uwb-calibrate: fits each tag-anchor pair's constant range offset (the median of range "
      "- |truth - anchor|, truth interpolated at the range's time) from an LCM log of UWB_RANGE "
      "with the tags' TRUTH, prints the fit and writes the site with the offsets as "
      "estimators.uwb_twr.range_offsets_m (keys ANCHOR when the log has one tag, TAG/ANCHOR "
      "otherwise).",
      kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, ips::CommonFlags{.lcm = false});
  std::string log_path, out_path, truth_channel;
  bool scale = false;
  twr::RangeCalibrationOptions fopt;
  app.add_option("LOG", log_path, "read UWB_RANGE, TRUTH (and SITE) from this LCM log")
      ->type_name("LOG")
      ->required();
  app.add_option("--truth", truth_channel,
                 "the channel of the reference poses (pose_t per tag); default: TRUTH (or its "
                 "--channel override)")
      ->type_name("CHANNEL");
  app.add_option("--out", out_path,
                 "write the site (--site, else the log's first SITE) with the offsets merged into "
                 "estimators.uwb_twr.range_offsets_m here; without it, only print the fit")
      ->type_name("SITE_OUT");
  app.add_flag("--scale", scale,
               "also fit each pair's scale, range = (1 + scale) d + b by least squares, and "
               "write it (estimators.uwb_twr.range_scales) with the offset of range / (1 + "
               "scale) - d; a pair whose distances vary by less than 0.5 m (std) keeps scale 0; "
               "|scale| > 0.1 is refused");
  app.add_flag("--force", fopt.force,
               "overwrite --out when it exists, and write pairs with fewer than 20 ranges with "
               "truth or an offset outside [-1, 1] m (refused otherwise)");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  fopt.fit_scale = scale;
  auto usage = [](const std::string& what) {
    ips::print_fatal(kProgram, what);
    return 2;
  };
  if (truth_channel.empty()) truth_channel = opts.channel(ips::channel::kTruth);
  std::error_code ec;
  if (!out_path.empty() && std::filesystem::exists(out_path, ec) && !fopt.force)
    return usage("--out: '" + ips::printable(out_path) + "' exists (--force overwrites it)");
  if (!out_path.empty()) {
    const std::filesystem::path dir = std::filesystem::path(out_path).parent_path();
    if (!std::filesystem::is_directory(dir.empty() ? "." : dir, ec))
      return usage("--out: no directory '" + ips::printable(dir.string()) + "'");
  }

  return ips::run_reporting_errors(kProgram, [&]() -> int {
    std::optional<ips::Site> site;
    const bool site_from_file = !opts.site_path.empty();
    if (site_from_file) site = ips::load_site_file(opts.site_path);  // ConfigError: status 2
    const std::string range_channel = opts.channel(ips::channel::kUwbRange);
    const std::string site_channel = opts.channel(ips::channel::kSite);
    int64_t bad_messages = 0, bad_sites = 0, truth_messages = 0;
    std::vector<twr::RangeSample> ranges;
    twr::TruthTracks truth;
    const auto log = ips::LogInput::open(kProgram, log_path);
    if (!log) return 2;
    while (const ips::LogEvent* e = log->next()) {
      if (e->channel == range_channel) {
        ips::uwb_range_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        ranges.push_back({m.tag_id, m.anchor_id, m.utime, m.range_m});
      } else if (e->channel == truth_channel) {
        ips::pose_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        ++truth_messages;
        const Eigen::Vector3d p(m.position[0], m.position[1], m.position[2]);
        if (p.allFinite()) truth[m.tag_id].push_back({m.utime, p});
      } else if (e->channel == site_channel && !site) {
        ips::site_t m;
        if (!ips::decode_message(m, e->data, e->size)) {
          ++bad_messages;
          continue;
        }
        try {
          site = ips::site_from_msg(m);
        } catch (const ips::SiteError& err) {
          if (bad_sites++ == 0) spdlog::warn("{}: skipped a bad SITE: {}", kProgram, err.what());
        }
      }
    }
    if (!log->finish("calibrating from what was read")) return 2;
    if (bad_messages > 0)
      std::fprintf(stderr, "%s: warning: %lld messages did not decode and were skipped\n", kProgram,
                   static_cast<long long>(bad_messages));
    if (!site) {
      ips::print_fatal(kProgram, "no site: " + ips::printable(log_path) +
                                     " has no SITE message; give the site with --site FILE");
      return 2;
    }
    if (ranges.empty()) {
      ips::print_fatal(kProgram, "no UWB_RANGE messages in " + ips::printable(log_path) +
                                     " (channel " + ips::printable(range_channel) + ")");
      return 2;
    }
    if (truth_messages == 0) {
      ips::print_fatal(kProgram, "no truth: no pose_t on channel " + ips::printable(truth_channel) +
                                     " in " + ips::printable(log_path) + " (--truth CHANNEL)");
      return 2;
    }
    // The input site's offsets (as the trackers read them): the med_site column.
    const twr::TwrParams site_params = twr::parse_twr_params(site->estimator_params("uwb_twr"));
    const twr::RangeCalibration result = twr::fit_range_offsets(
        *site, ranges, truth, fopt, site_params.range_offsets_m, site_params.range_scales);
    const auto& st = result.stats;
    std::printf("%s: %lld UWB_RANGE read, %lld TRUTH poses on %s; site from %s\n", kProgram,
                static_cast<long long>(st.ranges_in), static_cast<long long>(truth_messages),
                ips::printable(truth_channel).c_str(),
                site_from_file ? ips::printable(opts.site_path).c_str() : "the log's SITE");
    const std::pair<int64_t, const char*> skipped[] = {
        {st.unknown_anchor, "from anchors that are not enabled uwb anchors of the site"},
        {st.between_anchors, "between two anchors"},
        {st.invalid_range, "with a NaN, infinite or negative range"},
        {st.no_truth, "without truth of their tag within 0.2 s on both sides"}};
    for (const auto& [n, what] : skipped)
      if (n > 0) std::printf("skipped: %lld ranges %s\n", static_cast<long long>(n), what);
    std::printf(
        "\nresidual = range - |truth - anchor|; offset_m: its median; rms_raw / rms_cal: before "
        "/ after the offset; med_cal: median after it; med_site: median after the input site's "
        "offset\n");
    if (scale)
      std::printf(
          "scale: range = (1 + scale) d + line_b_m (least squares), scale_se its standard "
          "error; written (and offset_m and the columns after it of range / (1 + scale)) where "
          "the distances vary by 0.5 m or more and |scale| > 3 scale_se, else 0: see "
          "'scales:' below\n");
    print_table(result, scale);
    if (scale) {
      std::string used, unused;
      for (const auto& p : result.pairs)
        (p.scale_used ? used : unused) +=
            " " + ips::printable(p.tag_id) + "/" + ips::printable(p.anchor_id);
      std::printf("scales: used for%s; 0 for%s\n", used.empty() ? " none" : used.c_str(),
                  unused.empty() ? " none" : unused.c_str());
    }
    std::string refused;
    for (const auto& p : result.pairs)
      if (!p.refused.empty())
        refused += (refused.empty() ? "" : "; ") + ips::printable(p.tag_id) + "/" +
                   ips::printable(p.anchor_id) + ": " + p.refused;
    if (!refused.empty()) {
      ips::print_fatal(kProgram, "refused (--force writes them), nothing written: " + refused);
      return 2;
    }
    const auto offsets = twr::offsets_to_write(result.pairs);
    if (offsets.empty()) {
      ips::print_fatal(kProgram, "no tag-anchor pair with truth to calibrate");
      return 2;
    }
    if (out_path.empty()) {
      std::printf("(no --out: nothing written)\n");
      return 0;
    }
    const std::vector<std::string> header = {
        "Range offsets by ips-uwb-calibrate from " + ips::printable(log_path) + ": " +
            std::to_string(offsets.size()) + " pairs (estimators.uwb_twr.range_offsets_m).",
        "Comments of the input site are not kept."};
    return twr::write_offsets_site(
        kProgram, *site, offsets, header, out_path,
        scale ? twr::scales_to_write(result.pairs) : std::map<std::string, double>{});
  });
}
