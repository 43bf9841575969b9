#pragma once
// ips-deploy status: the HEALTH heard on the bus, per host, against what a deployment file says
// should run there. Pure: HEALTH messages with their arrival times in, rows and a verdict out.
#include <ips/health_t.hpp>

#include <string>
#include <vector>

#include "core/time.hpp"
#include "tools/deploy/deployment.hpp"
#include "tools/deploy/run_file.hpp"

namespace ips::deploy {

struct Heard {
  health_t health{};
  utime_t host_utime = 0;  // when its latest HEALTH arrived
};

struct StatusRow {
  std::string host;     // the deployment's host name, or the hostname HEALTH gave
  std::string process;  // the deployment's process name; empty for a process it does not list
  std::string program;  // HEALTH source, or the command's file name
  int32_t pid = 0;      // 0: none heard
  // "ok", "degraded", "error", "starting" (from HEALTH), "MISSING" (an ips-* process with no
  // HEALTH), "no HEALTH" (a program that does not publish it, e.g. lcm-logger).
  std::string state;
  double age_s = 0;  // since its last HEALTH
  double uptime_s = 0;
  int64_t msgs_in = 0, msgs_out = 0, drops = 0;
  // Lost on the way in (HEALTH kernel_drops + queue_drops) and missing by sequence numbers.
  int64_t kernel_drops = 0, queue_drops = 0, seq_lost = 0;
  std::string last_error;
};

struct StatusReport {
  std::vector<StatusRow> rows;  // by host (the deployment's order, then others), then start order
  int expected = 0;             // processes of the deployment that publish HEALTH
  int missing = 0;
  int in_error = 0;
  // How hosts were matched other than by hostname (a run of ips-deploy on this machine).
  std::vector<std::string> notes;
  bool ok() const { return missing == 0 && in_error == 0; }
};

// The HEALTH of every process heard (latest per host, source and pid), matched with the
// deployment's processes (nullptr: just list what was heard). A HEALTH more than stale_s older
// than `now` is a process that has gone (it restarted under a new pid, or stopped).
// Matching: first by pid, for the hosts that `runs` (the run files of `ips-deploy run` on this
// machine) say run here: the HEALTH from the run's hostname with the pid the run gave a process
// is that process's, whatever the file's `hostname`; then by hostname (the file's, or a run's)
// and program name. ips-deploy itself and other programs heard under a run's pids or on a host's
// hostname are listed under that host.
StatusReport compare_status(const Deployment* d, const std::vector<Heard>& heard, utime_t now,
                            const std::vector<RunRecord>& runs = {}, double stale_s = 2.5);

// A text table, one host after another; every string from the bus made printable.
std::string format_status(const StatusReport& r);
std::string status_json(const StatusReport& r);

}  // namespace ips::deploy
