#pragma once
// The run file: `ips-deploy run` keeps, while it runs, a small text file saying which deployment
// and host it runs, on which machine (its hostname) and the pid of each of its processes now.
// `ips-deploy status` on the same machine reads these files to match the HEALTH of those pids to
// the deployment's processes, whatever the file's `hostname` says (docs/deployment.md, "Status").
//
//   ips-deploy-run 1
//   deployment lab
//   host compute
//   hostname my-laptop
//   supervisor 4241
//   process uwb-twr 4242
//   process fuse 0          (0: not running now, e.g. waiting to be restarted)
//
// In run_file_dir(): $XDG_RUNTIME_DIR/ips-deploy, else /tmp/ips-deploy-<uid>, one file per run,
// <deployment>-<host>-<supervisor pid>.run, removed when the run ends.
#include <sys/types.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace ips::deploy {

struct RunRecord {
  std::string deployment;
  std::string host;      // the deployment's host name (--host)
  std::string hostname;  // this machine's, as HEALTH reports it
  int32_t supervisor_pid = 0;
  std::map<std::string, int32_t> pids;  // process name -> pid now (0: none)
};

// Pure: the text, and back. nullopt (with `error` saying why) for anything else.
std::string format_run_file(const RunRecord& r);
std::optional<RunRecord> parse_run_file(const std::string& text, std::string& error);

// The directory of the run files (not created).
std::string run_file_dir();

// Writes `r` into dir/<deployment>-<host>-<pid>.run (atomically: a temporary file renamed),
// creating dir (mode 0700) if needed. False with `error` on failure, or when dir is not ours.
bool write_run_file(const std::string& dir, const RunRecord& r, std::string& path,
                    std::string& error);

// The runs of `deployment` whose ips-deploy is still running on this machine. Files that cannot
// be read or parsed are counted in `unreadable` (their names and reasons in `errors`); files of
// runs that have ended (a SIGKILLed ips-deploy leaves its file) are skipped.
std::vector<RunRecord> read_run_files(const std::string& dir, const std::string& deployment,
                                      int& unreadable, std::vector<std::string>& errors);

}  // namespace ips::deploy
