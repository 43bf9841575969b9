#include "tools/deploy/deployment.hpp"

#include <algorithm>
#include <functional>
#include <set>

#include "core/tag_selector.hpp"

namespace ips::deploy {

namespace {

constexpr size_t kMaxHosts = 64;
constexpr size_t kMaxProcesses = 256;
constexpr size_t kMaxArgs = 256;

// [a-z0-9-], 1..max characters, not starting with '-'.
bool valid_name(const std::string& s, size_t max) {
  if (s.empty() || s.size() > max || s.front() == '-') return false;
  return std::all_of(s.begin(), s.end(),
                     [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-'; });
}

// Environment names as POSIX shells take them; values without control characters (they go
// into unit files and execve).
bool valid_env_name(const std::string& s) {
  if (s.empty() || s.size() > 128 || (s[0] >= '0' && s[0] <= '9')) return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  });
}

bool has_control(const std::string& s) {
  return std::any_of(s.begin(), s.end(),
                     [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
}

std::string text_field(const YamlField& f, size_t max_bytes) {
  const std::string s = f.as_string();
  if (s.size() > max_bytes) f.fail("longer than " + std::to_string(max_bytes) + " bytes");
  if (has_control(s)) f.fail("must not contain control characters (newlines, tabs, ...)");
  return s;
}

std::map<std::string, std::string> parse_environment(const YamlField& f) {
  std::map<std::string, std::string> env;
  if (!f.defined()) return env;
  if (!f.is_map()) f.fail("expected a map of NAME: value");
  for (const auto& kv : f.node()) {
    if (!kv.first.IsScalar()) f.fail("a name must be text, not a list or a map");
    const std::string key = kv.first.as<std::string>();
    const YamlField value = f[key];
    if (!valid_env_name(key)) value.fail("not a valid environment variable name");
    if (key == "LCM_DEFAULT_URL") value.fail("is set from lcm_url; set lcm_url instead");
    env[key] = text_field(value, 4096);
  }
  return env;
}

Backoff parse_backoff(const YamlField& f, const Backoff& fallback) {
  if (!f.defined()) return fallback;
  f.check_keys({"initial_s", "max_s", "reset_after_s"});
  Backoff b;
  b.initial_s = f.get_double_in("initial_s", fallback.initial_s, 0.1, 3600);
  b.max_s = f.get_double_in("max_s", std::max(fallback.max_s, b.initial_s), b.initial_s, 86400);
  b.reset_after_s = f.get_double_in("reset_after_s", fallback.reset_after_s, 1, 86400);
  return b;
}

Restart parse_restart(const YamlField& f) {
  if (!f.defined()) return Restart::kOnFailure;
  const std::string s = f.as_string();
  if (s == "no") return Restart::kNo;
  if (s == "on-failure") return Restart::kOnFailure;
  if (s == "always") return Restart::kAlways;
  f.fail("must be no, on-failure or always");
}

std::vector<std::string> string_list(const YamlField& f, size_t max_items) {
  std::vector<std::string> out;
  if (!f.defined()) return out;
  if (!f.is_sequence()) f.fail("expected a list of strings");
  if (f.size() > max_items) f.fail("more than " + std::to_string(max_items) + " items");
  for (size_t i = 0; i < f.size(); ++i) out.push_back(text_field(f[i], 4096));
  return out;
}

// Orders a host's processes so that each comes after those it names in `after` (file order
// otherwise); fails on a cycle.
std::vector<Process> start_order(std::vector<Process> procs, const YamlField& where) {
  std::vector<Process> ordered;
  std::set<std::string> placed;
  while (ordered.size() < procs.size()) {
    bool progress = false;
    for (const Process& p : procs) {
      if (placed.count(p.name)) continue;
      if (std::all_of(p.after.begin(), p.after.end(),
                      [&](const std::string& a) { return placed.count(a) > 0; })) {
        ordered.push_back(p);
        placed.insert(p.name);
        progress = true;
      }
    }
    if (!progress) {
      std::string stuck;
      for (const Process& p : procs)
        if (!placed.count(p.name)) stuck += (stuck.empty() ? "" : ", ") + p.name;
      where.fail("`after` goes round in a circle among: " + stuck);
    }
  }
  return ordered;
}

}  // namespace

const char* restart_name(Restart r) {
  switch (r) {
    case Restart::kNo:
      return "no";
    case Restart::kOnFailure:
      return "on-failure";
    case Restart::kAlways:
      return "always";
  }
  return "?";
}

const Host* Deployment::host(const std::string& n) const {
  for (const Host& h : hosts)
    if (h.name == n) return &h;
  return nullptr;
}

std::string Deployment::host_names() const {
  std::string s;
  for (const Host& h : hosts) s += (s.empty() ? "" : ", ") + h.name;
  return s;
}

namespace {

// One process entry of a host's `processes` or of `sharded` (whose two extra keys the caller
// reads); its name is checked against, and added to, `names`.
Process parse_process(const YamlField& f, const Backoff& backoff, double stop_timeout,
                      std::set<std::string>& names, bool sharded) {
  if (sharded) {
    f.check_keys({"name", "command", "args", "restart", "after", "environment", "restart_backoff",
                  "stop_timeout_s", "shards", "hosts"});
  } else {
    f.check_keys({"name", "command", "args", "restart", "after", "environment", "restart_backoff",
                  "stop_timeout_s"});
  }
  Process p;
  p.name = f.required("name").as_string();
  if (!valid_name(p.name, 32)) f["name"].fail("must be 1 to 32 of a-z, 0-9 and '-'");
  if (!sharded && !names.insert(p.name).second)
    f["name"].fail("duplicate process '" + p.name + "' (names are unique in the deployment)");
  p.command = text_field(f.required("command"), 4096);
  if (p.command.empty() || p.command.find(' ') != std::string::npos)
    f["command"].fail("one program (a name or a path, no spaces): put its arguments in args");
  p.args = string_list(f["args"], kMaxArgs);
  p.restart = parse_restart(f["restart"]);
  p.after = string_list(f["after"], kMaxProcesses);
  p.environment = parse_environment(f["environment"]);
  p.backoff = parse_backoff(f["restart_backoff"], backoff);
  p.stop_timeout_s = f.get_double_in("stop_timeout_s", stop_timeout, 0.1, 600);
  return p;
}

// A host's processes as parsed, each with its entry (for errors), before they are ordered.
struct HostEntries {
  std::vector<Process> list;
  std::vector<YamlField> where;
};

}  // namespace

Deployment parse_deployment(const YamlField& root) {
  if (!root.is_map()) root.fail("expected a map (name, lcm_url, hosts, ...)");
  root.check_keys({"name", "lcm_url", "bin_dir", "user", "working_dir", "environment", "restart",
                   "stop_timeout_s", "hosts", "sharded"});
  Deployment d;
  d.name = root.required("name").as_string();
  if (!valid_name(d.name, 32)) root["name"].fail("must be 1 to 32 of a-z, 0-9 and '-'");
  d.lcm_url = text_field(root.required("lcm_url"), 1024);
  if (d.lcm_url.find("://") == std::string::npos)
    root["lcm_url"].fail("expected an LCM URL such as udpm://239.255.76.67:7667?ttl=1");
  if (root["bin_dir"].defined()) d.bin_dir = text_field(root["bin_dir"], 4096);
  if (root["user"].defined()) {
    d.user = text_field(root["user"], 64);
    if (d.user.empty() || d.user.find_first_of(" :/") != std::string::npos)
      root["user"].fail("not a user name");
  }
  if (root["working_dir"].defined()) {
    d.working_dir = text_field(root["working_dir"], 4096);
    if (d.working_dir.empty() || d.working_dir[0] != '/') root["working_dir"].fail("must be absolute");
  }
  d.environment = parse_environment(root["environment"]);
  const Backoff backoff = parse_backoff(root["restart"], Backoff{});
  const double stop_timeout = root.get_double_in("stop_timeout_s", 5.0, 0.1, 600);

  const YamlField hosts = root.required("hosts");
  if (!hosts.is_sequence() || hosts.size() == 0) hosts.fail("expected a list of at least one host");
  if (hosts.size() > kMaxHosts) hosts.fail("more than " + std::to_string(kMaxHosts) + " hosts");
  const YamlField sharded = root["sharded"];
  if (sharded.defined() && !sharded.is_sequence())
    sharded.fail("expected a list of processes, each with shards: and hosts:");
  std::set<std::string> host_names, process_names;
  std::vector<HostEntries> entries;
  size_t total = 0;
  for (size_t i = 0; i < hosts.size(); ++i) {
    const YamlField h = hosts[i];
    h.check_keys({"name", "hostname", "processes"});
    Host host;
    host.name = h.required("name").as_string();
    if (!valid_name(host.name, 63)) h["name"].fail("must be 1 to 63 of a-z, 0-9 and '-'");
    if (!host_names.insert(host.name).second) h["name"].fail("duplicate host '" + host.name + "'");
    host.hostname = h["hostname"].defined() ? text_field(h["hostname"], 255) : host.name;
    if (host.hostname.empty()) h["hostname"].fail("must not be empty");
    // A host may have only shards (sharded: below); otherwise it needs processes.
    const YamlField procs = h["processes"];
    if (procs.defined() && (!procs.is_sequence() || procs.size() == 0))
      procs.fail("expected a list of at least one process");
    HostEntries e;
    for (size_t j = 0; procs.defined() && j < procs.size(); ++j) {
      e.list.push_back(parse_process(procs[j], backoff, stop_timeout, process_names, false));
      e.where.push_back(procs[j]);
      if (++total > kMaxProcesses)
        procs[j].fail("more than " + std::to_string(kMaxProcesses) + " processes");
    }
    d.hosts.push_back(std::move(host));
    entries.push_back(std::move(e));
  }
  // A sharded process: `shards: N` instances, instance k named <name>-<k> with --shard k/N added
  // to its args, on the hosts listed, round robin (instance k on hosts[(k - 1) mod len]).
  for (size_t i = 0; sharded.defined() && i < sharded.size(); ++i) {
    const YamlField f = sharded[i];
    if (!f.is_map()) f.fail("expected a process with shards: and hosts:");
    const Process base = parse_process(f, backoff, stop_timeout, process_names, true);
    const int64_t shards = f.required("shards").as_int();
    if (shards < 1 || shards > kMaxShards)
      f["shards"].fail("must be in [1, " + std::to_string(kMaxShards) + "]");
    const std::vector<std::string> on = string_list(f.required("hosts"), kMaxHosts);
    if (on.empty()) f["hosts"].fail("expected a list of at least one host");
    for (const std::string& a : base.args)
      if (a == "--shard" || a.rfind("--shard=", 0) == 0)
        f["args"].fail("--shard is set by shards: (instance k of N gets --shard k/N)");
    std::vector<size_t> host_index;
    for (size_t j = 0; j < on.size(); ++j) {
      const auto it = std::find_if(d.hosts.begin(), d.hosts.end(),
                                   [&](const Host& h) { return h.name == on[j]; });
      if (it == d.hosts.end())
        f["hosts"][j].fail("no host '" + on[j] + "' (hosts: " + d.host_names() + ")");
      host_index.push_back(static_cast<size_t>(it - d.hosts.begin()));
    }
    for (int64_t k = 1; k <= shards; ++k) {
      Process p = base;
      p.name = base.name + "-" + std::to_string(k);
      if (!valid_name(p.name, 32))
        f["name"].fail("'" + p.name + "', the name of shard " + std::to_string(k) +
                       ", is longer than 32 characters");
      if (!process_names.insert(p.name).second)
        f["name"].fail("shard " + std::to_string(k) + " would be named '" + p.name +
                       "', which another process has (names are unique in the deployment)");
      p.args.push_back("--shard");
      p.args.push_back(std::to_string(k) + "/" + std::to_string(shards));
      HostEntries& e = entries[host_index[static_cast<size_t>(k - 1) % host_index.size()]];
      e.list.push_back(std::move(p));
      e.where.push_back(f);
      if (++total > kMaxProcesses)
        f["shards"].fail("more than " + std::to_string(kMaxProcesses) + " processes in all");
    }
  }
  for (size_t i = 0; i < d.hosts.size(); ++i) {
    HostEntries& e = entries[i];
    if (e.list.empty())
      hosts[i].fail("host '" + d.hosts[i].name + "' has no processes (and no shards)");
    for (size_t j = 0; j < e.list.size(); ++j)
      for (const std::string& a : e.list[j].after) {
        const bool here = std::any_of(e.list.begin(), e.list.end(),
                                      [&](const Process& p) { return p.name == a; });
        if (!here)
          e.where[j]["after"].fail("no process '" + a + "' on host '" + d.hosts[i].name + "'");
        if (a == e.list[j].name) e.where[j]["after"].fail("a process cannot start after itself");
      }
    const YamlField where = hosts[i]["processes"].defined() ? hosts[i]["processes"] : hosts[i];
    d.hosts[i].processes = start_order(std::move(e.list), where);
  }
  return d;
}

Deployment load_deployment_file(const std::string& path) {
  return parse_deployment(load_yaml_file(path));
}

std::string resolve_command(const std::string& command, const std::string& bin_dir,
                            const std::function<bool(const std::string&)>& is_program) {
  if (command.find('/') != std::string::npos || bin_dir.empty()) return command;
  const std::string path = bin_dir.back() == '/' ? bin_dir + command : bin_dir + "/" + command;
  return is_program(path) ? path : command;
}

std::map<std::string, std::string> process_environment(const Deployment& d, const Process& p) {
  std::map<std::string, std::string> env = d.environment;
  for (const auto& [k, v] : p.environment) env[k] = v;
  env["LCM_DEFAULT_URL"] = d.lcm_url;
  return env;
}

}  // namespace ips::deploy
