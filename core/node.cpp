#include "core/node.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/lcm_url.hpp"
#include "core/text_escape.hpp"

namespace ips {

namespace {
std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}
}  // namespace

Node::Node(std::string name, const CommonOptions& opts)
    : name_(std::move(name)),
      opts_(opts),
      lcm_(open_lcm(opts.lcm_url)),
      health_channel_(opts.channel(channel::kHealth)),
      host_(host_name()),
      start_time_(std::chrono::steady_clock::now()) {
  // SIGINT/SIGTERM/SIGHUP (the terminal closed) arrive through a signalfd so that the loop ends
  // cleanly between messages.
  sigset_t mask;
  sigemptyset(&mask);
  sigaddset(&mask, SIGINT);
  sigaddset(&mask, SIGTERM);
  sigaddset(&mask, SIGHUP);
  sigprocmask(SIG_BLOCK, &mask, &old_sigmask_);
  signal_fd_ = signalfd(-1, &mask, SFD_CLOEXEC | SFD_NONBLOCK);
  if (signal_fd_ < 0) {
    sigprocmask(SIG_SETMASK, &old_sigmask_, nullptr);
    throw LcmOpenError(std::string("signalfd: ") + std::strerror(errno));
  }
  // For udpm this sets up reception, including liblcm's multicast self-test: do it once, here,
  // and fail loudly rather than run deaf.
  lcm_fd_ = lcm_->getFileno();
  if (lcm_fd_ < 0) {
    close(signal_fd_);
    sigprocmask(SIG_SETMASK, &old_sigmask_, nullptr);
    throw LcmOpenError("LCM on '" + effective_lcm_url(opts.lcm_url) +
                       "' cannot receive (its multicast self-test got nothing back); see "
                       "docs/networking.md");
  }
  // A closed pipe (e.g. `| head`) must not kill the process mid-write.
  signal(SIGPIPE, SIG_IGN);
  add_timer(1.0, [this] { publish_health(); });
}

Node::~Node() {
  close(signal_fd_);
  // Signals that arrived meanwhile stay pending and are delivered now, as if we had not been here.
  sigprocmask(SIG_SETMASK, &old_sigmask_, nullptr);
}

void Node::publish_raw(const std::string& channel, const void* data, size_t size) {
  if (size > UINT32_MAX || lcm_->publish(channel, data, static_cast<unsigned>(size)) != 0) {
    ++counters_.drops;
    report_error("channel " + channel + ": publish failed (" + std::to_string(size) + " bytes)");
    return;
  }
  ++counters_.msgs_out;
}

void Node::subscribe_raw(const std::string& channel, RawHandler handler) {
  // Every message that reaches us is counted, decodable or not. An exception from a handler
  // must not unwind through liblcm's C dispatch: it is counted and reported instead.
  handlers_.push_back([this, h = std::move(handler)](const lcm::ReceiveBuffer* rbuf,
                                                     const std::string& chan) {
    ++counters_.msgs_in;
    try {
      h(rbuf, chan);
    } catch (const std::exception& e) {
      ++counters_.drops;
      report_error("channel " + chan + ": handler failed: " + e.what());
    }
  });
  lcm::Subscription* sub = lcm_->subscribeFunction(
      channel,
      +[](const lcm::ReceiveBuffer* rbuf, const std::string& chan, RawHandler* h) {
        (*h)(rbuf, chan);
      },
      &handlers_.back());
  if (!sub) {
    handlers_.pop_back();
    throw LcmOpenError("cannot subscribe to channel '" + channel + "'");
  }
  // liblcm keeps 30 messages per subscription by default and drops the rest without a word when
  // the process falls behind (a loaded machine, a burst): replayed captures lost up to 14 % of
  // their ranges that way. kSubscriptionQueueMessages holds several seconds of a busy lab.
  sub->setQueueCapacity(kSubscriptionQueueMessages);
}

void Node::add_timer(double period_s, std::function<void()> fn) {
  auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(period_s));
  timers_.push_back({period, std::chrono::steady_clock::now() + period, std::move(fn)});
}

void Node::dispatch_timers() {
  auto now = std::chrono::steady_clock::now();
  for (auto& t : timers_) {
    if (now >= t.next) {
      t.fn();
      t.next += t.period;
      if (t.next < now) t.next = now + t.period;  // skip missed ticks rather than burst
    }
  }
}

bool Node::spin_once(int timeout_ms) {
  if (stopping_) return false;
  auto now = std::chrono::steady_clock::now();
  for (const auto& t : timers_) {
    // Round up: waking before the deadline would spin.
    auto until = std::chrono::ceil<std::chrono::milliseconds>(t.next - now).count();
    if (until < timeout_ms) timeout_ms = static_cast<int>(std::max<int64_t>(0, until));
  }
  pollfds_.clear();
  pollfds_.push_back({lcm_fd_, POLLIN, 0});
  pollfds_.push_back({signal_fd_, POLLIN, 0});
  for (const auto& w : watches_) pollfds_.push_back({w.fd, w.events, 0});
  pollfd* fds = pollfds_.data();
  int n = poll(fds, static_cast<nfds_t>(pollfds_.size()), timeout_ms);
  if (n < 0 && errno != EINTR) {
    report_error(std::string("poll: ") + std::strerror(errno));
  }
  if (n > 0 && (fds[1].revents & POLLIN)) {
    signalfd_siginfo si;
    if (read(signal_fd_, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
      spdlog::info("{}: signal {} received, stopping", name_, si.ssi_signo);
      stop_signal_ = static_cast<int>(si.ssi_signo);
    }
    stopping_ = true;
    return false;
  }
  if (n > 0 && (fds[0].revents & POLLIN)) {
    if (lcm_->handle() != 0) report_error("lcm handle() failed");
  } else if (n > 0 && (fds[0].revents & (POLLERR | POLLHUP | POLLNVAL))) {
    // The LCM socket is gone: nothing more can arrive. Stop rather than spin.
    state_ = health_t::STATE_ERROR;
    report_error("LCM socket failed; stopping");
    failed_ = true;
    stopping_ = true;
  }
  if (n > 0) {
    // Copy what fired first: a handler may watch or unwatch fds (pollfds_ is rebuilt each turn).
    std::vector<std::pair<int, short>> fired;
    for (size_t i = 2; i < pollfds_.size(); ++i)
      if (pollfds_[i].revents != 0) fired.emplace_back(pollfds_[i].fd, pollfds_[i].revents);
    for (const auto& [fd, revents] : fired) {
      auto it = std::find_if(watches_.begin(), watches_.end(),
                             [fd = fd](const Watch& w) { return w.fd == fd; });
      if (it == watches_.end()) continue;  // unwatched by an earlier handler
      auto fn = it->fn;                     // the handler may unwatch itself
      try {
        fn(revents);
      } catch (const std::exception& e) {
        ++counters_.drops;
        report_error(std::string("fd handler failed: ") + e.what());
      }
    }
  }
  dispatch_timers();
  return !stopping_;
}

void Node::watch_fd(int fd, short events, std::function<void(short revents)> fn) {
  for (auto& w : watches_)
    if (w.fd == fd) {
      w.events = events;
      w.fn = std::move(fn);
      return;
    }
  watches_.push_back({fd, events, std::move(fn)});
}

void Node::unwatch_fd(int fd) {
  watches_.erase(std::remove_if(watches_.begin(), watches_.end(),
                                [fd](const Watch& w) { return w.fd == fd; }),
                 watches_.end());
}

int Node::run() {
  publish_health();
  while (spin_once(1000)) {
  }
  publish_health();
  return failed_ ? 1 : 0;
}

void Node::report_error(const std::string& text) {
  last_error_ = text;
  last_error_at_ = std::chrono::steady_clock::now();
  if (state_ == health_t::STATE_OK) {
    state_ = health_t::STATE_DEGRADED;
    degraded_by_error_ = true;
  }
  if (error_log_limit_.allow(wall_utime_now())) spdlog::warn("{}: {}", name_, printable(text));
}

void Node::report_lasting_error(const std::string& key, const std::string& text) {
  last_error_ = text;
  lasting_.insert(key);
  if (error_log_limit_.allow(wall_utime_now())) spdlog::warn("{}: {}", name_, printable(text));
}

void Node::end_lasting_error(const std::string& key) {
  if (lasting_.erase(key) == 0 || !lasting_.empty()) return;
  if (degraded_by_error_) {
    state_ = health_t::STATE_OK;
    degraded_by_error_ = false;
  }
}

void Node::publish_health() {
  if (degraded_by_error_ && std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                                          last_error_at_)
                                    .count() >= degraded_hold_s_) {
    state_ = health_t::STATE_OK;
    degraded_by_error_ = false;
  }
  health_t h;
  h.utime = wall_utime_now();
  h.source = name_;
  h.host = host_;
  h.pid = static_cast<int32_t>(getpid());
  h.state = state();
  h.msgs_in = counters_.msgs_in;
  h.msgs_out = counters_.msgs_out;
  h.parse_errors = counters_.parse_errors;
  h.drops = counters_.drops;
  h.last_error = last_error_;
  h.uptime_us = std::chrono::duration_cast<std::chrono::microseconds>(
                    std::chrono::steady_clock::now() - start_time_)
                    .count();
  lcm_->publish(health_channel_, &h);
}

}  // namespace ips
