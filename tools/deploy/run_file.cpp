#include "tools/deploy/run_file.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/text_escape.hpp"
#include "core/yaml_fields.hpp"

namespace ips::deploy {

namespace {

constexpr const char* kMagic = "ips-deploy-run 1";
constexpr size_t kMaxRunFileBytes = 64 * 1024;

// A pid as written in a run file: 0 .. 2^31-1.
bool parse_pid(const std::string& s, int32_t& pid) {
  if (s.empty() || s.size() > 10) return false;
  int64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  if (v > INT32_MAX) return false;
  pid = static_cast<int32_t>(v);
  return true;
}

// Whether `pid` is an ips-deploy running now on this machine (not a pid reused since).
bool supervisor_running(int32_t pid) {
  if (pid <= 0 || (::kill(pid, 0) != 0 && errno != EPERM)) return false;
  std::ifstream comm("/proc/" + std::to_string(pid) + "/comm");
  std::string name;
  std::getline(comm, name);
  return !comm || name == "ips-deploy";
}

}  // namespace

std::string format_run_file(const RunRecord& r) {
  std::string s = std::string(kMagic) + "\n";
  s += "deployment " + r.deployment + "\n";
  s += "host " + r.host + "\n";
  s += "hostname " + r.hostname + "\n";
  s += "supervisor " + std::to_string(r.supervisor_pid) + "\n";
  for (const auto& [name, pid] : r.pids) s += "process " + name + " " + std::to_string(pid) + "\n";
  return s;
}

std::optional<RunRecord> parse_run_file(const std::string& text, std::string& error) {
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || line != kMagic) {
    error = "not a run file (its first line is not '" + std::string(kMagic) + "')";
    return std::nullopt;
  }
  RunRecord r;
  int n = 1;
  while (std::getline(in, line)) {
    ++n;
    const size_t sp = line.find(' ');
    const std::string key = line.substr(0, sp);
    const std::string value = sp == std::string::npos ? "" : line.substr(sp + 1);
    bool ok = !value.empty();
    if (key == "deployment") {
      r.deployment = value;
    } else if (key == "host") {
      r.host = value;
    } else if (key == "hostname") {
      r.hostname = value;
    } else if (key == "supervisor") {
      ok = ok && parse_pid(value, r.supervisor_pid);
    } else if (key == "process") {
      const size_t sp2 = value.rfind(' ');
      int32_t pid = 0;
      ok = ok && sp2 != std::string::npos && sp2 > 0 && parse_pid(value.substr(sp2 + 1), pid);
      if (ok) r.pids[value.substr(0, sp2)] = pid;
    } else {
      ok = false;
    }
    if (!ok) {
      error = "line " + std::to_string(n) + ": not understood: '" + printable(line) + "'";
      return std::nullopt;
    }
  }
  if (r.deployment.empty() || r.host.empty() || r.hostname.empty() || r.supervisor_pid <= 0) {
    error = "incomplete (deployment, host, hostname and supervisor are needed)";
    return std::nullopt;
  }
  return r;
}

std::string run_file_dir() {
  const char* xdg = std::getenv("XDG_RUNTIME_DIR");
  if (xdg && xdg[0] == '/') return std::string(xdg) + "/ips-deploy";
  return "/tmp/ips-deploy-" + std::to_string(::getuid());
}

bool write_run_file(const std::string& dir, const RunRecord& r, std::string& path,
                    std::string& error) {
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST) {
    error = "cannot create '" + printable(dir) + "': " + std::strerror(errno);
    return false;
  }
  struct stat st{};
  if (::lstat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != ::getuid()) {
    error = "'" + printable(dir) + "' is not a directory of this user";
    return false;
  }
  path = dir + "/" + r.deployment + "-" + r.host + "-" + std::to_string(r.supervisor_pid) + ".run";
  const std::string tmp = path + ".tmp";
  if (!write_text_file(tmp, format_run_file(r), error)) return false;
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    error = "cannot rename '" + printable(tmp) + "': " + std::strerror(errno);
    return false;
  }
  return true;
}

std::vector<RunRecord> read_run_files(const std::string& dir, const std::string& deployment,
                                      int& unreadable, std::vector<std::string>& errors) {
  std::vector<RunRecord> runs;
  std::error_code ec;
  std::filesystem::directory_iterator it(dir, ec);
  if (ec) return runs;  // no run here yet
  for (const auto& entry : it) {
    const std::string path = entry.path().string();
    if (entry.path().extension() != ".run") continue;
    std::string text, error;
    std::ifstream in(path, std::ios::binary);
    if (in) {
      text.resize(kMaxRunFileBytes + 1);
      in.read(text.data(), static_cast<std::streamsize>(text.size()));
      text.resize(static_cast<size_t>(in.gcount()));
    }
    std::optional<RunRecord> r;
    if (!in && !in.eof())
      error = "cannot read";
    else if (text.size() > kMaxRunFileBytes)
      error = "longer than " + std::to_string(kMaxRunFileBytes) + " bytes";
    else
      r = parse_run_file(text, error);
    if (!r) {
      ++unreadable;
      errors.push_back(printable(path) + ": " + error);
      continue;
    }
    if (r->deployment == deployment && supervisor_running(r->supervisor_pid))
      runs.push_back(std::move(*r));
  }
  return runs;
}

}  // namespace ips::deploy
