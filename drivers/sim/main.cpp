// ips-sim: publishes a simulated lab live over LCM, or writes it as fast as it can into a
// standard LCM log (--out). Deterministic for a seed.
#include <unistd.h>

#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <spdlog/spdlog.h>
#include <thread>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/progress.hpp"
#include "core/site_source.hpp"
#include "drivers/sim/simulator.hpp"

namespace {

constexpr ips::utime_t kDefaultLogStart = 1767225600000000;  // 2026-01-01T00:00:00Z

int write_log(ips::sim::Simulator& sim, const ips::CommonOptions& opts, const std::string& path) {
  lcm::LogFile log(path, "w");
  if (!log.good()) {
    ips::print_fatal("ips-sim", "cannot write log '" + path + "'");
    return 1;
  }
  ips::ProgressLine progress("ips-sim");
  ips::sim::SimEvent ev;
  int64_t count = 0;
  const double span = static_cast<double>(sim.end_utime() - sim.start_utime());
  while (sim.next(ev)) {
    lcm::LogEvent le;
    le.eventnum = count;
    le.timestamp = ev.utime;
    le.channel = opts.channel(ev.kind);
    le.datalen = static_cast<int32_t>(ev.data.size());
    le.data = ev.data.data();
    if (log.writeEvent(&le) != 0) {
      ips::print_fatal("ips-sim", "write to '" + path + "' failed (disk full?)");
      return 1;
    }
    ++count;
    progress.update(static_cast<double>(ev.utime - sim.start_utime()) / span, count);
  }
  progress.finish();
  // The log's last buffer is written at close: check it here, not in LogFile's silent destructor.
  if (std::fflush(log.getFilePtr()) != 0 || std::ferror(log.getFilePtr())) {
    ips::print_fatal("ips-sim", "write to '" + path + "' failed (disk full?)");
    return 1;
  }
  spdlog::info("ips-sim: wrote {} messages ({:.0f} s of scenario '{}') to {}", count, span * 1e-6,
               sim.scenario().name, path);
  return 0;
}

int publish_live(ips::sim::Simulator& sim, ips::Node& node, double speed) {
  ips::sim::SimEvent ev;
  // The SITE published last: the answer to a process that asks for it (a restarted estimator).
  std::optional<ips::site_t> site;
  ips::answer_site_requests(node, [&]() -> const ips::site_t* { return site ? &*site : nullptr; });
  const auto wall0 = std::chrono::steady_clock::now();
  int64_t count = 0;
  spdlog::info("ips-sim: publishing scenario '{}' live for {:.0f} s (speed x{}) on {}",
               sim.scenario().name, 1e-6 * static_cast<double>(sim.end_utime() - sim.start_utime()),
               speed, ips::effective_lcm_url(node.options().lcm_url));
  while (sim.next(ev)) {
    const auto due = wall0 + std::chrono::microseconds(static_cast<int64_t>(
                                 static_cast<double>(ev.utime - sim.start_utime()) / speed));
    for (;;) {
      auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                      due - std::chrono::steady_clock::now())
                      .count();
      if (left <= 0) break;
      if (!node.spin_once(static_cast<int>(std::min<int64_t>(left, 100)))) return 0;
    }
    if (!node.spin_once(0)) return 0;
    node.publish_raw(node.options().channel(ev.kind), ev.data.data(), ev.data.size());
    if (ev.kind == ips::channel::kSite) {
      ips::site_t m;
      if (ips::decode_message(m, ev.data.data(), ev.data.size())) site = std::move(m);
    }
    ++count;
  }
  node.publish_health();
  spdlog::info("ips-sim: scenario over, {} messages published", count);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-sim: simulated lab. Publishes SITE, TRUTH and sensor messages live over LCM, "
               "or writes them into a standard LCM log with --out.",
               "ips-sim"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  std::string scenario_name;
  uint64_t seed = 1;
  double duration = 0;
  double speed = 1.0;
  std::string out;
  std::optional<int64_t> start_utime;
  bool list = false;
  int tags = 1;
  app.add_option("--scenario", scenario_name, "built-in scenario name or scenario file")
      ->type_name("NAME|FILE");
  app.add_option("--seed", seed, "random seed")->capture_default_str();
  app.add_option("--duration", duration, "seconds to simulate (default: the scenario's)")
      ->check(CLI::Range(1e-3, 1e7));
  auto* out_opt =
      app.add_option("--out", out, "write a standard LCM log as fast as possible instead of "
                                   "publishing")
          ->type_name("FILE.lcm");
  auto* speed_opt = app.add_option("--speed", speed, "live mode: playback speed factor")
                        ->capture_default_str()
                        ->check(CLI::Range(1e-3, 1e4));
  out_opt->excludes(speed_opt);
  if (auto* url_opt = app.get_option_no_throw("--lcm-url")) out_opt->excludes(url_opt);
  app.add_option("--start-utime", start_utime,
                 "utime of the scenario start (default: now when live, 2026-01-01T00:00:00Z with "
                 "--out)");
  app.add_flag("--list-scenarios", list, "print the built-in scenario names and exit");
  app.add_option("--tags", tags,
                 "walkers per scenario walker: copies named <tag>-2 ... <tag>-N walk the same "
                 "path, started later")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000));
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  if (list) {
    for (const auto& n : ips::sim::builtin_scenario_names()) std::printf("%s\n", n.c_str());
    return 0;
  }
  if (start_utime && !ips::plausible_utime(*start_utime)) {
    ips::print_fatal("ips-sim", "--start-utime: must be a positive utime before the year 2096");
    return 2;
  }
  if (scenario_name.empty()) {
    ips::print_fatal("ips-sim", "--scenario is required (built-in: lab; see --list-scenarios)");
    return 2;
  }
  return ips::run_reporting_errors("ips-sim", [&] {
    ips::sim::Scenario sc = ips::sim::load_scenario(scenario_name);
    if (duration > 0) sc.duration_s = duration;
    ips::sim::replicate_walkers(sc, tags);
    if (!out.empty()) {
      ips::sim::Simulator sim(std::move(sc), seed, start_utime.value_or(kDefaultLogStart));
      return write_log(sim, opts, out);
    }
    ips::Node node("ips-sim", opts);
    ips::sim::Simulator sim(std::move(sc), seed, start_utime.value_or(ips::wall_utime_now()));
    return publish_live(sim, node, speed);
  });
}
