#pragma once
// A deployment file (docs/deployment.md): which processes run on which lab machine, with their
// arguments, environment, restart policy and start order, and the LCM URL they share. Parsed and
// checked here; systemd_units.hpp turns a host's part into unit files, supervisor.hpp runs it,
// status.hpp compares it with the HEALTH on the bus.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/yaml_fields.hpp"

namespace ips::deploy {

enum class Restart { kNo, kOnFailure, kAlways };
const char* restart_name(Restart r);  // "no", "on-failure", "always" (systemd's spelling)

struct Backoff {
  double initial_s = 1.0;       // the first restart's delay
  double max_s = 30.0;          // doubling stops here
  double reset_after_s = 60.0;  // a process that ran this long starts again from initial_s
};

struct Process {
  std::string name;     // unique in the deployment
  std::string command;  // as written; resolved against bin_dir when it has no '/'
  std::vector<std::string> args;
  Restart restart = Restart::kOnFailure;
  std::vector<std::string> after;  // processes of the same host started first
  std::map<std::string, std::string> environment;
  Backoff backoff;
  double stop_timeout_s = 5.0;
};

struct Host {
  std::string name;
  std::string hostname;  // as HEALTH reports it (default: name)
  std::vector<Process> processes;  // in start order (after: first, else file order)
};

struct Deployment {
  std::string name;
  std::string lcm_url;
  std::string bin_dir;  // empty: the caller's default
  std::string user;
  std::string working_dir;
  std::map<std::string, std::string> environment;
  std::vector<Host> hosts;

  // nullptr when there is no such host.
  const Host* host(const std::string& name) const;
  // The host names, comma-separated, for error messages.
  std::string host_names() const;
};

// A `sharded:` entry (a process with `shards: N` and `hosts: [...]`) becomes N processes
// <name>-1 .. <name>-N with `--shard k/N` added to their args, on those hosts round robin, each
// after the host's own processes.
// Throws ConfigError "file:line: field: reason" on anything wrong: unknown keys, bad names,
// duplicate names, `after` naming a process that is not on the same host, a cycle of `after`,
// bounds, an lcm_url that is not an LCM URL.
Deployment parse_deployment(const YamlField& root);
Deployment load_deployment_file(const std::string& path);

// The command's path: as written when it holds a '/'; else bin_dir/command when that is a
// program (`is_program`); else the bare name, which the PATH (ips-deploy run) or systemd's
// search path resolves (lcm-logger, say).
std::string resolve_command(const std::string& command, const std::string& bin_dir,
                            const std::function<bool(const std::string&)>& is_program);

// The environment a process runs with, on top of the inherited one: the deployment's, the
// process's (which wins), and LCM_DEFAULT_URL from lcm_url.
std::map<std::string, std::string> process_environment(const Deployment& d, const Process& p);

}  // namespace ips::deploy
