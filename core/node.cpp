#include "core/node.hpp"

#include <ips/ble_aoa_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <spdlog/spdlog.h>

#include "core/channels.hpp"
#include "core/lcm_url.hpp"
#include "core/text_escape.hpp"
#include "core/version.hpp"
#include "core/yaml_fields.hpp"

namespace ips {

namespace {
constexpr int kShadowQueueMessages = 200000;

int64_t big_endian_i64(const void* data) {
  const auto* b = static_cast<const uint8_t*>(data);
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | b[i];
  return static_cast<int64_t>(v);
}

std::string host_name() {
  char buf[256] = {0};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

// A socket's receive buffer as the kernel reports it (SO_RCVBUF), or -1.
int granted_recv_buf(int fd) {
  int granted = 0;
  socklen_t len = sizeof granted;
  if (fd < 0 || getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &granted, &len) != 0) return -1;
  return granted;
}

// Linux doubles what it grants (bookkeeping overhead) and caps the request at
// net.core.rmem_max: less than twice the request means it was capped.
bool granted_in_full(int granted, int32_t requested) {
  return int64_t{granted} >= 2 * int64_t{requested};
}
}  // namespace

Node::Node(std::string name, const CommonOptions& opts)
    : name_(std::move(name)),
      opts_(opts),
      lcm_(open_lcm(opts.lcm_url, opts.lcm_recv_buf)),
      health_channel_(opts.channel(channel::kHealth)),
      host_(host_name()),
      start_time_(std::chrono::steady_clock::now()) {
  const std::string url = effective_lcm_url(opts.lcm_url);
  const bool try_direct = (opts.lcm_receiver == "direct" || opts.lcm_receiver == "auto") &&
                          lcm_url_udpm_port(url) != 0;
  const std::string busy_poll_refused =
      "--busy-poll-us needs --lcm-receiver direct on a udpm:// bus (LCM URL '" + url +
      "'): with liblcm's receiver its own thread sleeps for each message";
  if (opts.busy_poll_us > 0 && !try_direct) throw ConfigError(busy_poll_refused);
  busy_poll_ = std::chrono::microseconds(opts.busy_poll_us);
  last_input_ = start_time_ - busy_poll_;  // no message yet
  recv_buf_requested_ = lcm_url_recv_buf(lcm_url_with_recv_buf(url, opts.lcm_recv_buf));
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
  // (The mask is set before liblcm starts its receive thread, which inherits it: a signal must
  // not end the process there.) On a failure below, as it was.
  const auto undo_signals = [this] {
    close(signal_fd_);
    sigprocmask(SIG_SETMASK, &old_sigmask_, nullptr);
  };
  if (try_direct) {
    try {
      open_direct_receiver(lcm_url_with_recv_buf(url, opts.lcm_recv_buf));
    } catch (...) {
      undo_signals();
      throw;
    }
    if (opts.lcm_receiver == "auto") choose_receiver(url);
  }
  if (opts.busy_poll_us > 0 && !direct_) {
    undo_signals();
    throw ConfigError(busy_poll_refused + " (--lcm-receiver auto chose liblcm's: the receive "
                                          "buffer is capped; see docs/networking.md#loss)");
  }
  if (direct_) {
    lcm_fd_ = direct_->fd();
  } else {
    // For udpm this sets up reception, including liblcm's multicast self-test: do it once,
    // here, and fail loudly rather than run deaf.
    lcm_fd_ = lcm_->getFileno();
  }
  if (lcm_fd_ < 0) {
    undo_signals();
    throw LcmOpenError("LCM on '" + url +
                       "' cannot receive (its multicast self-test got nothing back); see "
                       "docs/networking.md");
  }
  measure_recv_buf();
  // A closed pipe (e.g. `| head`) must not kill the process mid-write.
  signal(SIGPIPE, SIG_IGN);
  add_timer(1.0, [this] { publish_health(); });
}

Node::~Node() {
  close(signal_fd_);
  // Signals that arrived meanwhile stay pending and are delivered now, as if we had not been here.
  sigprocmask(SIG_SETMASK, &old_sigmask_, nullptr);
}

void Node::open_direct_receiver(const std::string& url) {
  direct_ = std::make_unique<LcmUdpmReceiver>(url);
  // liblcm's self-test, ours: a message to the group must come back to this socket, or the
  // process would run deaf (no multicast route, a firewall, a group the interface did not join).
  static constexpr std::string_view kChannel = "LCM_SELF_TEST";
  static constexpr std::string_view kText = "lcm self test";
  bool heard = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  auto next_send = std::chrono::steady_clock::now();
  while (!heard && std::chrono::steady_clock::now() < deadline) {
    if (std::chrono::steady_clock::now() >= next_send) {
      lcm_->publish(std::string(kChannel), kText.data(), static_cast<unsigned>(kText.size()));
      next_send += std::chrono::milliseconds(200);
    }
    pollfd p{direct_->fd(), POLLIN, 0};
    if (poll(&p, 1, 50) <= 0) continue;
    // What else arrives before the process subscribes is for nobody here (as with liblcm).
    direct_->read_batch(
        [&](const LcmReassembler::Message& m, int64_t) {
          heard = heard || (m.channel == kChannel &&
                            std::string_view(reinterpret_cast<const char*>(m.data), m.size) ==
                                kText);
        },
        nullptr);
  }
  if (!heard) {
    direct_.reset();
    throw LcmOpenError("LCM on '" + url +
                       "' cannot receive (its multicast self-test got nothing back in 2 s); see "
                       "docs/networking.md");
  }
}

void Node::choose_receiver(const std::string& url) {
  // Read directly, the socket's buffer is all that holds a burst while the process is busy;
  // liblcm's thread empties a small one into its queues. At 100 tags, 208 KiB read directly lost
  // 305 datagrams in 15 s, liblcm's receiver none (docs/development.md#the-bus-at-scale).
  const int asked = recv_buf_requested_;
  const int granted = granted_recv_buf(direct_->fd());
  // Read directly, it must also hold what the documented size does (docs/networking.md#loss).
  const int64_t has = granted / 2;
  if (asked > 0 && granted_in_full(granted, asked) && has >= kDefaultRecvBufBytes) {
    // (debug: a start-up error must stay the one line on stderr)
    spdlog::debug("{}: --lcm-receiver auto: reading the bus directly (receive buffer {} bytes)",
                  name_, has);
    return;
  }
  spdlog::info(
      "{}: --lcm-receiver auto: reading the bus through liblcm's receive thread and queues: the "
      "receive buffer on '{}' is {} bytes, and reading directly needs the {} asked for and at "
      "least {} (docs/networking.md#receivers)",
      name_, url, has, asked, kDefaultRecvBufBytes);
  direct_.reset();
}

const Node::DirectRoute& Node::direct_route(std::string_view channel) {
  if (direct_routes_stale_) {
    direct_routes_.clear();
    direct_routes_stale_ = false;
  }
  if (auto it = direct_routes_.find(channel); it != direct_routes_.end()) return *it;
  // A bus of ever new names (a fault, an attack) must not grow this without bound.
  if (direct_routes_.size() >= 4096) direct_routes_.clear();
  std::vector<RawHandler*> handlers;
  const std::string name(channel);
  for (const auto& sub : direct_subscriptions_)
    if (std::regex_match(name, sub.channel)) handlers.push_back(sub.handler);
  return *direct_routes_.emplace(name, std::move(handlers)).first;
}

bool Node::read_direct() {
  const int n = direct_->read_batch(
      [this](const LcmReassembler::Message& m, int64_t recv_utime) {
        const DirectRoute& route = direct_route(m.channel);
        if (route.second.empty()) return;
        lcm::ReceiveBuffer rbuf{const_cast<uint8_t*>(m.data), static_cast<uint32_t>(m.size),
                                recv_utime};
        for (RawHandler* h : route.second) (*h)(&rbuf, route.first);
      },
      [this](const std::string& why) {
        ++counters_.parse_errors;
        report_error("LCM datagram dropped: " + why);
      });
  return n >= 0;
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
  QueueWatch* watch =
      opts_.lcm_queue > 0 && !direct_ ? &queue_watches_.emplace_back() : nullptr;
  handlers_.push_back([this, watch, h = std::move(handler)](const lcm::ReceiveBuffer* rbuf,
                                                            const std::string& chan) {
    ++counters_.msgs_in;
    if (watch) ++watch->delivered;
    count_sequence(rbuf);
    try {
      h(rbuf, chan);
    } catch (const std::exception& e) {
      ++counters_.drops;
      report_error("channel " + chan + ": handler failed: " + e.what());
    }
  });
  if (direct_) {
    // No queue here: the socket's receive buffer is the only one, and what it drops the kernel
    // counts (kernel_drops).
    try {
      direct_subscriptions_.push_back({std::regex(channel), &handlers_.back()});
    } catch (const std::regex_error& e) {
      handlers_.pop_back();
      throw LcmOpenError("cannot subscribe to channel '" + channel + "': " + e.what());
    }
    // Matched again from the next message on (a handler running now may be the subscriber).
    direct_routes_stale_ = true;
    return;
  }
  lcm::Subscription* sub = lcm_->subscribeFunction(
      channel,
      +[](const lcm::ReceiveBuffer* rbuf, const std::string& chan, RawHandler* h) {
        (*h)(rbuf, chan);
      },
      &handlers_.back());
  if (!sub) {
    handlers_.pop_back();
    if (watch) queue_watches_.pop_back();
    throw LcmOpenError("cannot subscribe to channel '" + channel + "'");
  }
  // liblcm keeps 30 messages per subscription by default and drops the rest without a word when
  // the process falls behind (a loaded machine, a burst): replayed captures lost up to 14 % of
  // their ranges that way. --lcm-queue (20000 by default) holds several seconds of a busy lab;
  // 0 lifts the limit (liblcm's own meaning of a capacity <= 0).
  sub->setQueueCapacity(opts_.lcm_queue);
  if (!watch) return;
  // The shadow: same channels, a longer queue (4x, at least kShadowQueueMessages), counting
  // only. liblcm enqueues a message when any subscription has room and hands it to each that
  // had, so while the shadow has room every message the real queue dropped is seen here and not
  // there. (Its room is memory liblcm holds only while this process is that far behind.)
  lcm::Subscription* shadow = lcm_->subscribeFunction(
      channel, +[](const lcm::ReceiveBuffer*, const std::string&, QueueWatch* w) { ++w->seen; },
      watch);
  if (shadow)
    shadow->setQueueCapacity(opts_.lcm_queue > INT32_MAX / 4
                                 ? 0
                                 : std::max(opts_.lcm_queue * 4, kShadowQueueMessages));
}

void Node::count_sequence(const lcm::ReceiveBuffer* rbuf) {
  // The three numbered kinds, told apart by their fingerprint (any channel, decoded or not by
  // the subscriber). Keys: who numbers the sequence (docs/networking.md#loss).
  if (rbuf->data_size < 8) return;
  const int64_t hash = big_endian_i64(rbuf->data);
  const auto size = static_cast<size_t>(rbuf->data_size);
  if (hash == uwb_range_t::getHash()) {
    uwb_range_t m;
    if (decode_message(m, rbuf->data, size))
      seq_loss_.observe("uwb_range\x1f" + m.source + '\x1f' + m.tag_id + '\x1f' + m.anchor_id,
                        m.seq);
  } else if (hash == uwb_rx_t::getHash()) {
    uwb_rx_t m;
    if (decode_message(m, rbuf->data, size))
      seq_loss_.observe("uwb_rx\x1f" + m.source + '\x1f' + m.anchor_id + '\x1f' + m.sender_id,
                        m.seq);
  } else if (hash == ble_aoa_t::getHash()) {
    ble_aoa_t m;
    if (decode_message(m, rbuf->data, size))
      seq_loss_.observe("ble_aoa\x1f" + m.source + '\x1f' + m.anchor_id, m.seq);
  }
}

void Node::measure_recv_buf() {
  const uint16_t port = lcm_url_udpm_port(effective_lcm_url(opts_.lcm_url));
  if (port == 0) return;  // not udpm: no socket of ours
  // The direct receiver's socket is known; liblcm's is found by its port.
  const int granted = granted_recv_buf(direct_ ? direct_->fd() : own_udp_socket_bound_to(port));
  if (granted < 0) return;
  recv_buf_bytes_ = granted;
  if (recv_buf_requested_ > 0 && !granted_in_full(granted, recv_buf_requested_)) {
    spdlog::warn(
        "{}: the LCM receive buffer is {} bytes, not the {} asked for: net.core.rmem_max caps it, "
        "and messages will be lost under load. As root: sysctl -w net.core.rmem_max={} (and a "
        "file in /etc/sysctl.d/ to keep it; docs/networking.md#loss)",
        name_, granted / 2, recv_buf_requested_, recv_buf_requested_);
  }
}

BusLoss Node::loss() {
  BusLoss l;
  l.kernel_drops = kernel_drops_.update();
  for (const auto& w : queue_watches_) l.queue_drops += std::max<int64_t>(0, w.seen - w.delivered);
  // A fragmented message given up (a fragment lost) is lost on the way in, as a queue's drop.
  if (direct_) l.queue_drops += direct_->counts().incomplete + direct_->counts().too_large;
  l.seq = seq_loss_.counts();
  l.recv_buf_bytes = recv_buf_bytes_;
  l.recv_buf_requested = recv_buf_requested_;
  l.lcm_queue = opts_.lcm_queue;
  l.receiver = direct_ ? "direct" : "liblcm";
  return l;
}

std::string BusLoss::json() const {
  return "{\"kernel_drops\": " + std::to_string(kernel_drops) +
         ", \"queue_drops\": " + std::to_string(queue_drops) +
         ", \"lost\": " + std::to_string(kernel_drops + queue_drops) +
         ", \"seq_lost\": " + std::to_string(seq.lost) +
         ", \"seq_received\": " + std::to_string(seq.received) +
         ", \"seq_unknown\": " + std::to_string(seq.unknown) +
         ", \"seq_late\": " + std::to_string(seq.late) +
         ", \"seq_restarts\": " + std::to_string(seq.restarts) +
         ", \"recv_buf_bytes\": " + std::to_string(recv_buf_bytes) +
         ", \"recv_buf_requested\": " + std::to_string(recv_buf_requested) +
         ", \"lcm_queue\": " + std::to_string(lcm_queue) + ", \"receiver\": \"" + receiver +
         "\"}";
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
  // --busy-poll-us: soon after a message, look again without sleeping.
  if (now - last_input_ < busy_poll_) timeout_ms = 0;
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
  // Nothing to read (EAGAIN) is no signal: a signal the process took with a handler of its own
  // (ips-site's SIGHUP) wakes poll() on the signalfd before it is delivered to the handler.
  if (signalfd_siginfo si; n > 0 && (fds[1].revents & POLLIN) &&
                           read(signal_fd_, &si, sizeof si) == static_cast<ssize_t>(sizeof si)) {
    spdlog::info("{}: signal {} received, stopping", name_, si.ssi_signo);
    stop_signal_ = static_cast<int>(si.ssi_signo);
    stopping_ = true;
    return false;
  }
  if (n > 0 && (fds[0].revents & POLLIN)) {
    if (busy_poll_.count() > 0) last_input_ = std::chrono::steady_clock::now();
    if (direct_) {
      if (!read_direct()) report_error(std::string("reading the LCM socket: ") + std::strerror(errno));
    } else if (lcm_->handle() != 0) {
      report_error("lcm handle() failed");
    }
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
  degradation_published_ = false;
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

void Node::report_note(const std::string& key, const std::string& text) {
  auto [it, added] = notes_.try_emplace(key, text);
  it->second = text;
  if (added) spdlog::info("{}: {}", name_, printable(text));
}

std::string Node::note() const {
  std::string out;
  for (const auto& [key, text] : notes_) out += (out.empty() ? "" : "; ") + text;
  return out;
}

void Node::publish_health() {
  // A degradation ends once the hold has passed and a HEALTH has said it: a process stalled past
  // the hold (a loaded machine, SIGSTOP) still shows the error it reported.
  if (degraded_by_error_ && degradation_published_ &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_error_at_).count() >=
          degraded_hold_s_) {
    state_ = health_t::STATE_OK;
    degraded_by_error_ = false;
  }
  const BusLoss lost = loss();
  // Loss on the way in is an error worth seeing (degraded for a while), not just a number.
  if (const int64_t bus_lost = lost.kernel_drops + lost.queue_drops;
      bus_lost > reported_bus_loss_) {
    report_error(std::to_string(bus_lost - reported_bus_loss_) + " messages lost on the way in (" +
                 std::to_string(lost.kernel_drops) + " dropped by the kernel: receive buffer " +
                 std::to_string(lost.recv_buf_bytes) + " bytes; " +
                 std::to_string(lost.queue_drops) + " by the LCM queue of " +
                 std::to_string(opts_.lcm_queue) + "; docs/networking.md#loss)");
    reported_bus_loss_ = bus_lost;
  }
  health_t h;
  h.utime = wall_utime_now();
  h.source = name_;
  h.host = host_;
  h.pid = static_cast<int32_t>(getpid());
  h.state = state();
  degradation_published_ = true;
  h.msgs_in = counters_.msgs_in;
  h.msgs_out = counters_.msgs_out;
  h.parse_errors = counters_.parse_errors;
  h.drops = counters_.drops;
  h.last_error = last_error_;
  h.kernel_drops = lost.kernel_drops;
  h.queue_drops = lost.queue_drops;
  h.seq_lost = lost.seq.lost;
  h.recv_buf_bytes = lost.recv_buf_bytes;
  h.consistency = consistency_;
  h.note = note();
  h.version = version_text();
  h.uptime_us = std::chrono::duration_cast<std::chrono::microseconds>(
                    std::chrono::steady_clock::now() - start_time_)
                    .count();
  lcm_->publish(health_channel_, &h);
}

}  // namespace ips
