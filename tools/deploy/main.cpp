// ips-deploy: runs a deployment file's processes on the lab machines (docs/deployment.md).
//   ips-deploy check DEPLOY.yaml                          the file's hosts and start order
//   ips-deploy systemd DEPLOY.yaml --host NAME --out DIR  systemd units for one host
//   ips-deploy run DEPLOY.yaml --host NAME                the host's processes, supervised here
//                                                         (and a run file for status, run_file.hpp)
//   ips-deploy status [DEPLOY.yaml]                       every process's HEALTH on the bus
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <tuple>
#include <string>
#include <vector>

#include "core/channels.hpp"
#include "core/cli.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"
#include "core/yaml_fields.hpp"
#include "tools/deploy/deployment.hpp"
#include "tools/deploy/run_file.hpp"
#include "tools/deploy/status.hpp"
#include "tools/deploy/supervisor.hpp"
#include "tools/deploy/systemd_units.hpp"

namespace {

constexpr const char* kProgram = "ips-deploy";
namespace deploy = ips::deploy;

bool is_program(const std::string& path) {
  struct stat st{};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

void print_warning(const std::string& what) {
  std::fprintf(stderr, "%s: warning: %s\n", kProgram, what.c_str());
  std::fflush(stderr);
}

std::string this_hostname() {
  char buf[256] = {0};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

// The systemd version the units are for: --systemd-version, else `systemctl --version`'s, else
// kDefaultSystemdVersion. `how` says which, for the output.
int systemd_version(int flag, std::string& how) {
  if (flag > 0) {
    how = "--systemd-version";
    return flag;
  }
  std::string first;
  if (FILE* p = ::popen("systemctl --version 2>/dev/null", "r")) {
    char buf[256];
    if (std::fgets(buf, sizeof buf, p)) first = buf;
    ::pclose(p);
  }
  if (const int v = deploy::parse_systemctl_version(first); v > 0) {
    how = "from systemctl --version";
    return v;
  }
  how = "the default: systemctl --version gave no version here; --systemd-version N to say";
  return deploy::kDefaultSystemdVersion;
}

// The directory ips-deploy itself is in: the programs built beside it.
std::string own_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

std::string bin_dir_of(const deploy::Deployment& d, const std::string& flag) {
  if (!flag.empty()) return flag;
  if (!d.bin_dir.empty()) return d.bin_dir;
  return own_dir();
}

// The host, or nullptr after one error line naming the hosts there are.
const deploy::Host* find_host(const deploy::Deployment& d, const std::string& name,
                              const std::string& path) {
  const deploy::Host* h = d.host(name);
  if (!h)
    ips::print_fatal(kProgram, "no host '" + ips::printable(name) + "' in " + path +
                                   " (hosts: " + d.host_names() + ")");
  return h;
}

std::map<std::string, std::string> resolve_all(const deploy::Host& h, const std::string& bin_dir) {
  std::map<std::string, std::string> out;
  for (const deploy::Process& p : h.processes)
    out[p.name] = deploy::resolve_command(p.command, bin_dir, is_program);
  return out;
}

// A program on the PATH, as posix_spawnp finds it.
bool on_path(const std::string& name) {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  size_t start = 0;
  for (;;) {
    const size_t colon = dirs.find(':', start);
    const std::string dir = dirs.substr(start, colon == std::string::npos ? colon : colon - start);
    if (is_program((dir.empty() ? "." : dir) + "/" + name)) return true;
    if (colon == std::string::npos) return false;
    start = colon + 1;
  }
}

int check(const std::string& path) {
  const deploy::Deployment d = deploy::load_deployment_file(path);
  std::printf("deployment %s: LCM %s, %zu hosts\n", d.name.c_str(), d.lcm_url.c_str(),
              d.hosts.size());
  for (const deploy::Host& h : d.hosts) {
    std::printf("host %s (hostname %s), in start order:\n", h.name.c_str(), h.hostname.c_str());
    for (const deploy::Process& p : h.processes) {
      std::string line = "  " + p.name + ": " + p.command;
      for (const std::string& a : p.args) line += " " + a;
      line += std::string("  [restart ") + deploy::restart_name(p.restart) + "]";
      std::printf("%s\n", ips::printable(line).c_str());
    }
  }
  return 0;
}

int systemd(const std::string& path, const std::string& host_name, const std::string& out_dir,
            const std::string& bin_flag, bool force, int version_flag, bool allow_missing) {
  const deploy::Deployment d = deploy::load_deployment_file(path);
  const deploy::Host* host = find_host(d, host_name, path);
  if (!host) return 2;
  const std::string bin_dir = bin_dir_of(d, bin_flag);
  const auto resolved = resolve_all(*host, bin_dir);
  // A unit whose program systemd cannot find fails at every start: refused unless asked for.
  const std::vector<std::string> missing =
      deploy::commands_systemd_cannot_find(*host, resolved, is_program);
  if (!missing.empty()) {
    std::string list;
    for (const std::string& m : missing) list += (list.empty() ? "" : ", ") + m;
    const std::string where =
        (std::filesystem::is_directory(bin_dir) ? "not in " + bin_dir
                                                : "no directory " + bin_dir + " here") +
        ", nor in systemd's search path";
    const std::string what = std::to_string(missing.size()) + " of " +
                             std::to_string(host->processes.size()) +
                             " programs not found: " + ips::printable(list) + " (" +
                             ips::printable(where) + ")";
    if (!allow_missing) {
      ips::print_fatal(kProgram, what + "; --bin-dir DIR to say where they are, or "
                                        "--allow-missing to write the units all the same");
      return 2;
    }
    print_warning(what + "; writing the units all the same (--allow-missing)");
  }
  std::string how;
  const int version = systemd_version(version_flag, how);
  const auto files = deploy::systemd_units(d, *host, resolved, version);
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) {
    ips::print_fatal(kProgram, "cannot create '" + out_dir + "': " + ec.message());
    return 1;
  }
  if (!force)
    for (const auto& [name, text] : files)
      if (std::filesystem::exists(std::filesystem::path(out_dir) / name)) {
        ips::print_fatal(kProgram, "'" + (std::filesystem::path(out_dir) / name).string() +
                                       "' exists (--force to overwrite)");
        return 2;
      }
  for (const auto& [name, text] : files) {
    std::string error;
    if (!ips::write_text_file((std::filesystem::path(out_dir) / name).string(), text, error)) {
      ips::print_fatal(kProgram, error);
      return 1;
    }
  }
  std::printf("wrote %zu units for host %s into %s, for systemd %d (%s)\n", files.size(),
              host->name.c_str(), out_dir.c_str(), version, how.c_str());
  for (const auto& [name, text] : files) std::printf("  %s\n", name.c_str());
  std::printf("install: sudo cp %s/*.service %s/%s /etc/systemd/system/ && sudo systemctl "
              "daemon-reload && sudo systemctl enable --now %s\n",
              out_dir.c_str(), out_dir.c_str(), deploy::target_name(d).c_str(),
              deploy::target_name(d).c_str());
  return 0;
}

int run(const ips::CommonOptions& common, const std::string& path, const std::string& host_name,
        const std::string& bin_flag, const std::string& working_dir_flag) {
  deploy::Deployment d = deploy::load_deployment_file(path);
  const deploy::Host* host = find_host(d, host_name, path);
  if (!host) return 2;
  const auto resolved = resolve_all(*host, bin_dir_of(d, bin_flag));
  if (!working_dir_flag.empty()) {
    std::error_code ec;
    const auto dir = std::filesystem::absolute(working_dir_flag, ec);
    if (ec || !std::filesystem::is_directory(dir)) {
      ips::print_fatal(kProgram, "--working-dir '" + ips::printable(working_dir_flag) +
                                     "': not a directory");
      return 2;
    }
    d.working_dir = dir.lexically_normal().string();
  } else if (!d.working_dir.empty() && !std::filesystem::is_directory(d.working_dir)) {
    ips::print_fatal(kProgram, path + ": working_dir '" + ips::printable(d.working_dir) +
                                   "' is not a directory on this machine: create it, or give "
                                   "--working-dir DIR to run the processes in DIR instead");
    return 2;
  }
  // Every program must be there before anything starts.
  for (const deploy::Process& p : host->processes) {
    const std::string& c = resolved.at(p.name);
    if (c.find('/') != std::string::npos ? !is_program(c) : !on_path(c)) {
      ips::print_fatal(kProgram, "process '" + p.name + "': no program '" + ips::printable(c) +
                                     "' (looked in " + bin_dir_of(d, bin_flag) +
                                     " and on the PATH; --bin-dir or bin_dir: to say where)");
      return 2;
    }
  }
  // Said once everything is known to start: status matches this run's processes by pid all the
  // same (the run file below).
  const std::string hostname = this_hostname();
  if (hostname != host->hostname)
    print_warning("this machine's hostname is '" + ips::printable(hostname) + "', not '" +
                  ips::printable(host->hostname) + "' (host " + host->name + "'s in " + path +
                  "); HEALTH will say '" + ips::printable(hostname) + "'");
  // ips-deploy's own HEALTH goes on the deployment's bus, beside its processes'.
  ips::CommonOptions opts = common;
  if (opts.lcm_url.empty()) opts.lcm_url = d.lcm_url;
  ips::Node node(kProgram, opts);
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  deploy::Supervisor sup(node, d, *host, resolved, [](const std::string& line) {
    std::fwrite(line.data(), 1, line.size(), stdout);
    std::fputc('\n', stdout);
  });
  std::printf("[ips-deploy] deployment %s, host %s: %zu processes, LCM %s\n", d.name.c_str(),
              host->name.c_str(), host->processes.size(), d.lcm_url.c_str());
  // The run file: which pid is which process, for ips-deploy status on this machine.
  deploy::RunRecord record{d.name, host->name, hostname, static_cast<int32_t>(::getpid()), {}};
  const std::string run_dir = deploy::run_file_dir();
  std::string run_path;
  bool run_file_failed = false;
  sup.on_pids_changed([&] {
    record.pids = sup.pids();
    std::string error;
    if (!deploy::write_run_file(run_dir, record, run_path, error) && !run_file_failed) {
      run_file_failed = true;
      print_warning("no run file (" + error + "): ips-deploy status matches this run's "
                    "processes by hostname only");
    }
  });
  sup.start();
  node.add_timer(0.2, [&] {
    if (sup.finished()) node.stop();
  });
  const int rc = node.run();
  sup.stop();
  if (!run_path.empty()) std::filesystem::remove(run_path);
  if (node.stop_signal() != 0) return rc;
  std::printf("[ips-deploy] every process has ended\n");
  return rc != 0 ? rc : sup.any_failed() ? 1 : 0;
}

int status(const ips::CommonOptions& common, const std::string& path, double wait_s, bool json) {
  std::optional<deploy::Deployment> d;
  ips::CommonOptions opts = common;
  if (!path.empty()) {
    d = deploy::load_deployment_file(path);
    if (opts.lcm_url.empty() && std::getenv("LCM_DEFAULT_URL") == nullptr) opts.lcm_url = d->lcm_url;
  }
  ips::Node node(kProgram, opts);
  std::map<std::tuple<std::string, std::string, int32_t>, deploy::Heard> heard;
  node.subscribe<ips::health_t>(opts.channel(ips::channel::kHealth),
                                [&](const ips::health_t& h, const std::string&) {
                                  // Not our own.
                                  if (h.source == kProgram && h.pid == ::getpid()) return;
                                  heard[{h.host, h.source, h.pid}] = {h, ips::wall_utime_now()};
                                });
  node.add_timer(wait_s, [&] { node.stop(); });
  const int rc = node.run();
  if (rc != 0 || node.stop_signal() != 0) return rc;
  std::vector<deploy::Heard> list;
  for (const auto& [k, h] : heard) list.push_back(h);
  // The runs of this deployment on this machine (`ips-deploy run` keeps a run file).
  std::vector<deploy::RunRecord> runs;
  if (d) {
    int unreadable = 0;
    std::vector<std::string> errors;
    runs = deploy::read_run_files(deploy::run_file_dir(), d->name, unreadable, errors);
    if (unreadable > 0)
      print_warning(std::to_string(unreadable) + " run files could not be read and were left out "
                    "(first: " + errors.front() + ")");
  }
  const deploy::StatusReport report =
      deploy::compare_status(d ? &*d : nullptr, list, ips::wall_utime_now(), runs);
  const std::string text = json ? deploy::status_json(report) + "\n" : deploy::format_status(report);
  std::fwrite(text.data(), 1, text.size(), stdout);
  return report.ok() ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"ips-deploy: the lab's processes from a deployment file (hosts, programs, "
               "arguments, restart policy): systemd units for production, a foreground "
               "supervisor for development, and the status of every process from HEALTH.",
               kProgram};
  ips::CommonOptions opts;
  ips::add_common_options(app, opts, {.lcm = true, .site = false, .channels = true});
  app.require_subcommand(1);
  std::string path, host, out_dir, bin_dir, working_dir;
  bool force = false, json = false, allow_missing = false;
  int systemd_version_flag = 0;
  double wait_s = 3.0;

  CLI::App* check_cmd = app.add_subcommand("check", "validate a deployment file and print its "
                                                    "hosts and processes in start order");
  check_cmd->add_option("DEPLOY", path, "deployment file (YAML)")->required();

  CLI::App* systemd_cmd = app.add_subcommand(
      "systemd", "write the systemd units of one host: ips-<name>-<process>.service and "
                 "ips-<name>.target");
  systemd_cmd->add_option("DEPLOY", path, "deployment file (YAML)")->required();
  systemd_cmd->add_option("--host", host, "the host to write units for")->required();
  systemd_cmd->add_option("--out", out_dir, "directory to write them into")->required();
  systemd_cmd->add_option("--bin-dir", bin_dir,
                          "where the programs are installed (default: the file's bin_dir, "
                          "else ips-deploy's own directory)");
  systemd_cmd->add_flag("--force", force, "overwrite existing unit files");
  systemd_cmd->add_option("--systemd-version", systemd_version_flag,
                          "the systemd version the units are for (default: systemctl --version "
                          "here, else 252): below 254 there is no RestartSteps=/"
                          "RestartMaxDelaySec=, and the back-off is a start limit plus a retry "
                          "unit instead")
      ->check(CLI::Range(230, 9999));
  systemd_cmd->add_flag("--allow-missing", allow_missing,
                        "write the units even when a program is neither in the bin directory "
                        "nor in systemd's search path here (it is refused otherwise)");

  CLI::App* run_cmd = app.add_subcommand(
      "run", "run one host's processes in the foreground, restarting those that exit (with "
             "back-off); Ctrl-C or SIGTERM stops them all");
  run_cmd->add_option("DEPLOY", path, "deployment file (YAML)")->required();
  run_cmd->add_option("--host", host, "the host whose processes to run")->required();
  run_cmd->add_option("--bin-dir", bin_dir,
                      "where the programs are (default: the file's bin_dir, else ips-deploy's "
                      "own directory, then the PATH)");
  run_cmd->add_option("--working-dir", working_dir,
                      "run the processes in this directory instead of the file's working_dir "
                      "(to try a deployment on a machine without it)");

  CLI::App* status_cmd = app.add_subcommand(
      "status", "listen to HEALTH and list every process per host; with DEPLOY, also what is "
                "missing. Exit status 0 when every expected process is heard and none is in "
                "error, else 1");
  status_cmd->add_option("DEPLOY", path, "deployment file (YAML)");
  status_cmd->add_option("--wait", wait_s, "seconds to listen (HEALTH is sent once a second)")
      ->check(CLI::Range(1.0, 600.0))
      ->capture_default_str();
  status_cmd->add_flag("--json", json, "print JSON");
  for (CLI::App* sub : {check_cmd, systemd_cmd, run_cmd, status_cmd}) sub->fallthrough();

  int rc = 0;
  if (!ips::parse_command_line(app, opts, argc, argv, rc)) return rc;
  return ips::run_reporting_errors(kProgram, [&]() -> int {
    if (*check_cmd) return check(path);
    if (*systemd_cmd)
      return systemd(path, host, out_dir, bin_dir, force, systemd_version_flag, allow_missing);
    if (*run_cmd) return run(opts, path, host, bin_dir, working_dir);
    return status(opts, path, wait_s, json);
  });
}
