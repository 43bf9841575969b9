#include "tools/deploy/systemd_units.hpp"

#include <cmath>
#include <cstdio>

namespace ips::deploy {

namespace {

std::string seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%gs", s);
  return buf;
}

// Doublings from initial_s to max_s: RestartSteps, so that systemd >= 254 backs off as
// ips-deploy run does.
int backoff_steps(const Backoff& b) {
  if (b.max_s <= b.initial_s) return 0;
  return static_cast<int>(std::ceil(std::log2(b.max_s / b.initial_s)));
}

}  // namespace

std::string systemd_quote(const std::string& word, bool exec) {
  std::string out = "\"";
  for (char c : word) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '%' || (exec && c == '$')) out += c;
    out += c;
  }
  return out + '"';
}

std::string unit_name(const Deployment& d, const Process& p) {
  return "ips-" + d.name + "-" + p.name + ".service";
}

std::string target_name(const Deployment& d) { return "ips-" + d.name + ".target"; }

std::map<std::string, std::string> systemd_units(const Deployment& d, const Host& host,
                                                 const std::map<std::string, std::string>& resolved) {
  std::map<std::string, std::string> files;
  const std::string target = target_name(d);
  std::string wants;
  for (const Process& p : host.processes) {
    wants += (wants.empty() ? "" : " ") + unit_name(d, p);
    std::string after = "network-online.target";
    for (const std::string& a : p.after) {
      for (const Process& q : host.processes)
        if (q.name == a) after += " " + unit_name(d, q);
    }
    std::string exec = systemd_quote(resolved.at(p.name), true);
    for (const std::string& arg : p.args) exec += " " + systemd_quote(arg, true);
    std::string u;
    u += "# Written by ips-deploy from the deployment '" + d.name + "', host '" + host.name +
         "'. Regenerate rather than edit.\n";
    u += "[Unit]\n";
    u += "Description=ips-fusion " + d.name + ": " + p.name + " on " + host.name + "\n";
    u += "Wants=network-online.target\n";
    u += "After=" + after + "\n";
    u += "PartOf=" + target + "\n";
    u += "StartLimitIntervalSec=0\n\n";
    u += "[Service]\n";
    u += "Type=simple\n";
    u += "ExecStart=" + exec + "\n";
    for (const auto& [k, v] : process_environment(d, p))
      u += "Environment=" + systemd_quote(k + "=" + v, false) + "\n";
    if (!d.working_dir.empty()) {
      std::string dir;  // specifiers doubled, as in systemd_quote()
      for (char ch : d.working_dir) dir += ch == '%' ? std::string("%%") : std::string(1, ch);
      u += "WorkingDirectory=" + dir + "\n";
    }
    if (!d.user.empty()) u += "User=" + d.user + "\n";
    u += std::string("Restart=") + restart_name(p.restart) + "\n";
    u += "RestartSec=" + seconds(p.backoff.initial_s) + "\n";
    const int steps = backoff_steps(p.backoff);
    if (steps > 0) {
      u += "# Exponential back-off (systemd >= 254; older versions ignore these two lines).\n";
      u += "RestartSteps=" + std::to_string(steps) + "\n";
      u += "RestartMaxDelaySec=" + seconds(p.backoff.max_s) + "\n";
    }
    // The programs end cleanly on SIGINT (ips-record flushes its log).
    u += "KillSignal=SIGINT\n";
    u += "TimeoutStopSec=" + seconds(p.stop_timeout_s) + "\n\n";
    u += "[Install]\n";
    u += "WantedBy=" + target + "\n";
    files[unit_name(d, p)] = u;
  }
  std::string t;
  t += "# Written by ips-deploy from the deployment '" + d.name + "', host '" + host.name + "'.\n";
  t += "[Unit]\n";
  t += "Description=ips-fusion " + d.name + " on " + host.name + "\n";
  t += "Wants=" + wants + "\n\n";
  t += "[Install]\n";
  t += "WantedBy=multi-user.target\n";
  files[target] = t;
  return files;
}

}  // namespace ips::deploy
