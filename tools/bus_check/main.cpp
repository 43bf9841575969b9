// ips-bus-check: publishes a probe on a private channel and waits for it to come back, to tell
// whether this machine delivers LCM multicast to itself (it does not without a multicast route;
// docs/networking.md). With --wait-for it instead waits until the named processes report on
// HEALTH, so scripts start a publisher only once its subscribers are up.
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <set>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/version.hpp"

int main(int argc, char** argv) {
  CLI::App app{"ips-bus-check: checks that LCM messages published on this machine are received "
               "on this machine (exit status 0 when they are, 1 when not), or with --wait-for "
               "waits until the named processes publish their HEALTH.",
               "ips-bus-check"};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  double timeout_s = 2.0;
  std::vector<std::string> wait_for;
  app.add_option("--timeout", timeout_s, "seconds to wait")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 3600.0));
  app.add_option("--wait-for", wait_for,
                 "process names (health_t source, e.g. ips-uwb-twr) to wait for on HEALTH")
      ->type_name("NAME");
  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors("ips-bus-check", [&] {
    ips::Node node("ips-bus-check", opts);
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000));
    const std::string url = ips::effective_lcm_url(opts.lcm_url);

    if (!wait_for.empty()) {
      std::set<std::string> missing(wait_for.begin(), wait_for.end());
      node.subscribe<ips::health_t>(opts.channel(ips::channel::kHealth),
                                    [&](const ips::health_t& h, const std::string&) {
                                      missing.erase(h.source);
                                    });
      while (!missing.empty() && std::chrono::steady_clock::now() < deadline)
        if (!node.spin_once(50)) return 1;
      if (missing.empty()) return 0;
      std::string names;
      for (const auto& n : missing) names += (names.empty() ? "" : ", ") + n;
      std::fprintf(stderr, "ips-bus-check: no HEALTH from %s within %.1f s on %s\n",
                   names.c_str(), timeout_s, url.c_str());
      return 1;
    }

    const std::string channel = "IPS_BUS_CHECK_" + std::to_string(getpid());
    bool received = false;
    node.subscribe<ips::health_t>(channel,
                                  [&](const ips::health_t&, const std::string&) { received = true; });
    ips::health_t probe{};
    probe.utime = ips::wall_utime_now();
    probe.source = "ips-bus-check";
    probe.version = ips::version_text();
    auto next_send = std::chrono::steady_clock::now();
    while (!received && std::chrono::steady_clock::now() < deadline) {
      if (std::chrono::steady_clock::now() >= next_send) {
        node.publish(channel, probe);
        next_send += std::chrono::milliseconds(200);
      }
      if (!node.spin_once(50)) return 1;  // interrupted: no verdict
    }
    if (received) {
      std::printf("ips-bus-check: LCM traffic on %s reaches this machine\n", url.c_str());
      return 0;
    }
    std::fprintf(stderr,
                 "ips-bus-check: no LCM message came back within %.1f s on %s. This machine does "
                 "not deliver multicast to itself; add a route as root: "
                 "`ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo` "
                 "(see docs/networking.md)\n",
                 timeout_s, url.c_str());
    return 1;
  });
}
