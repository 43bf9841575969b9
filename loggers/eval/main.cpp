// ips-eval: reads an LCM log and scores every pose channel against TRUTH, per channel and tag.
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <optional>
#include <set>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"
#include "loggers/eval/evaluation.hpp"
#include "loggers/eval/report.hpp"

namespace {

void print_json_number(double v) {
  if (std::isfinite(v))
    std::printf("%.6f", v);
  else
    std::printf("null");
}

// Writes `text` to DIR/name; on failure an error message naming the file and the reason.
bool write_report_file(const std::filesystem::path& dir, const char* name, const std::string& text,
                       std::string& error) {
  const auto path = dir / name;
  errno = 0;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (out) out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (out) out.close();
  if (!out) {
    error = "cannot write report file '" + ips::printable(path.string()) + "': " +
            (errno ? std::strerror(errno) : "write failed");
    return false;
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-eval: scores every pose channel of an LCM log against TRUTH (horizontal error "
               "count, mean, RMSE, median, 95th percentile, max; vertical RMSE).",
               "ips-eval"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = false, .site = false, .channels = true});
  std::string log_path;
  bool json = false;
  app.add_option("LOG", log_path, "LCM log file")->required();
  app.add_flag("--json", json, "print {\"rows\": [...]} instead of a table");
  std::vector<double> static_point;
  app.add_option("--static-point", static_point,
                 "static-point mode: score every estimate against this known point instead of "
                 "TRUTH (z only when given)")
      ->type_name("X,Y[,Z]")
      ->delimiter(',')
      ->expected(2, 3);
  std::string report_dir;
  auto* report_opt = app.add_option("--report", report_dir,
                 "also write DIR/index.html (map, error against time, error CDF, statistics; "
                 "self-contained) and the figures as DIR/map.svg, error_time.svg, error_cdf.svg")
      ->type_name("DIR");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;

  const auto log = ips::LogInput::open("ips-eval", log_path);
  if (!log) return 2;
  std::error_code ec;
  if (report_opt->count() > 0 && report_dir.empty()) {
    ips::print_fatal("ips-eval", "--report: expected a directory, got an empty name");
    return 2;
  }
  if (!report_dir.empty()) {
    // Before reading a long log, so an unwritable DIR fails at once.
    std::filesystem::create_directories(report_dir, ec);
    if (ec || !std::filesystem::is_directory(report_dir, ec)) {
      ips::print_fatal("ips-eval", "cannot create report directory '" +
                                       ips::printable(report_dir) + "': " +
                                       (ec ? ec.message() : std::string("not a directory")));
      return 2;
    }
  }
  const std::string truth_channel = opts.channel(ips::channel::kTruth);
  const std::string site_channel = opts.channel(ips::channel::kSite);
  std::optional<ips::site_t> site;  // the last SITE message that decodes, for the report's map
  ips::eval::Evaluator ev;
  if (!static_point.empty()) {
    if (static_point.size() < 2 || !std::isfinite(static_point[0]) || !std::isfinite(static_point[1])) {
      ips::print_fatal("ips-eval", "--static-point: expected X,Y or X,Y,Z in metres");
      return 2;
    }
    ev.set_static_point({static_point[0], static_point[1], static_point.size() > 2 ? static_point[2] : 0.0},
                        static_point.size() > 2);
  }
  int64_t events = 0, poses = 0, truth = 0;
  while (const ips::LogEvent* e = log->next()) {
    ++events;
    if (!report_dir.empty() && e->channel == site_channel) {
      ips::site_t s;
      if (ips::decode_message(s, e->data, e->size)) site = std::move(s);
      continue;
    }
    ips::pose_t m;
    // Only pose_t decodes here: the fingerprint check rejects every other type.
    if (!ips::decode_message(m, e->data, e->size)) continue;
    if (e->channel == truth_channel) {
      ev.add_truth(m);
      ++truth;
    } else {
      ev.add_estimate(e->channel, m);
      ++poses;
    }
  }
  if (!log->finish("scoring what was read")) return 2;
  const auto rows = ev.rows();
  if (json) {
    std::printf("{\"rows\": [");
    for (size_t i = 0; i < rows.size(); ++i) {
      const auto& r = rows[i];
      std::printf("%s{\"channel\": %s, \"tag\": %s, \"count\": %zu, \"non_finite\": %zu",
                  i ? ", " : "", ips::json_quote(r.channel).c_str(), ips::json_quote(r.tag).c_str(),
                  r.count, r.non_finite);
      const std::pair<const char*, double> fields[] = {
          {"mean_h", r.mean_h},     {"rmse_h", r.rmse_h},     {"median_h", r.median_h},
          {"p95_h", r.p95_h},       {"max_h", r.max_h},       {"rmse_v", r.rmse_v},
          {"cep50_h", r.cep50()},   {"cep95_h", r.cep95()},   {"mean_v", r.mean_v},
          {"median_v", r.median_v}, {"p95_v", r.p95_v},       {"max_v", r.max_v}};
      for (const auto& [name, v] : fields) {
        std::printf(", \"%s\": ", name);
        print_json_number(r.count ? v : NAN);
      }
      std::printf("}");
    }
    std::printf("]}\n");
  } else {
    std::printf("%-14s %-10s %7s %8s %8s %8s %8s %8s %8s\n", "channel", "tag", "count", "mean_h",
                "rmse_h", "median_h", "p95_h", "max_h", "rmse_v");
    for (const auto& r : rows) {
      if (r.count == 0) {  // no truth around any estimate: no numbers, rather than zeros
        std::printf("%-14s %-10s %7zu %8s %8s %8s %8s %8s %8s\n", ips::printable(r.channel).c_str(),
                    ips::printable(r.tag).c_str(), r.count, "-", "-", "-", "-", "-", "-");
        continue;
      }
      auto num = [](double v) {
        char buf[32];
        if (std::isfinite(v))
          std::snprintf(buf, sizeof buf, "%8.3f", v);
        else
          std::snprintf(buf, sizeof buf, "%8s", "-");  // not measured (e.g. no height)
        return std::string(buf);
      };
      std::printf("%-14s %-10s %7zu %s %s %s %s %s %s\n", ips::printable(r.channel).c_str(),
                  ips::printable(r.tag).c_str(), r.count, num(r.mean_h).c_str(),
                  num(r.rmse_h).c_str(), num(r.median_h).c_str(), num(r.p95_h).c_str(),
                  num(r.max_h).c_str(), num(r.rmse_v).c_str());
    }
    std::printf("(errors in metres; %lld log events, %lld truth samples, %lld estimates, %zu "
                "estimates without truth around them)\n",
                static_cast<long long>(events), static_cast<long long>(truth),
                static_cast<long long>(poses), ev.unmatched());
  }
  if (!report_dir.empty()) {
    ips::eval::ReportInput in;
    in.log_path = log_path;
    in.truth_channel = truth_channel;
    in.rows = rows;
    in.series = ev.estimate_series();
    in.truth = &ev.truth_tracks();
    in.static_point = ev.static_point();
    if (site)
      for (const auto& a : site->anchors)
        in.anchors.push_back({a.id, a.position[0], a.position[1], a.enabled != 0});
    in.events = events;
    in.truth_samples = truth;
    in.estimates = poses;
    in.unmatched = ev.unmatched();
    const auto report = ips::eval::build_report(in);
    std::string error;
    if (!write_report_file(report_dir, "map.svg", ips::eval::svg_document(report.map_svg), error) ||
        !write_report_file(report_dir, "error_time.svg",
                           ips::eval::svg_document(report.error_time_svg), error) ||
        !write_report_file(report_dir, "error_cdf.svg",
                           ips::eval::svg_document(report.error_cdf_svg), error) ||
        !write_report_file(report_dir, "index.html", report.index_html, error)) {
      ips::print_fatal("ips-eval", error);
      return 2;
    }
  }
  size_t non_finite = 0;
  for (const auto& r : rows) non_finite += r.non_finite;
  if (non_finite > 0)
    std::fprintf(stderr, "ips-eval: warning: %zu estimates have a non-finite position (not scored)\n",
                 non_finite);
  if (ev.bad_truth() > 0)
    std::fprintf(stderr, "ips-eval: warning: %zu truth samples with a non-finite position or bad "
                 "utime were ignored\n", ev.bad_truth());
  if (truth == 0 && static_point.empty()) std::fprintf(stderr, "ips-eval: warning: no %s messages in %s\n", truth_channel.c_str(), log_path.c_str());
  if (rows.empty()) std::fprintf(stderr, "ips-eval: warning: no pose estimates in %s\n", log_path.c_str());
  return 0;
}
