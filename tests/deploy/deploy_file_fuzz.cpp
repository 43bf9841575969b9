// libFuzzer target: deployment files (tools/deploy/deployment.hpp) are text from the lab's
// own hands, but a typo must still end in a ConfigError, never a crash or a hang. Whatever
// parses goes on through the systemd units of every host and the status table (with one HEALTH
// per process, so every row kind is built), and must keep its promises: every process of a host
// gets its unit, and a process comes after every process it names in `after`. The same bytes
// are also read as a run file (run_file.hpp): refused with a reason, or read back as written.
#include <cstddef>
#include <cstdint>
#include <set>
#include <stdexcept>
#include <string>

#include "core/yaml_fields.hpp"
#include "tools/deploy/deployment.hpp"
#include "tools/deploy/run_file.hpp"
#include "tools/deploy/status.hpp"
#include "tools/deploy/systemd_units.hpp"

namespace {
void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // The same bytes as a run file (tools/deploy/run_file.hpp): read back exactly, or refused.
  std::string run_error;
  if (const auto run = ips::deploy::parse_run_file(text, run_error)) {
    std::string again_error;
    const auto again = ips::deploy::parse_run_file(ips::deploy::format_run_file(*run), again_error);
    check(again && again->pids == run->pids && again->hostname == run->hostname,
          "a run file reads back as written");
  } else {
    check(!run_error.empty(), "a refused run file says why");
  }
  ips::deploy::Deployment d;
  try {
    d = ips::deploy::parse_deployment(ips::parse_yaml_text(text, "fuzz.yaml"));
  } catch (const ips::ConfigError&) {
    return 0;
  }
  std::vector<ips::deploy::Heard> heard;
  for (const ips::deploy::Host& h : d.hosts) {
    std::map<std::string, std::string> resolved;
    std::set<std::string> started;
    for (const ips::deploy::Process& p : h.processes) {
      for (const std::string& a : p.after) check(started.count(a) > 0, "started before its after");
      started.insert(p.name);
      resolved[p.name] = ips::deploy::resolve_command(p.command, "/opt/bin",
                                                      [](const std::string&) { return true; });
      ips::deploy::Heard x;
      x.health.source = p.command;
      x.health.host = h.hostname;
      x.health.pid = static_cast<int32_t>(heard.size() + 1);
      x.host_utime = 1'000'000;
      heard.push_back(x);
    }
    const auto units = ips::deploy::systemd_units(d, h, resolved, 254);
    check(units.size() == h.processes.size() + 1, "a unit per process and the target");
    // systemd 252: a retry unit at most per process besides.
    const auto old_units = ips::deploy::systemd_units(d, h, resolved, 252);
    check(old_units.size() >= units.size() && old_units.size() <= 2 * h.processes.size() + 1,
          "systemd 252: at most a retry unit per process more");
  }
  const auto report = ips::deploy::compare_status(&d, heard, 1'500'000);
  (void)ips::deploy::format_status(report);
  (void)ips::deploy::status_json(report);
  return 0;
}
