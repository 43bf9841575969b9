#include "tools/deploy/supervisor.hpp"

#include <fcntl.h>
#include <signal.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <linux/close_range.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <thread>

#include <spdlog/spdlog.h>

#include "core/node.hpp"
#include "core/text_escape.hpp"

extern char** environ;

namespace ips::deploy {

namespace {

constexpr size_t kMaxLineBytes = 8192;  // longer output lines are printed in pieces

std::string format_s(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g s", s);
  return buf;
}

// environ with `overrides` replacing or adding their keys.
std::vector<std::string> child_environment(const std::map<std::string, std::string>& overrides) {
  std::vector<std::string> env;
  for (char** e = environ; *e; ++e) {
    const std::string kv = *e;
    const std::string key = kv.substr(0, kv.find('='));
    if (!overrides.count(key)) env.push_back(kv);
  }
  for (const auto& [k, v] : overrides) env.push_back(k + "=" + v);
  return env;
}

// Starts `path` (looked up in PATH without a '/') with stdout and stderr on `out_fd`, stdin on
// /dev/null, in `dir` (if not empty), in its own process group, with default signal handling and
// an empty mask (the node blocks SIGINT and SIGTERM for its signalfd, and ignores SIGPIPE; a
// child would inherit both). The child gets SIGTERM when ips-deploy dies, however it dies
// (PR_SET_PDEATHSIG): a SIGKILLed supervisor leaves no processes behind. posix_spawn cannot set
// that, hence fork and exec; between them only async-signal-safe calls. Returns 0 and `pid`, or
// the errno of what failed (the exec's comes back through a close-on-exec pipe).
int start_child(const std::string& path, char* const argv[], char* const envp[], int out_fd,
                const std::string& dir, pid_t& pid) {
  int status_pipe[2];
  if (pipe2(status_pipe, O_CLOEXEC) != 0) return errno;
  const pid_t parent = ::getpid();
  rlimit files{};
  const int max_fd = ::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < 1u << 20
                         ? static_cast<int>(files.rlim_cur)
                         : 1 << 20;
  const bool search = path.find('/') == std::string::npos;
  const char* file = path.c_str();
  const char* cwd = dir.empty() ? nullptr : dir.c_str();
  pid = ::fork();
  if (pid < 0) {
    const int err = errno;
    ::close(status_pipe[0]);
    ::close(status_pipe[1]);
    return err;
  }
  if (pid == 0) {
    auto fail = [&](int err) {
      [[maybe_unused]] const ssize_t n = ::write(status_pipe[1], &err, sizeof err);
      ::_exit(127);
    };
    if (::prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) fail(errno);
    if (::getppid() != parent) ::_exit(127);  // ips-deploy died before the prctl
    ::setpgid(0, 0);
    struct sigaction dfl = {};
    dfl.sa_handler = SIG_DFL;
    for (int sig : {SIGINT, SIGTERM, SIGPIPE, SIGCHLD, SIGHUP}) ::sigaction(sig, &dfl, nullptr);
    sigset_t none;
    sigemptyset(&none);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);
    const int null_fd = ::open("/dev/null", O_RDONLY);
    if (null_fd < 0 || ::dup2(null_fd, STDIN_FILENO) < 0 || ::dup2(out_fd, STDOUT_FILENO) < 0 ||
        ::dup2(out_fd, STDERR_FILENO) < 0)
      fail(errno);
    if (cwd && ::chdir(cwd) != 0) fail(errno);
    // Nothing of ips-deploy's but the output: liblcm opens its sockets without close-on-exec, and
    // a child holding ips-deploy's LCM receive socket counted that socket's drops as its own
    // (every process of the soak's compute host reported ips-deploy's 15 660, degraded by them).
    // Close-on-exec rather than closed: the status pipe must reach the exec.
    if (::close_range(3, ~0U, CLOSE_RANGE_CLOEXEC) != 0)  // before Linux 5.11: one by one
      for (int fd = 3; fd < max_fd; ++fd) ::fcntl(fd, F_SETFD, FD_CLOEXEC);
    if (search)
      ::execvpe(file, argv, envp);
    else
      ::execve(file, argv, envp);
    fail(errno);
  }
  ::setpgid(pid, pid);  // also here: a stop right after the start reaches the whole group
  ::close(status_pipe[1]);
  int err = 0;
  ssize_t n;
  do n = ::read(status_pipe[0], &err, sizeof err);
  while (n < 0 && errno == EINTR);
  ::close(status_pipe[0]);
  if (n == static_cast<ssize_t>(sizeof err)) {
    int status = 0;
    ::waitpid(pid, &status, 0);
    pid = -1;
    return err != 0 ? err : ENOEXEC;
  }
  return 0;
}

}  // namespace

double BackoffPolicy::next_delay(double run_s) {
  if (last_ == 0 || run_s >= b_.reset_after_s)
    last_ = b_.initial_s;
  else
    last_ = std::min(last_ * 2, b_.max_s);
  return last_;
}

bool should_restart(Restart policy, bool exited_cleanly) {
  switch (policy) {
    case Restart::kNo:
      return false;
    case Restart::kAlways:
      return true;
    case Restart::kOnFailure:
      return !exited_cleanly;
  }
  return false;
}

std::string describe_wait_status(int status) {
  if (WIFEXITED(status)) return "status " + std::to_string(WEXITSTATUS(status));
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    const char* abbrev = sigabbrev_np(sig);
    return "signal " + std::to_string(sig) + (abbrev ? std::string(" (SIG") + abbrev + ")" : "");
  }
  return "wait status " + std::to_string(status);
}

Supervisor::Supervisor(Node& node, const Deployment& d, const Host& host,
                       std::map<std::string, std::string> resolved,
                       std::function<void(const std::string&)> print)
    : node_(node), d_(d), print_(std::move(print)) {
  for (const Process& p : host.processes) {
    auto c = std::make_unique<Child>(Child{&p, resolved.at(p.name), -1, -1, "", {},
                                           BackoffPolicy(p.backoff), false, {}, false, 0});
    children_.push_back(std::move(c));
  }
}

Supervisor::~Supervisor() {
  for (auto& c : children_) close_output(*c);
}

void Supervisor::start() {
  for (auto& c : children_) spawn(*c);
  node_.add_timer(0.05, [this] {
    if (!stopping_) tick();
  });
}

pid_t Supervisor::pid_of(const std::string& name) const {
  for (const auto& c : children_)
    if (c->process->name == name) return c->pid;
  return -1;
}

std::map<std::string, int32_t> Supervisor::pids() const {
  std::map<std::string, int32_t> out;
  for (const auto& c : children_) out[c->process->name] = c->pid > 0 ? c->pid : 0;
  return out;
}

bool Supervisor::finished() const {
  return std::all_of(children_.begin(), children_.end(),
                     [](const auto& c) { return c->done; });
}

void Supervisor::spawn(Child& c) {
  const Process& p = *c.process;
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    node_.report_error(p.name + ": pipe: " + strerror(errno));
    c.restart_pending = true;
    c.restart_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(c.backoff.next_delay(0)));
    return;
  }
  std::vector<std::string> args = {c.path};
  args.insert(args.end(), p.args.begin(), p.args.end());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<std::string> env = child_environment(process_environment(d_, p));
  std::vector<char*> envp;
  for (auto& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  const int rc = start_child(c.path, argv.data(), envp.data(), fds[1], d_.working_dir, c.pid);
  ::close(fds[1]);
  ++c.runs;
  c.started = Clock::now();
  if (rc != 0) {
    ::close(fds[0]);
    c.pid = -1;
    print_("[ips-deploy] " + p.name + ": cannot run " + printable(c.path) + ": " + strerror(rc));
    reaped(c, W_EXITCODE(127, 0));
    return;
  }
  const pid_t pid = c.pid;
  c.out_fd = fds[0];
  fcntl(c.out_fd, F_SETFL, fcntl(c.out_fd, F_GETFL) | O_NONBLOCK);
  node_.watch_fd(c.out_fd, POLLIN, [this, &c](short) { on_output(c); });
  print_("[ips-deploy] started " + p.name + " (pid " + std::to_string(pid) + "): " +
         printable(c.path) + (p.args.empty() ? "" : " ...") +
         (c.runs > 1 ? ", run " + std::to_string(c.runs) : ""));
  if (on_pids_changed_) on_pids_changed_();
}

// HEALTH's last_error (and degraded state) without the Node's own log line on stderr: every
// exit is printed once, by print_, as "[ips-deploy] ..." (it used to appear twice).
void Supervisor::report_quietly(const std::string& text) {
  const auto logger = spdlog::default_logger();
  const auto level = logger->level();
  logger->set_level(spdlog::level::off);
  node_.report_error(text);
  logger->set_level(level);
}

void Supervisor::on_output(Child& c) {
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(c.out_fd, buf, sizeof buf);
    if (n > 0) {
      c.partial.append(buf, static_cast<size_t>(n));
      size_t start = 0;
      for (size_t nl; (nl = c.partial.find('\n', start)) != std::string::npos; start = nl + 1)
        print_("[" + c.process->name + "] " + c.partial.substr(start, nl - start));
      c.partial.erase(0, start);
      if (c.partial.size() >= kMaxLineBytes) {
        print_("[" + c.process->name + "] " + c.partial);
        c.partial.clear();
      }
      continue;
    }
    if (n < 0 && (errno == EAGAIN || errno == EINTR)) return;
    close_output(c);  // end of file: the child (and whatever it started) closed its output
    return;
  }
}

void Supervisor::close_output(Child& c) {
  if (c.out_fd < 0) return;
  if (!c.partial.empty()) print_("[" + c.process->name + "] " + c.partial);
  c.partial.clear();
  node_.unwatch_fd(c.out_fd);
  ::close(c.out_fd);
  c.out_fd = -1;
}

void Supervisor::reaped(Child& c, int status) {
  // Output written just before the exit is still in the pipe: print it first.
  if (c.out_fd >= 0) on_output(c);
  close_output(c);
  const Process& p = *c.process;
  const double ran = std::chrono::duration<double>(Clock::now() - c.started).count();
  const bool clean = WIFEXITED(status) && WEXITSTATUS(status) == 0;
  c.pid = -1;
  if (on_pids_changed_) on_pids_changed_();
  std::string what = p.name + " exited with " + describe_wait_status(status) + " after " +
                     format_s(ran);
  if (!stopping_ && should_restart(p.restart, clean)) {
    const double delay = c.backoff.next_delay(ran);
    c.restart_pending = true;
    c.restart_at = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(delay));
    ++restarts_;
    ++node_.counters().drops;
    report_quietly(what + "; restarting in " + format_s(delay));
    print_("[ips-deploy] " + what + "; restarting in " + format_s(delay) + " (restart " +
           std::to_string(c.runs) + ", policy " + restart_name(p.restart) + ")");
    return;
  }
  c.done = true;
  if (!clean && !stopping_) {
    any_failed_ = true;
    report_quietly(what + "; not restarted (restart: " + restart_name(p.restart) + ")");
  }
  if (!stopping_)
    print_("[ips-deploy] " + what + (clean ? "" : "; not restarted (restart: " +
                                                      std::string(restart_name(p.restart)) + ")"));
}

void Supervisor::tick() {
  for (auto& c : children_) {
    if (c->pid > 0) {
      int status = 0;
      const pid_t r = ::waitpid(c->pid, &status, WNOHANG);
      if (r == c->pid) reaped(*c, status);
    } else if (c->restart_pending && Clock::now() >= c->restart_at) {
      c->restart_pending = false;
      spawn(*c);
    }
  }
}

void Supervisor::stop() {
  stopping_ = true;
  // Each process gets its own stop_timeout_s after its SIGINT, then SIGKILL.
  std::map<const Child*, Clock::time_point> deadline;
  for (auto it = children_.rbegin(); it != children_.rend(); ++it) {
    Child& c = **it;
    c.restart_pending = false;
    if (c.pid <= 0) continue;
    print_("[ips-deploy] stopping " + c.process->name + " (pid " + std::to_string(c.pid) + ")");
    ::kill(c.pid, SIGINT);
    deadline[&c] = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(c.process->stop_timeout_s));
  }
  for (;;) {
    bool running = false;
    for (auto& c : children_) {
      if (c->pid <= 0) continue;
      int status = 0;
      if (::waitpid(c->pid, &status, WNOHANG) == c->pid) {
        reaped(*c, status);
        print_("[ips-deploy] " + c->process->name + " stopped (" + describe_wait_status(status) +
               ")");
        continue;
      }
      running = true;
      const auto d = deadline.find(c.get());
      if (d != deadline.end() && Clock::now() >= d->second) {
        print_("[ips-deploy] " + c->process->name + " did not stop in time: SIGKILL");
        ::kill(c->pid, SIGKILL);
        deadline.erase(d);
      }
    }
    if (!running) break;
    for (auto& c : children_)
      if (c->out_fd >= 0) on_output(*c);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace ips::deploy
