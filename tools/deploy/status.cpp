#include "tools/deploy/status.hpp"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>

#include "core/health_state.hpp"
#include "core/text_escape.hpp"

namespace ips::deploy {

namespace {

std::string base_name(const std::string& path) {
  const size_t slash = path.rfind('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

StatusRow row_of(const std::string& host, const std::string& process, const Heard& h,
                 utime_t now) {
  StatusRow r;
  r.host = host;
  r.process = process;
  r.program = h.health.source;
  r.pid = h.health.pid;
  r.state = health_state_name(h.health.state);
  r.age_s = utime_to_s(now) - utime_to_s(h.host_utime);
  r.uptime_s = utime_to_s(h.health.uptime_us);
  r.msgs_in = h.health.msgs_in;
  r.msgs_out = h.health.msgs_out;
  r.drops = h.health.drops;
  r.kernel_drops = h.health.kernel_drops;
  r.queue_drops = h.health.queue_drops;
  r.seq_lost = h.health.seq_lost;
  r.last_error = h.health.last_error;
  return r;
}

std::string fixed(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

}  // namespace

StatusReport compare_status(const Deployment* d, const std::vector<Heard>& heard, utime_t now,
                            const std::vector<RunRecord>& runs, double stale_s) {
  // Live processes only, newest first.
  std::vector<const Heard*> live;
  for (const Heard& h : heard)
    if (utime_to_s(now) - utime_to_s(h.host_utime) <= stale_s) live.push_back(&h);
  std::sort(live.begin(), live.end(),
            [](const Heard* a, const Heard* b) { return a->host_utime > b->host_utime; });
  std::set<const Heard*> used;
  StatusReport report;
  if (d) {
    // The runs of each host on this machine.
    std::map<std::string, std::vector<const RunRecord*>> runs_of;
    for (const RunRecord& r : runs)
      if (r.deployment == d->name && d->host(r.host)) runs_of[r.host].push_back(&r);
    const auto heard_from = [&](const std::string& hostname, int32_t pid) -> const Heard* {
      for (const Heard* h : live)
        if (!used.count(h) && h->health.host == hostname && h->health.pid == pid) return h;
      return nullptr;
    };
    // Pass 1, every host: the pids the runs gave their processes.
    std::map<const Process*, const Heard*> match;
    for (const Host& host : d->hosts)
      for (const RunRecord* r : runs_of[host.name])
        for (const Process& p : host.processes) {
          const auto pid = r->pids.find(p.name);
          if (match.count(&p) || pid == r->pids.end() || pid->second <= 0) continue;
          if (const Heard* h = heard_from(r->hostname, pid->second)) {
            match[&p] = h;
            used.insert(h);
          }
        }
    for (const Host& host : d->hosts) {
      std::set<std::string> hostnames = {host.hostname};
      std::set<std::pair<std::string, int32_t>> run_pids;  // (hostname, pid) of its runs
      for (const RunRecord* r : runs_of[host.name]) {
        hostnames.insert(r->hostname);
        run_pids.insert({r->hostname, r->supervisor_pid});
        for (const auto& [name, pid] : r->pids) run_pids.insert({r->hostname, pid});
        report.notes.push_back(
            "host " + host.name + ": run on this machine by ips-deploy (pid " +
            std::to_string(r->supervisor_pid) + ") under hostname '" + printable(r->hostname) +
            "'" +
            (r->hostname == host.hostname ? ""
                                          : " (the file says '" + printable(host.hostname) + "')") +
            "; its processes matched by pid");
      }
      for (const Process& p : host.processes) {
        const std::string program = base_name(p.command);
        const bool on_bus = program.rfind("ips-", 0) == 0;
        // A row for a process of the file with no HEALTH to show.
        const auto unheard = [&](const char* state) {
          StatusRow r;
          r.host = host.name;
          r.process = p.name;
          r.program = program;
          r.state = state;
          report.rows.push_back(r);
        };
        if (!on_bus && !match.count(&p)) {
          unheard("no HEALTH");
          continue;
        }
        ++report.expected;
        // Pass 2: by hostname and program.
        if (!match.count(&p))
          for (const Heard* h : live)
            if (!used.count(h) && hostnames.count(h->health.host) && h->health.source == program) {
              match[&p] = h;
              used.insert(h);
              break;
            }
        if (!match.count(&p)) {
          unheard("MISSING");
          ++report.missing;
          continue;
        }
        const Heard* m = match[&p];
        if (m->health.state == health_t::STATE_ERROR) ++report.in_error;
        report.rows.push_back(row_of(host.name, p.name, *m, now));
      }
      // Others heard on this host (ips-deploy itself, a tool run by hand).
      std::vector<const Heard*> extra;
      for (const Heard* h : live)
        if (!used.count(h) && (h->health.host == host.hostname ||
                               run_pids.count({h->health.host, h->health.pid})))
          extra.push_back(h);
      std::sort(extra.begin(), extra.end(), [](const Heard* a, const Heard* b) {
        return std::tie(a->health.source, a->health.pid) < std::tie(b->health.source, b->health.pid);
      });
      for (const Heard* h : extra) {
        used.insert(h);
        report.rows.push_back(row_of(host.name, "", *h, now));
      }
    }
  }
  // Hosts the deployment does not name (or every host, without one).
  std::vector<const Heard*> rest;
  for (const Heard* h : live)
    if (!used.count(h)) rest.push_back(h);
  std::sort(rest.begin(), rest.end(), [](const Heard* a, const Heard* b) {
    return std::tie(a->health.host, a->health.source, a->health.pid) <
           std::tie(b->health.host, b->health.source, b->health.pid);
  });
  for (const Heard* h : rest) report.rows.push_back(row_of(h->health.host, "", *h, now));
  return report;
}

std::string format_status(const StatusReport& r) {
  std::string s;
  char line[512];
  std::string host;
  for (const StatusRow& row : r.rows) {
    if (row.host != host || s.empty()) {
      host = row.host;
      s += (s.empty() ? "" : "\n") + ("host " + printable(host)) + "\n";
      std::snprintf(line, sizeof line,
                    "  %-16s %-22s %8s %-10s %9s %7s %10s %10s %7s %8s %8s  %s\n", "process",
                    "program", "pid", "state", "uptime s", "age s", "in", "out", "drops",
                    "bus lost", "seq lost", "last error");
      s += line;
    }
    const bool heard = row.pid != 0;
    std::snprintf(line, sizeof line, "  %-16s %-22s %8s %-10s %9s %7s %10s %10s %7s %8s %8s  %s\n",
                  row.process.empty() ? "-" : row.process.c_str(),
                  printable(row.program).substr(0, 22).c_str(),
                  heard ? std::to_string(row.pid).c_str() : "-", row.state.c_str(),
                  heard ? fixed(row.uptime_s, 0).c_str() : "-",
                  heard ? fixed(row.age_s, 1).c_str() : "-",
                  heard ? std::to_string(row.msgs_in).c_str() : "-",
                  heard ? std::to_string(row.msgs_out).c_str() : "-",
                  heard ? std::to_string(row.drops).c_str() : "-",
                  heard ? std::to_string(row.kernel_drops + row.queue_drops).c_str() : "-",
                  heard ? std::to_string(row.seq_lost).c_str() : "-",
                  printable(row.last_error).substr(0, 160).c_str());
    s += line;
  }
  if (r.rows.empty()) s += "no HEALTH heard\n";
  if (!r.notes.empty()) s += "\n";
  for (const std::string& note : r.notes) s += note + "\n";
  s += "\n" + std::to_string(r.expected - r.missing) + " of " + std::to_string(r.expected) +
       " expected processes heard" +
       (r.in_error ? ", " + std::to_string(r.in_error) + " in error" : "") + "\n";
  return s;
}

std::string status_json(const StatusReport& r) {
  std::string s = "{\"ok\":";
  s += r.ok() ? "true" : "false";
  s += ",\"expected\":" + std::to_string(r.expected) + ",\"missing\":" + std::to_string(r.missing) +
       ",\"in_error\":" + std::to_string(r.in_error) + ",\"processes\":[";
  for (size_t i = 0; i < r.rows.size(); ++i) {
    const StatusRow& row = r.rows[i];
    s += (i ? ",{" : "{");
    s += "\"host\":" + json_quote(row.host) + ",\"process\":" + json_quote(row.process) +
         ",\"program\":" + json_quote(row.program) + ",\"pid\":" + std::to_string(row.pid) +
         ",\"state\":" + json_quote(row.state) + ",\"age_s\":" + fixed(row.age_s, 3) +
         ",\"uptime_s\":" + fixed(row.uptime_s, 3) + ",\"msgs_in\":" +
         std::to_string(row.msgs_in) + ",\"msgs_out\":" + std::to_string(row.msgs_out) +
         ",\"drops\":" + std::to_string(row.drops) +
         ",\"kernel_drops\":" + std::to_string(row.kernel_drops) +
         ",\"queue_drops\":" + std::to_string(row.queue_drops) +
         ",\"seq_lost\":" + std::to_string(row.seq_lost) + ",\"last_error\":" +
         json_quote(row.last_error) + "}";
  }
  s += "],\"notes\":[";
  for (size_t i = 0; i < r.notes.size(); ++i) s += (i ? "," : "") + json_quote(r.notes[i]);
  return s + "]}";
}

}  // namespace ips::deploy
