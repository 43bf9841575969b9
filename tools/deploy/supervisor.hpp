#pragma once
// ips-deploy run: one host's processes in the foreground. Each is started in start order as its
// own process group (so that a terminal's Ctrl-C reaches ips-deploy only, which then stops them
// in order), with the deployment's environment; its output lines are printed prefixed
// "[name] "; when it exits it is restarted as its policy says, after a back-off that doubles
// from initial_s to max_s and starts over once a run has lasted reset_after_s. stop() sends
// SIGINT in reverse start order and SIGKILL to what is left after stop_timeout_s.
#include <sys/types.h>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "tools/deploy/deployment.hpp"

namespace ips {
class Node;
}

namespace ips::deploy {

// The delay before each restart. Pure.
class BackoffPolicy {
 public:
  explicit BackoffPolicy(Backoff b) : b_(b) {}
  // A run that lasted run_s ended: the delay before the next start.
  double next_delay(double run_s);

 private:
  Backoff b_;
  double last_ = 0;  // 0: no restart yet, or reset
};

// Whether a process that ended is started again: never for kNo, always for kAlways, and for
// kOnFailure unless it exited with status 0.
bool should_restart(Restart policy, bool exited_cleanly);

// "status 1", "signal 9 (SIGKILL)".
std::string describe_wait_status(int status);

class Supervisor {
 public:
  using Clock = std::chrono::steady_clock;
  // `resolved`: each process's command path. `print`: one line of output (ours or a child's).
  Supervisor(Node& node, const Deployment& d, const Host& host,
             std::map<std::string, std::string> resolved,
             std::function<void(const std::string&)> print);
  ~Supervisor();
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;

  // Starts every process (in start order) and a 50 ms timer that reaps and restarts.
  void start();
  // Stops every process; returns when all have exited.
  void stop();
  // True when no process runs and none will be restarted.
  bool finished() const;
  // True when some process ended (for good) other than with status 0.
  bool any_failed() const { return any_failed_; }
  int64_t restarts() const { return restarts_; }
  // The pid of a process now, or -1.
  pid_t pid_of(const std::string& name) const;
  // Every process's pid now (0: not running), for the run file (run_file.hpp).
  std::map<std::string, int32_t> pids() const;
  // Called after a process has started or ended (its pid changed).
  void on_pids_changed(std::function<void()> f) { on_pids_changed_ = std::move(f); }

 private:
  struct Child {
    const Process* process;
    std::string path;
    pid_t pid = -1;
    int out_fd = -1;
    std::string partial;  // output after the last newline
    Clock::time_point started;
    BackoffPolicy backoff;
    bool restart_pending = false;
    Clock::time_point restart_at;
    bool done = false;  // ended for good
    int runs = 0;
  };
  void spawn(Child& c);
  void tick();
  void on_output(Child& c);
  void close_output(Child& c);
  void reaped(Child& c, int status);
  void report_quietly(const std::string& text);

  Node& node_;
  const Deployment& d_;
  std::vector<std::unique_ptr<Child>> children_;
  std::function<void(const std::string&)> print_;
  std::function<void()> on_pids_changed_;
  int64_t restarts_ = 0;
  bool any_failed_ = false;
  bool stopping_ = false;
};

}  // namespace ips::deploy
