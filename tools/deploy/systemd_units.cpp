#include "tools/deploy/systemd_units.hpp"

#include <algorithm>
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

// The restart lines of a service, for systemd_version: [Unit] lines (start limit, OnFailure=)
// and [Service] lines (RestartSec= and what follows).
struct RestartLines {
  std::string unit, service;
  bool retry = false;  // with ips-<deployment>-<process>-retry.service
};

RestartLines restart_lines(const Deployment& d, const Process& p, int systemd_version) {
  RestartLines r;
  r.service = std::string("Restart=") + restart_name(p.restart) + "\n";
  r.service += "RestartSec=" + seconds(p.backoff.initial_s) + "\n";
  const int steps = backoff_steps(p.backoff);
  if (systemd_version >= kSystemdBackoffVersion) {
    r.unit = "StartLimitIntervalSec=0\n";
    if (steps > 0) {
      r.service += "# Exponential back-off (systemd >= " +
                   std::to_string(kSystemdBackoffVersion) + ").\n";
      r.service += "RestartSteps=" + std::to_string(steps) + "\n";
      r.service += "RestartMaxDelaySec=" + seconds(p.backoff.max_s) + "\n";
    }
    return r;
  }
  const StartLimit limit = start_limit(p.backoff);
  if (p.restart == Restart::kNo || limit.burst == 0) {
    r.unit = "StartLimitIntervalSec=0\n";
    return r;
  }
  char text[512];
  std::snprintf(text, sizeof text,
                "# systemd %d has no RestartSteps=/RestartMaxDelaySec= (>= %d): the delay does not\n"
                "# grow. Instead: at most %d starts in %s, each %s after the last exit; then\n"
                "# systemd gives up and %s starts it again %s later.\n",
                systemd_version, kSystemdBackoffVersion, limit.burst,
                seconds(limit.interval_s).c_str(), seconds(p.backoff.initial_s).c_str(),
                retry_unit_name(d, p).c_str(), seconds(p.backoff.max_s).c_str());
  r.unit = text;
  r.unit += "StartLimitIntervalSec=" + seconds(limit.interval_s) + "\n";
  r.unit += "StartLimitBurst=" + std::to_string(limit.burst) + "\n";
  r.unit += "OnFailure=" + retry_unit_name(d, p) + "\n";
  r.retry = true;
  return r;
}

// systemd < 254: the oneshot that starts `p` again max_s after systemd gave up on it.
std::string retry_unit(const Deployment& d, const Host& host, const Process& p,
                       int systemd_version) {
  const std::string service = unit_name(d, p);
  char delay[32];
  std::snprintf(delay, sizeof delay, "%g", p.backoff.max_s);
  std::string u;
  u += "# Written by ips-deploy from the deployment '" + d.name + "', host '" + host.name +
       "', for systemd " + std::to_string(systemd_version) + ". Regenerate rather than edit.\n";
  u += "# systemd < " + std::to_string(kSystemdBackoffVersion) + " only: " + service +
       " names this unit in OnFailure=, which runs once systemd\n# has given up restarting it "
       "(StartLimitBurst=): it starts it again " +
       delay + " s later (max_s), so that it is not\n# left stopped for good.\n";
  u += "[Unit]\n";
  u += "Description=ips-fusion " + d.name + ": " + p.name + " on " + host.name +
       ", started again after its restarts ran out\n";
  u += "PartOf=" + target_name(d) + "\n\n";
  u += "[Service]\n";
  u += "Type=oneshot\n";
  u += "TimeoutStartSec=infinity\n";
  u += std::string("ExecStart=/bin/sleep ") + delay + "\n";
  u += "ExecStart=/bin/systemctl reset-failed " + service + "\n";
  u += "ExecStart=/bin/systemctl start --no-block " + service + "\n";
  return u;
}

}  // namespace

int parse_systemctl_version(const std::string& first_line) {
  const std::string prefix = "systemd ";
  if (first_line.rfind(prefix, 0) != 0) return 0;
  int v = 0;
  size_t i = prefix.size();
  for (; i < first_line.size() && first_line[i] >= '0' && first_line[i] <= '9' && v < 100000; ++i)
    v = v * 10 + (first_line[i] - '0');
  if (i == prefix.size() || (i < first_line.size() && first_line[i] != ' ' && first_line[i] != '\n'))
    return 0;
  return v;
}

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

std::string retry_unit_name(const Deployment& d, const Process& p) {
  return "ips-" + d.name + "-" + p.name + "-retry.service";
}

std::string target_name(const Deployment& d) { return "ips-" + d.name + ".target"; }

StartLimit start_limit(const Backoff& b) {
  const int steps = backoff_steps(b);
  if (steps == 0) return {};
  StartLimit l;
  l.burst = steps + 1;
  double delay = b.initial_s;
  for (int k = 0; k < steps; ++k, delay *= 2) l.interval_s += std::min(delay, b.max_s);
  l.interval_s += b.max_s;
  return l;
}

std::map<std::string, std::string> systemd_units(const Deployment& d, const Host& host,
                                                 const std::map<std::string, std::string>& resolved,
                                                 int systemd_version) {
  std::map<std::string, std::string> files;
  const std::string target = target_name(d);
  const std::string written = "# Written by ips-deploy from the deployment '" + d.name +
                              "', host '" + host.name + "', for systemd " +
                              std::to_string(systemd_version) + ".";
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
    const RestartLines restart = restart_lines(d, p, systemd_version);
    std::string u;
    u += written + " Regenerate rather than edit.\n";
    u += "[Unit]\n";
    u += "Description=ips-fusion " + d.name + ": " + p.name + " on " + host.name + "\n";
    u += "Wants=network-online.target\n";
    u += "After=" + after + "\n";
    u += "PartOf=" + target + "\n";
    u += restart.unit + "\n";
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
    u += restart.service;
    // The programs end cleanly on SIGINT (ips-record flushes its log).
    u += "KillSignal=SIGINT\n";
    u += "TimeoutStopSec=" + seconds(p.stop_timeout_s) + "\n\n";
    u += "[Install]\n";
    u += "WantedBy=" + target + "\n";
    files[unit_name(d, p)] = u;
    if (restart.retry)
      files[retry_unit_name(d, p)] = retry_unit(d, host, p, systemd_version);
  }
  std::string t;
  t += written + "\n";
  t += "[Unit]\n";
  t += "Description=ips-fusion " + d.name + " on " + host.name + "\n";
  t += "Wants=" + wants + "\n\n";
  t += "[Install]\n";
  t += "WantedBy=multi-user.target\n";
  files[target] = t;
  return files;
}

std::vector<std::string> commands_systemd_cannot_find(
    const Host& host, const std::map<std::string, std::string>& resolved,
    const std::function<bool(const std::string&)>& is_program) {
  std::vector<std::string> missing;
  for (const Process& p : host.processes) {
    const std::string& c = resolved.at(p.name);
    bool found = false;
    if (c.find('/') != std::string::npos) {
      found = is_program(c);
    } else {
      const std::string dirs = kSystemdSearchPath;
      for (size_t start = 0; !found && start <= dirs.size();) {
        const size_t colon = std::min(dirs.find(':', start), dirs.size());
        found = is_program(dirs.substr(start, colon - start) + "/" + c);
        start = colon + 1;
      }
    }
    if (!found) missing.push_back(p.name + ": " + c);
  }
  return missing;
}

}  // namespace ips::deploy
