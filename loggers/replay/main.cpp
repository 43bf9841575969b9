// ips-replay: feeds a log, in file order, through every estimator hosted in this one process and
// writes the inputs plus the new estimates to a new log. The same input and binary give a
// byte-identical output.
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <memory>
#include <sstream>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/log_input.hpp"
#include "core/log_reader.hpp"
#include "core/text_escape.hpp"
#include "loggers/replay/replay_host.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ips-replay: runs a log through every estimator in one process, as fast as the CPU "
               "allows, and writes the inputs plus the new estimates (POSE_UWB, ...) to OUT. "
               "Input channels that the hosted estimators produce are regenerated, not copied.",
               "ips-replay"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = false, .site = true, .channels = true});
  std::string in_path, out_path, only;
  bool keep = false;
  app.add_option("IN", in_path, "input LCM log")->required();
  app.add_option("--out", out_path, "output LCM log (overwritten)")->required();
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
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (!ips::channel::valid_channel_name(zones_pose_channel)) {
    ips::print_fatal("ips-replay", "--zones-pose-channel: '" +
                                       ips::printable(zones_pose_channel) +
                                       "' is not a channel name (1 to 63 of A-Z a-z 0-9 _)");
    return 2;
  }

  return ips::run_reporting_errors("ips-replay", [&]() -> int {
    ips::replay::ReplayOptions ro;
    ro.keep_regenerated = keep;
    ro.site_path = opts.site_path;
    ro.zones_pose_channel = zones_pose_channel;
    std::stringstream names(only);
    for (std::string n; std::getline(names, n, ',');)
      if (!n.empty()) ro.only.insert(n);

    const auto in = ips::LogInput::open("ips-replay", in_path);
    if (!in) return 2;
    lcm::LogFile out(out_path, "w");
    if (!out.good()) {
      ips::print_fatal("ips-replay", "cannot write log '" + out_path + "'");
      return 2;
    }
    int64_t written = 0;
    bool write_failed = false;
    ips::replay::ReplayHost host(ro, opts, [&](const std::string& channel, int64_t timestamp,
                                               const uint8_t* data, size_t size) {
      lcm::LogEvent le;
      le.eventnum = written++;
      le.timestamp = timestamp;
      le.channel = channel;
      le.datalen = static_cast<int32_t>(size);
      le.data = const_cast<uint8_t*>(data);
      if (out.writeEvent(&le) != 0) write_failed = true;
    });

    const auto t0 = std::chrono::steady_clock::now();
    int64_t first_ts = 0, last_ts = 0;
    while (const ips::LogEvent* e = in->next()) {
      if (host.stats().events_in == 0) first_ts = e->timestamp_us;
      last_ts = e->timestamp_us;
      host.process(e->channel, e->timestamp_us, e->data, e->size);
      if (write_failed) {
        ips::print_fatal("ips-replay", "write to '" + out_path + "' failed (disk full?)");
        return 1;
      }
    }
    host.finish();
    if (!in->finish("replayed what was read")) return 2;
    if (std::fflush(out.getFilePtr()) != 0 || std::ferror(out.getFilePtr())) {
      ips::print_fatal("ips-replay", "write to '" + out_path + "' failed (disk full?)");
      return 1;
    }
    const auto& s = host.stats();
    const double secs =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double span = 1e-6 * static_cast<double>(last_ts - first_ts);
    std::string hosted;
    for (const auto& n : host.hosted()) hosted += (hosted.empty() ? "" : ", ") + n;
    spdlog::info("ips-replay: {} events in ({} passed through, {} regenerated channel events "
                 "dropped), {} estimates out [{}]; {} undecodable, {} bad sites; {:.2f} s "
                 "({:.0f} events/s, {:.0f}x real time)",
                 s.events_in, s.passed_through, s.dropped_regenerated, s.estimates_out, hosted,
                 s.undecodable, s.bad_sites, secs, static_cast<double>(s.events_in) / secs,
                 secs > 0 ? span / secs : 0.0);
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
