#include "tools/site/reload_triggers.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/inotify.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "core/text_escape.hpp"

namespace ips::site_tool {

namespace {
constexpr uint32_t kFileEvents = IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE |
                                 IN_DELETE;
constexpr uint32_t kDirMoved = IN_DELETE_SELF | IN_MOVE_SELF;  // asked for
constexpr uint32_t kDirGone = kDirMoved | IN_IGNORED | IN_UNMOUNT;  // the last two always come
}  // namespace

FileWatch::FileWatch(Node& node, const std::string& path, double settle_s,
                     std::function<void()> on_change,
                     std::function<void(const std::string& why)> on_lost)
    : node_(node),
      settle_s_(settle_s),
      on_change_(std::move(on_change)),
      on_lost_(std::move(on_lost)) {
  const std::filesystem::path p(path);
  dir_ = p.has_parent_path() ? p.parent_path().string() : ".";
  name_ = p.filename().string();
  inotify_fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
  timer_fd_ = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (inotify_fd_ >= 0)
    wd_ = inotify_add_watch(inotify_fd_, dir_.c_str(), kFileEvents | kDirMoved | IN_ONLYDIR);
  if (inotify_fd_ < 0 || timer_fd_ < 0 || wd_ < 0) {
    const std::string why = std::strerror(errno);
    wd_ = -1;
    lost("cannot watch " + dir_ + " for changes (" + why + ")");
    return;
  }
  node_.watch_fd(inotify_fd_, POLLIN, [this](short) { on_events(); });
  node_.watch_fd(timer_fd_, POLLIN, [this](short) {
    uint64_t expirations = 0;
    if (read(timer_fd_, &expirations, sizeof expirations) != sizeof expirations) return;
    armed_ = false;
    on_change_();
  });
}

FileWatch::~FileWatch() {
  if (inotify_fd_ >= 0) {
    node_.unwatch_fd(inotify_fd_);
    close(inotify_fd_);
  }
  if (timer_fd_ >= 0) {
    node_.unwatch_fd(timer_fd_);
    close(timer_fd_);
  }
}

void FileWatch::lost(const std::string& why) {
  if (inotify_fd_ >= 0) node_.unwatch_fd(inotify_fd_);
  wd_ = -1;
  on_lost_(why);
}

void FileWatch::arm() {
  const auto now = std::chrono::steady_clock::now();
  if (!armed_) burst_start_ = now;
  // A file rewritten again and again is still read: the burst is cut at kMaxSettleS.
  else if (std::chrono::duration<double>(now - burst_start_).count() >= kMaxSettleS) return;
  itimerspec t{};
  t.it_value.tv_sec = static_cast<time_t>(settle_s_);
  t.it_value.tv_nsec = static_cast<long>(std::fmod(settle_s_, 1.0) * 1e9);
  if (t.it_value.tv_sec == 0 && t.it_value.tv_nsec == 0) t.it_value.tv_nsec = 1;  // 0 disarms
  if (timerfd_settime(timer_fd_, 0, &t, nullptr) != 0) {
    on_change_();  // no timer: read now rather than never
    return;
  }
  armed_ = true;
}

void FileWatch::on_events() {
  // Aligned as inotify(7) asks; room for many events with names.
  alignas(inotify_event) char buf[16 * 1024];
  for (;;) {
    const ssize_t n = read(inotify_fd_, buf, sizeof buf);
    if (n <= 0) return;  // EAGAIN: all read
    for (ssize_t i = 0; i < n;) {
      const auto* ev = reinterpret_cast<const inotify_event*>(buf + i);
      i += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
      if (ev->mask & IN_Q_OVERFLOW) {
        arm();  // events were lost: ours may be among them
      } else if (ev->len > 0 && (ev->mask & kFileEvents) && name_ == ev->name) {
        arm();
      } else if (ev->wd == wd_ && (ev->mask & kDirGone)) {
        lost("the directory " + dir_ + " was removed, renamed or unmounted");
        return;
      }
    }
  }
}

namespace {
int g_hangup_write_fd = -1;

extern "C" void on_sighup(int) {
  const int saved = errno;
  const char byte = 1;
  // Async-signal-safe; a full pipe already holds a wake-up.
  [[maybe_unused]] const ssize_t n = write(g_hangup_write_fd, &byte, 1);
  errno = saved;
}
}  // namespace

HangupHandler::HangupHandler(Node& node, std::function<void()> on_hangup) : node_(node) {
  if (g_hangup_write_fd >= 0) throw std::logic_error("one HangupHandler at a time");
  int fds[2];
  if (pipe2(fds, O_NONBLOCK | O_CLOEXEC) != 0)
    throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  read_fd_ = fds[0];
  g_hangup_write_fd = fds[1];
  node_.watch_fd(read_fd_, POLLIN, [this, fn = std::move(on_hangup)](short) {
    char drain[64];
    while (read(read_fd_, drain, sizeof drain) > 0) {
    }
    fn();
  });
  // The node takes SIGHUP through its signalfd while the signal is blocked (pending); with a
  // handler and the signal unblocked it is delivered to the handler instead. The signalfd may
  // still wake the node's poll() in between, with nothing to read then: the node goes on
  // (core/node.cpp stops only on a signal it has read).
  struct sigaction sa{};
  sa.sa_handler = on_sighup;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;
  sigaction(SIGHUP, &sa, nullptr);
  sigset_t hup;
  sigemptyset(&hup);
  sigaddset(&hup, SIGHUP);
  sigprocmask(SIG_UNBLOCK, &hup, nullptr);
}

HangupHandler::~HangupHandler() {
  sigset_t hup;
  sigemptyset(&hup);
  sigaddset(&hup, SIGHUP);
  sigprocmask(SIG_BLOCK, &hup, nullptr);  // back to the node's own handling
  signal(SIGHUP, SIG_DFL);
  node_.unwatch_fd(read_fd_);
  close(read_fd_);
  close(g_hangup_write_fd);
  g_hangup_write_fd = -1;
}

}  // namespace ips::site_tool
