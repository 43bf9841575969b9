// ips-replay: feeds a log, in file order, through every estimator hosted in this one process and
// writes the inputs plus the new estimates to a new log. The same input and binary give a
// byte-identical output.
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <sstream>
#include <thread>
#include <utility>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/log_reader.hpp"
#include "core/log_writer.hpp"
#include "core/text_escape.hpp"
#include "loggers/replay/replay_host.hpp"
#include "loggers/replay/replayer.hpp"
#include "loggers/replay/sweep.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ips-replay: runs a log through every estimator in one process, as fast as the CPU "
               "allows, and writes the inputs plus the new estimates (POSE_UWB, ...) to OUT. "
               "Input channels that the hosted estimators produce are regenerated, not copied. "
               "With --set, a parameter sweep: every combination of the values replayed (on "
               "every core) and scored against TRUTH, one row per configuration.\n\n"
               "Examples:\n  ips-replay lab.lcm --out lab-replayed.lcm\n"
               "  ips-replay lab.lcm --set estimators.fuse.range_sigma_m=0.05,0.1,0.2 "
               "--set estimators.fuse.accel_psd=0.5,1\n",
               "ips-replay"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts,
                          {.lcm = false, .site = true, .channels = true, .tags = true});
  std::string out_path, only;
  std::vector<std::string> in_paths;
  bool keep = false;
  app.add_option("IN", in_paths, "input LCM log (with --set: one or more)")->required();
  app.add_option("--out", out_path, "output LCM log (overwritten); required unless --set");
  app.add_option("--only", only, "comma-separated estimators to host (default: all; available: " +
                                      [] {
                                        std::string s;
                                        for (const auto& n : ips::replay::ReplayHost::available())
                                          s += (s.empty() ? "" : ", ") + n;
                                        return s;
                                      }() +
                                      ")");
  std::string zones_pose_channel = "POSE_FUSED";
  app.add_option("--zones-pose-channel", zones_pose_channel,
                 "the poses the hosted ips-zones watches (its --pose-channel: TRUTH, "
                 "POSE_UWB, ...)")
      ->capture_default_str();
  app.add_flag("--keep", keep, "also copy input events on channels the estimators regenerate");
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int jobs = 0;
  app.add_option("--jobs", jobs,
                 "threads. A replay: 1 runs everything on one; 2 runs ips-fuse, ips-zones and the "
                 "output on a second; with --lanes, the lanes run on this many threads (at most "
                 "L) beside a reading and a merging one (the same bytes out for any number). A "
                 "sweep: configurations replayed side by side. Default: the cores (" +
                     std::to_string(cores) + " here; at most 2 for a replay without --lanes)")
      ->check(CLI::Range(1, 1024));
  int lanes = 0;
  app.add_option("--lanes", lanes,
                 "split the tags into L lanes (by their shard among L, as --shard), each with its "
                 "own instance of every estimator but ips-zones, as L shards of a live site: "
                 "--jobs threads run them side by side. The output depends on L, not on --jobs; "
                 "what an estimator learns across tags (each BLE anchor's angle noise, the TDoA "
                 "anchors' clocks) each lane learns from its own tags")
      ->check(CLI::Range(1, 1024));
  std::vector<std::string> sets;
  app.add_option("--set", sets,
                 "KEY=V1,V2,...: a site setting and the values to try (a sweep); repeatable: "
                 "every combination runs")
      ->type_name("KEY=V1,V2");
  std::string sort_metric = "rmse";
  app.add_option("--sort", sort_metric, "a sweep's metric, smallest first")
      ->check(CLI::IsMember(ips::replay::sweep_metrics()))
      ->capture_default_str();
  std::string score_channel = "POSE_FUSED";
  app.add_option("--score-channel", score_channel, "the channel a sweep scores against TRUTH")
      ->capture_default_str();
  bool json = false;
  app.add_flag("--json", json, "a sweep's table as JSON on stdout");
  std::string out_dir;
  app.add_option("--out-dir", out_dir,
                 "a sweep: also write each configuration's replay into DIR (config-N.lcm, "
                 "config-N-log-K.lcm with several logs; index.tsv names their settings)");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (!ips::channel::valid_channel_name(zones_pose_channel)) {
    ips::print_fatal("ips-replay", "--zones-pose-channel: '" +
                                       ips::printable(zones_pose_channel) +
                                       "' is not a channel name (1 to 63 of A-Z a-z 0-9 _)");
    return 2;
  }

  if (sets.empty() && (in_paths.size() != 1 || out_path.empty())) {
    ips::print_fatal("ips-replay", in_paths.size() != 1
                                       ? "one IN log to replay (several only with --set)"
                                       : "--out is required (unless --set: a sweep)");
    return 2;
  }
  if (!sets.empty() && !out_path.empty()) {
    ips::print_fatal("ips-replay", "--out does not apply to a sweep (--set)");
    return 2;
  }
  if (sets.empty() && !out_dir.empty()) {
    ips::print_fatal("ips-replay", "--out-dir is for a sweep (--set); a replay writes --out");
    return 2;
  }

  return ips::run_reporting_errors("ips-replay", [&]() -> int {
    ips::replay::ReplayOptions ro;
    ro.keep_regenerated = keep;
    ro.site_path = opts.site_path;
    ro.zones_pose_channel = zones_pose_channel;
    ro.tags = opts.tags;
    ro.shard = opts.shard;
    ro.lanes = lanes;
    ro.threads = jobs > 0 ? jobs : lanes > 0 ? cores : std::min(cores, 2);
    std::stringstream names(only);
    for (std::string n; std::getline(names, n, ',');)
      if (!n.empty()) ro.only.insert(n);
    if (!sets.empty()) {
      ips::replay::SweepOptions so;
      so.logs = in_paths;
      for (const auto& s : sets) so.settings.push_back(ips::replay::parse_sweep_setting(s));
      so.site_path = opts.site_path;
      so.channel = opts.channel(score_channel);
      so.metric = sort_metric;
      so.jobs = jobs > 0 ? jobs : cores;
      so.replay = ro;
      so.out_dir = out_dir;
      so.channels = opts;
      ips::ProgressLine progress("ips-replay");
      so.progress = [&](size_t done, size_t total) {
        if (progress.enabled())
          progress.update(static_cast<double>(done) / static_cast<double>(total),
                          static_cast<int64_t>(done));
      };
      const auto t0 = std::chrono::steady_clock::now();
      const auto rows = ips::replay::run_sweep(so);
      progress.finish();
      const double secs =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      const std::string out =
          json ? ips::replay::sweep_json(so, rows) : ips::replay::sweep_table(so, rows);
      std::fputs(out.c_str(), stdout);
      size_t failed = 0;
      for (const auto& r : rows) failed += r.error.empty() ? 0 : 1;
      const size_t runs = rows.size() * so.logs.size();
      spdlog::info("ips-replay: {} configurations x {} logs in {:.1f} s on {} threads; {} failed",
                   rows.size(), so.logs.size(), secs, std::min<size_t>(so.jobs, runs), failed);
      return failed == rows.size() ? 1 : 0;
    }
    const std::string& in_path = in_paths.front();

    // Mapped: read in place, and the events' bytes handed on uncopied.
    const auto in = ips::LogInput::open("ips-replay", in_path, true);
    if (!in) return 2;
    ips::LogWriter out(out_path);
    if (!out.ok()) {
      ips::print_fatal("ips-replay", out.error());
      return 2;
    }
    std::atomic<bool> write_failed{false};
    ips::replay::Replayer host(
        ro, opts,
        [&](const std::string& channel, int64_t timestamp, const uint8_t* data, size_t size) {
          if (!out.add(channel, timestamp, data, size)) write_failed = true;
        });

    const auto t0 = std::chrono::steady_clock::now();
    int64_t first_ts = 0, last_ts = 0;
    bool first = true;
    while (const ips::LogEvent* e = in->next()) {
      if (std::exchange(first, false)) first_ts = e->timestamp_us;
      last_ts = e->timestamp_us;
      host.process(e->channel, e->timestamp_us, e->data, e->size, true);
      if (write_failed) break;
    }
    host.finish();
    if (write_failed || !out.close()) {
      ips::print_fatal("ips-replay", out.error() + " (disk full?)");
      return 1;
    }
    if (!in->finish("replayed what was read")) return 2;
    const auto& s = host.stats();
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double span = 1e-6 * static_cast<double>(last_ts - first_ts);
    std::string hosted;
    for (const auto& n : host.hosted()) hosted += (hosted.empty() ? "" : ", ") + n;
    spdlog::info(
        "ips-replay: {} events in ({} passed through, {} regenerated channel events "
        "dropped), {} estimates out [{}]; {} undecodable, {} bad sites; {:.2f} s "
        "({:.0f} events/s, {:.0f}x real time; {} thread{}{})",
        s.events_in, s.passed_through, s.dropped_regenerated, s.estimates_out, hosted,
        s.undecodable, s.bad_sites, secs, static_cast<double>(s.events_in) / secs,
        secs > 0 ? span / secs : 0.0, host.threads(), host.threads() > 1 ? "s" : "",
        host.lanes() > 0 ? ", " + std::to_string(host.lanes()) + " lanes" : "");
    if (host.lanes() > 0) {
      // Where the time went, for what more cores would give (scripts/bench-replay).
      const auto cpu = host.cpu_times();
      const auto [least, most] = std::minmax_element(cpu.lanes_s.begin(), cpu.lanes_s.end());
      double sum = 0.0;
      for (double t : cpu.lanes_s) sum += t;
      std::string each;
      for (double t : cpu.lanes_s) each += (each.empty() ? "" : " ") + fmt::format("{:.3f}", t);
      spdlog::info(
          "ips-replay: CPU: lanes {:.2f} to {:.2f} s each, {:.2f} s in all; reading and "
          "dispatching {:.2f} s; ips-zones and writing {:.2f} s",
          *least, *most, sum, cpu.caller_s, cpu.merging_s);
      spdlog::info("ips-replay: CPU of each lane, s: {}", each);
    }
    if (host.repeated_estimates() > 0) {
      std::string which;
      for (const auto& [channel, n] : host.repeated_by_channel())
        which += (which.empty() ? "" : ", ") + channel + " " + std::to_string(n);
      spdlog::info(
          "ips-replay: {} estimates made the same by several lanes for the same input "
          "written once ({}), and counted once",
          host.repeated_estimates(), which);
    }
    if (!host.tag_selector().selects_all())
      spdlog::info("ips-replay: {}: {} messages of other tags not estimated (passed through)",
                   host.tag_selector().describe(), s.skipped_other_tags);
    // Per estimator: in, out, and why inputs gave nothing; an estimator that had input and gave
    // nothing for a fault is a warning. A replay that estimated nothing at all fails (status 1)
    // with one error line that carries the reasons.
    const std::string why = host.nothing_estimated();
    for (const auto& a : host.accounts()) {
      if (a.warn && why.empty()) {
        spdlog::warn("ips-replay: {}", a.line);
      } else {
        spdlog::info("ips-replay: {}", a.line);
      }
      if (!a.notes.empty() && a.messages_in > 0)
        spdlog::info("ips-replay: {}: {}", a.name, a.notes);
      if (!a.consistency.empty())
        spdlog::info("ips-replay: {}: consistency: {}", a.name, a.consistency);
      if (!a.consistency_problems.empty())
        spdlog::warn("ips-replay: {}: at the end: {}", a.name, a.consistency_problems);
      // An estimator hosted by default that only waited (an INS on a hand-held phone) says why
      // without a warning; one that estimated, or was asked for, warns.
      if (!a.problems.empty()) {
        if (a.silent && !a.warn)
          spdlog::info("ips-replay: {}: {}", a.name, a.problems);
        else
          spdlog::warn("ips-replay: {}: {}", a.name, a.problems);
      }
    }
    if (!why.empty()) {
      ips::print_fatal("ips-replay", why);
      return 1;
    }
    return 0;
  });
}
