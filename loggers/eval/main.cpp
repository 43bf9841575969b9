// ips-eval: reads an LCM log and scores every pose channel (and ALTITUDE) against TRUTH, per
// channel and tag or per channel.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ips/altitude_t.hpp>
#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <initializer_list>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <tuple>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/node.hpp"
#include "core/site.hpp"
#include "core/text_escape.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "loggers/eval/dwell_file.hpp"
#include "loggers/eval/evaluation.hpp"
#include "loggers/eval/health_verdict.hpp"
#include "loggers/eval/report.hpp"
#include "loggers/eval/time_window.hpp"

namespace {

void print_json_number(double v) {
  if (std::isfinite(v))
    std::printf("%.6f", v);
  else
    std::printf("null");
}

// A statistic for the table: "-" where nothing was measured (no height, a 2D estimator).
std::string table_number(double v) {
  char buf[32];
  if (std::isfinite(v))
    std::snprintf(buf, sizeof buf, "%8.3f", v);
  else
    std::snprintf(buf, sizeof buf, "%8s", "-");
  return buf;
}

void print_json_fields(std::initializer_list<std::pair<const char*, double>> fields, bool scored) {
  for (const auto& [name, v] : fields) {
    std::printf(", \"%s\": ", name);
    print_json_number(scored ? v : NAN);
  }
}

// The site's floors from the log's last SITE message, as ips-altitude reads them
// (estimators.altitude.floors); none when there is no SITE or it does not parse (a warning).
ips::altitude::FloorParams floors_of(const std::optional<ips::site_t>& site) {
  if (!site) return {};
  try {
    return ips::altitude::parse_altitude_params(ips::site_from_msg(*site).estimator_params("altitude"))
        .floors;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ips-eval: warning: SITE: floors not read (%s): floors not scored\n",
                 ips::printable(e.what()).c_str());
    return {};
  }
}

// The whole of a dwell file (a few kB); nullopt after an error line.
std::optional<std::string> read_small_file(const std::string& path, const char* flag) {
  constexpr std::uintmax_t kMaxBytes = 64u << 20;
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || !std::filesystem::is_regular_file(path, ec)) {
    ips::print_fatal("ips-eval", std::string(flag) + ": cannot read '" + ips::printable(path) +
                                     "': " + (ec ? ec.message() : "not a regular file"));
    return std::nullopt;
  }
  if (size > kMaxBytes) {
    ips::print_fatal("ips-eval", std::string(flag) + ": '" + ips::printable(path) +
                                     "' is larger than 64 MiB");
    return std::nullopt;
  }
  std::ifstream in(path, std::ios::binary);
  std::string text(static_cast<size_t>(size), '\0');
  if (!in || !in.read(text.data(), static_cast<std::streamsize>(size))) {
    ips::print_fatal("ips-eval", std::string(flag) + ": cannot read '" + ips::printable(path) +
                                     "': " + std::strerror(errno));
    return std::nullopt;
  }
  return text;
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
               "count, mean, RMSE, median, 95th percentile, max; vertical RMSE), and ALTITUDE "
               "(bias, RMSE, p95, max of the height error; share on the right floor).",
               "ips-eval"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = false, .site = false, .channels = true});
  std::string log_path;
  bool json = false;
  app.add_option("LOG", log_path, "LCM log file")->required();
  app.add_flag("--json", json, "print {\"rows\": [...]} instead of a table");
  bool health = false;
  app.add_flag("--health", health,
               "also give a verdict per process from the log's HEALTH messages: OK when it never "
               "reported degraded or error (starting only at the start), else when and why");
  std::vector<double> static_point;
  app.add_option("--static-point", static_point,
                 "static-point mode: score every estimate against this known point instead of "
                 "TRUTH (z only when given)")
      ->type_name("X,Y[,Z]")
      ->delimiter(',')
      ->expected(2, 3);
  std::string from_text, to_text, by = "tag";
  app.add_option("--from", from_text,
                 "score only estimates from this time: seconds from the log's first event, or a "
                 "Unix time in s (a number > 1e9), or ISO-8601 (2024-12-18T05:58:05Z)")
      ->type_name("S");
  app.add_option("--to", to_text, "score only estimates up to this time (as --from)")
      ->type_name("S");
  app.add_option("--by", by,
                 "rows per channel and tag (tag, the default) or per channel with the errors of "
                 "all its tags pooled (channel)")
      ->check(CLI::IsMember({"tag", "channel"}));
  std::string dwell_path, dwell_columns, dwell_time_unit, dwell_unit;
  app.add_option("--dwell", dwell_path,
                 "dwell mode: score every estimate of a tag inside a time range of FILE against "
                 "that range's known point (rows start,end,x,y[,z][,tag]; header names "
                 "StartTimestamp, EndTimestamp, X, Y, Z, Tag); estimates outside every range are "
                 "not scored; TRUTH is not needed")
      ->type_name("FILE");
  app.add_option("--dwell-columns", dwell_columns,
                 "the dwell file's columns by position, e.g. start,end,x,y,z,tag ('-' skips one); "
                 "default: from its header")
      ->type_name("LIST");
  app.add_option("--dwell-time-unit", dwell_time_unit,
                 "unit of the dwell file's epoch times: s, ms, us or ns (default: guessed from "
                 "their size; ISO-8601 times are read as such)")
      ->type_name("U");
  app.add_option("--dwell-unit", dwell_unit,
                 "unit of the dwell file's x, y, z: m (default), cm, mm, ... or a factor (0.01m)")
      ->type_name("U");
  std::string report_dir;
  auto* report_opt = app.add_option("--report", report_dir,
                 "also write DIR/index.html (map, error against time, error CDF, height against "
                 "time, statistics; self-contained) and the figures as DIR/map.svg, "
                 "error_time.svg, error_cdf.svg, height.svg")
      ->type_name("DIR");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  std::optional<ips::eval::TimeBound> from, to;
  for (auto [text, bound, flag] : {std::tuple{&from_text, &from, "--from"},
                                   std::tuple{&to_text, &to, "--to"}}) {
    if (text->empty()) continue;
    std::string error;
    *bound = ips::eval::parse_time_bound(*text, error);
    if (!*bound) {
      ips::print_fatal("ips-eval", std::string(flag) + ": " + error);
      return 2;
    }
  }
  // Comparable before the log is read when both are of one kind.
  if (from && to && from->absolute == to->absolute &&
      (from->absolute ? to->utime < from->utime : to->offset_s < from->offset_s)) {
    ips::print_fatal("ips-eval", "--to " + to_text + " is before --from " + from_text);
    return 2;
  }
  const bool by_channel = by == "channel";
  std::optional<ips::eval::DwellFile> dwell;
  if (!dwell_path.empty()) {
    if (!static_point.empty()) {
      ips::print_fatal("ips-eval", "--dwell excludes --static-point");
      return 2;
    }
    ips::eval::DwellFileOptions dopt;
    dopt.columns = dwell_columns;
    if (!dwell_time_unit.empty()) {
      dopt.time_unit = ips::table::time_unit_from_name(dwell_time_unit);
      if (!dopt.time_unit) {
        ips::print_fatal("ips-eval", "--dwell-time-unit: expected s, ms, us or ns, got '" +
                                         ips::printable(dwell_time_unit) + "'");
        return 2;
      }
    }
    if (!dwell_unit.empty()) {
      dopt.unit = ips::table::parse_unit(dwell_unit, ips::table::Quantity::kLength);
      if (!dopt.unit) {
        ips::print_fatal("ips-eval", "--dwell-unit: expected a length unit (" +
                                         std::string(ips::table::unit_names(
                                             ips::table::Quantity::kLength)) +
                                         "), got '" + ips::printable(dwell_unit) + "'");
        return 2;
      }
    }
    const auto text = read_small_file(dwell_path, "--dwell");
    if (!text) return 2;
    dwell = ips::eval::read_dwell_file(*text, ips::printable(dwell_path), dopt);
    if (!dwell->error.empty()) {
      ips::print_fatal("ips-eval", "--dwell: " + dwell->error);
      return 2;
    }
    const auto& t = dwell->tally;
    if (t.bad > 0)
      std::fprintf(stderr,
                   "ips-eval: warning: --dwell: %s: %lld of %lld rows rejected; the first, line "
                   "%lld '%s': %s\n",
                   ips::printable(dwell_path).c_str(), static_cast<long long>(t.bad),
                   static_cast<long long>(t.bad + t.rows), static_cast<long long>(t.first_bad_line),
                   t.first_bad_text.c_str(), t.first_bad_reason.c_str());
    // A header that names its columns wrongly (the BLE dataset's 0317/gt/rectangular.csv) maps
    // start and end onto one moment.
    size_t zero_length = 0;
    for (const auto& d : dwell->intervals) zero_length += d.start == d.end;
    if (zero_length > 0)
      std::fprintf(stderr,
                   "ips-eval: warning: --dwell: %s: %zu of %zu intervals have no length (start = "
                   "end; columns %s): check the columns, or name them with --dwell-columns\n",
                   ips::printable(dwell_path).c_str(), zero_length, dwell->intervals.size(),
                   dwell->columns.c_str());
  } else if (!dwell_columns.empty() || !dwell_time_unit.empty() || !dwell_unit.empty()) {
    ips::print_fatal("ips-eval",
                     "--dwell-columns, --dwell-time-unit and --dwell-unit need --dwell");
    return 2;
  }

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
  const std::string altitude_channel = opts.channel(ips::channel::kAltitude);
  const std::string health_channel = opts.channel(ips::channel::kHealth);
  ips::eval::HealthVerdicts verdicts;
  // The last SITE message that decodes: the report's map, the floors.
  std::optional<ips::site_t> site;
  ips::eval::Evaluator ev;
  if (!static_point.empty()) {
    if (static_point.size() < 2 || !std::isfinite(static_point[0]) || !std::isfinite(static_point[1])) {
      ips::print_fatal("ips-eval", "--static-point: expected X,Y or X,Y,Z in metres");
      return 2;
    }
    ev.set_static_point({static_point[0], static_point[1], static_point.size() > 2 ? static_point[2] : 0.0},
                        static_point.size() > 2);
  }
  if (dwell) ev.set_dwell_intervals(dwell->intervals);
  int64_t events = 0, poses = 0, truth = 0, altitudes = 0;
  ips::utime_t window_from = 0, window_to = 0, log_start = 0;
  while (const ips::LogEvent* e = log->next()) {
    if (++events == 1 && (from || to)) {
      // The window is known once the log's start is.
      log_start = e->timestamp_us;
      window_from = from ? from->resolve(log_start) : std::numeric_limits<ips::utime_t>::min();
      window_to = to ? to->resolve(log_start) : std::numeric_limits<ips::utime_t>::max();
      if (window_to < window_from) {
        ips::print_fatal("ips-eval", "--to " + to_text + " is before --from " + from_text +
                                         " (the log starts at " + ips::eval::iso8601_utc(log_start) +
                                         ")");
        return 2;
      }
      ev.set_window(window_from, window_to);
    }
    if (e->channel == site_channel) {
      ips::site_t s;
      if (ips::decode_message(s, e->data, e->size)) site = std::move(s);
      continue;
    }
    if (health && e->channel == health_channel) {
      ips::health_t h;
      if (ips::decode_message(h, e->data, e->size)) verdicts.add(h, e->timestamp_us);
      continue;
    }
    if (e->channel == altitude_channel) {
      ips::altitude_t a;
      if (ips::decode_message(a, e->data, e->size)) {
        ev.add_altitude(e->channel, a);
        ++altitudes;
      }
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
  if (altitudes > 0) ev.set_floors(floors_of(site));
  const auto rows = by_channel ? ev.rows_by_channel() : ev.rows();
  const auto alt_rows = by_channel ? ev.altitude_rows_by_channel() : ev.altitude_rows();
  const bool window = from || to;
  if (json) {
    std::printf("{\"by\": \"%s\", \"rows\": [", by.c_str());
    for (size_t i = 0; i < rows.size(); ++i) {
      const auto& r = rows[i];
      std::printf("%s{\"channel\": %s, \"tag\": %s, ", i ? ", " : "",
                  ips::json_quote(r.channel).c_str(),
                  by_channel ? "null" : ips::json_quote(r.tag).c_str());
      if (by_channel) std::printf("\"tags\": %zu, ", r.tags);
      std::printf("\"count\": %zu, \"non_finite\": %zu, \"count_v\": %zu", r.count, r.non_finite,
                  r.count_v);
      print_json_fields({{"mean_h", r.mean_h},
                         {"rmse_h", r.rmse_h},
                         {"median_h", r.median_h},
                         {"p95_h", r.p95_h},
                         {"max_h", r.max_h},
                         {"rmse_v", r.rmse_v},
                         {"cep50_h", r.cep50()},
                         {"cep95_h", r.cep95()},
                         {"mean_v", r.mean_v},
                         {"median_v", r.median_v},
                         {"p95_v", r.p95_v},
                         {"max_v", r.max_v}},
                        r.count > 0);
      std::printf("}");
    }
    std::printf("], \"altitude\": [");
    for (size_t i = 0; i < alt_rows.size(); ++i) {
      const auto& r = alt_rows[i];
      std::printf("%s{\"channel\": %s, \"tag\": %s, ", i ? ", " : "",
                  ips::json_quote(r.channel).c_str(),
                  by_channel ? "null" : ips::json_quote(r.tag).c_str());
      if (by_channel) std::printf("\"tags\": %zu, ", r.tags);
      std::printf("\"count\": %zu, \"non_finite\": %zu", r.count, r.non_finite);
      print_json_fields({{"bias_v", r.bias}, {"rmse_v", r.rmse}, {"p95_v", r.p95}, {"max_v", r.max}},
                        r.count > 0);
      std::printf(", \"floor_count\": %zu, \"floor_right\": %zu", r.floor_count, r.floor_right);
      print_json_fields({{"floor_share", r.floor_share()}}, true);
      std::printf("}");
    }
    std::printf("], \"%s\": %zu, \"altitudes_unmatched\": %zu", ev.dwell_mode() ? "outside_dwell" : "unmatched",
                ev.unmatched(), ev.altitudes_unmatched());
    if (health) {
      std::printf(", \"processes\": [");
      const auto& ps = verdicts.processes();
      for (size_t i = 0; i < ps.size(); ++i) {
        const auto& p = ps[i];
        std::printf("%s{\"source\": %s, \"host\": %s, \"pid\": %d, \"version\": %s, "
                    "\"verdict\": \"%s\", \"health\": %lld, \"starting\": %lld, \"ok\": %lld, "
                    "\"degraded\": %lld, \"error\": %lld, \"first_problem\": %s, \"note\": %s}",
                    i ? ", " : "", ips::json_quote(p.source).c_str(),
                    ips::json_quote(p.host).c_str(), p.pid, ips::json_quote(p.version).c_str(),
                    p.verdict(), static_cast<long long>(p.messages),
                    static_cast<long long>(p.starting), static_cast<long long>(p.ok),
                    static_cast<long long>(p.degraded), static_cast<long long>(p.error),
                    ips::json_quote(p.first_problem).c_str(), ips::json_quote(p.note).c_str());
      }
      std::printf("], \"all_ok\": %s", verdicts.all_ok() ? "true" : "false");
    }
    if (window) {
      // null for a bound not given (the start or the end of the log).
      auto bound = [](bool given, ips::utime_t t) {
        return given ? std::to_string(t) : std::string("null");
      };
      std::printf(", \"window\": {\"from_utime\": %s, \"to_utime\": %s, \"outside\": %zu}",
                  bound(from.has_value(), window_from).c_str(),
                  bound(to.has_value(), window_to).c_str(), ev.outside_window());
    }
    std::printf("}\n");
  } else {
    std::printf("%-14s %-10s %7s %8s %8s %8s %8s %8s %8s\n", "channel", "tag", "count", "mean_h",
                "rmse_h", "median_h", "p95_h", "max_h", "rmse_v");
    for (const auto& r : rows) {
      const bool scored = r.count > 0;  // no truth around any estimate: no numbers, not zeros
      std::printf("%-14s %-10s %7zu %s %s %s %s %s %s\n", ips::printable(r.channel).c_str(),
                  ips::printable(r.tag).c_str(), r.count,
                  table_number(scored ? r.mean_h : NAN).c_str(),
                  table_number(scored ? r.rmse_h : NAN).c_str(),
                  table_number(scored ? r.median_h : NAN).c_str(),
                  table_number(scored ? r.p95_h : NAN).c_str(),
                  table_number(scored ? r.max_h : NAN).c_str(),
                  table_number(scored ? r.rmse_v : NAN).c_str());
    }
    if (!alt_rows.empty()) {
      std::printf("%-14s %-10s %7s %8s %8s %8s %8s %8s\n", "altitude", "tag", "count", "bias_v",
                  "rmse_v", "p95_v", "max_v", "floor");
      for (const auto& r : alt_rows)
        std::printf("%-14s %-10s %7zu %s %s %s %s %s\n", ips::printable(r.channel).c_str(),
                    ips::printable(r.tag).c_str(), r.count, table_number(r.bias).c_str(),
                    table_number(r.rmse).c_str(), table_number(r.p95).c_str(),
                    table_number(r.max).c_str(), table_number(r.floor_share()).c_str());
    }
    std::printf("(errors in metres; %lld log events, %lld truth samples, %lld estimates, %zu "
                "estimates %s)\n",
                static_cast<long long>(events), static_cast<long long>(truth),
                static_cast<long long>(poses), ev.unmatched(),
                ev.dwell_mode() ? "outside every dwell interval" : "without truth around them");
    if (altitudes > 0)
      std::printf("(%lld altitudes, %zu of them without a reference height; floor: the share on "
                  "the right floor, where the site gives floors)\n",
                  static_cast<long long>(altitudes), ev.altitudes_unmatched());
    if (dwell)
      std::printf("(dwell mode: %zu intervals from %s; columns %s, times in %s, lengths x %g m)\n",
                  dwell->intervals.size(), ips::printable(dwell_path).c_str(),
                  dwell->columns.c_str(), dwell->time_unit.c_str(), dwell->unit_factor);
    if (window) {
      auto bound = [&](bool given, ips::utime_t t, const char* none) {
        if (!given) return std::string(none);
        char buf[48];
        std::snprintf(buf, sizeof buf, " (%.3f s)", static_cast<double>(t - log_start) * 1e-6);
        return ips::eval::iso8601_utc(t) + buf;
      };
      std::printf("(window from %s to %s, seconds from the log's first event; %zu estimates "
                  "outside it, not scored)\n",
                  bound(from.has_value(), window_from, "the start").c_str(),
                  bound(to.has_value(), window_to, "the end").c_str(), ev.outside_window());
    }
    if (health) {
      const auto& ps = verdicts.processes();
      std::printf("%-20s %-9s %s\n", "process", "verdict", "from its HEALTH");
      for (const auto& p : ps) std::printf("%s\n", ips::eval::verdict_line(p, log_start).c_str());
      const auto bad = std::count_if(ps.begin(), ps.end(), [](const auto& p) {
        return std::string(p.verdict()) != "OK";
      });
      if (ps.empty())
        std::printf("(health: no HEALTH message in the log)\n");
      else if (bad == 0)
        std::printf("(health: %zu processes, all OK)\n", ps.size());
      else
        std::printf("(health: %lld of %zu processes not OK)\n", static_cast<long long>(bad),
                    ps.size());
    }
  }
  if (!report_dir.empty()) {
    ips::eval::ReportInput in;
    in.log_path = log_path;
    in.truth_channel = truth_channel;
    in.rows = by_channel ? ev.rows() : rows;
    if (by_channel) in.channel_rows = rows;
    in.altitude_rows = alt_rows;
    in.series = ev.estimate_series();
    in.altitude_series = ev.altitude_series();
    in.truth = &ev.truth_tracks();
    in.static_point = ev.static_point();
    if (dwell) in.dwell = dwell->intervals;
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
        !write_report_file(report_dir, "height.svg", ips::eval::svg_document(report.height_svg),
                           error) ||
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
  if (truth == 0 && static_point.empty() && !ev.dwell_mode()) std::fprintf(stderr, "ips-eval: warning: no %s messages in %s\n", truth_channel.c_str(), log_path.c_str());
  if (rows.empty())
    std::fprintf(stderr, "ips-eval: warning: no pose estimates in %s\n", log_path.c_str());
  else if (dwell && ev.unmatched() > 0 &&
           std::none_of(rows.begin(), rows.end(), [](const auto& r) { return r.count > 0; }))
    std::fprintf(stderr,
                 "ips-eval: warning: no estimate is inside a dwell interval of %s (the file's "
                 "times and the log's do not meet)\n",
                 ips::printable(dwell_path).c_str());
  return 0;
}
