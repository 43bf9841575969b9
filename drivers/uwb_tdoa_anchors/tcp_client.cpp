#include "drivers/uwb_tdoa_anchors/tcp_client.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips::uwb_tdoa_anchors {

std::string parse_host_port(const std::string& text, std::string& host, uint16_t& port) {
  size_t colon = text.rfind(':');
  if (colon == std::string::npos) return "expected HOST:PORT, e.g. 192.168.1.20:5000";
  std::string h = text.substr(0, colon);
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  if (h.empty()) return "no host before ':'";
  if (h.find(':') != std::string::npos && text.front() != '[')
    return "write an IPv6 address as [ADDR]:PORT";
  const std::string p = text.substr(colon + 1);
  if (p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos)
    return "port '" + printable(p) + "' is not a number";
  const long v = std::stol(p);
  if (v < 1 || v > 65535) return "port " + p + " is not in 1..65535";
  host = h;
  port = static_cast<uint16_t>(v);
  return "";
}

TcpClient::TcpClient(Node& node, TcpClientOptions options, Callbacks callbacks)
    : node_(node),
      options_(std::move(options)),
      callbacks_(std::move(callbacks)),
      backoff_s_(options_.backoff_min_s),
      alive_(std::make_shared<bool>(true)) {
  std::weak_ptr<bool> alive = alive_;
  node_.add_timer(0.05, [this, alive] {
    if (alive.expired()) return;
    const auto now = Clock::now();
    if (retry_pending_ && now >= next_attempt_) {
      retry_pending_ = false;
      attempt();
    } else if (connecting_ && now >= connect_deadline_) {
      close_and_retry("no answer to the connection within " +
                      std::to_string(static_cast<int>(options_.connect_timeout_s)) + " s");
    }
  });
}

TcpClient::~TcpClient() {
  alive_.reset();
  close_fd();
}

std::string TcpClient::endpoint() const {
  const bool v6 = options_.host.find(':') != std::string::npos;
  return (v6 ? "[" + options_.host + "]" : options_.host) + ":" + std::to_string(options_.port);
}

void TcpClient::start() { attempt(); }

void TcpClient::close_fd() {
  if (fd_ < 0) return;
  node_.unwatch_fd(fd_);
  ::close(fd_);
  fd_ = -1;
}

void TcpClient::close_and_retry(const std::string& why) {
  const bool was_connected = connected_;
  close_fd();
  connecting_ = connected_ = false;
  if (got_bytes_) backoff_s_ = options_.backoff_min_s;
  got_bytes_ = false;
  if (was_connected && callbacks_.on_disconnect) callbacks_.on_disconnect(why);
  char delay[32];
  std::snprintf(delay, sizeof delay, "%.2g", backoff_s_);
  node_.report_lasting_error(endpoint(),
                             endpoint() + ": " + why + "; reconnecting in " + delay + " s");
  next_attempt_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                     std::chrono::duration<double>(backoff_s_));
  retry_pending_ = true;
  backoff_s_ = std::min(backoff_s_ * 2, options_.backoff_max_s);
}

void TcpClient::attempt() {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  // A name lookup may block for a moment; anchors' servers are normally given by address.
  const int gai =
      getaddrinfo(options_.host.c_str(), std::to_string(options_.port).c_str(), &hints, &found);
  if (gai != 0 || found == nullptr) {
    close_and_retry(std::string("cannot resolve host: ") + gai_strerror(gai));
    return;
  }
  fd_ = ::socket(found->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    const int err = errno;
    freeaddrinfo(found);
    close_and_retry(std::string("socket: ") + std::strerror(err));
    return;
  }
  const int on = 1;
  setsockopt(fd_, SOL_SOCKET, SO_KEEPALIVE, &on, sizeof on);
  const int idle_s = 10, interval_s = 5, probes = 4;
  setsockopt(fd_, IPPROTO_TCP, TCP_KEEPIDLE, &idle_s, sizeof idle_s);
  setsockopt(fd_, IPPROTO_TCP, TCP_KEEPINTVL, &interval_s, sizeof interval_s);
  setsockopt(fd_, IPPROTO_TCP, TCP_KEEPCNT, &probes, sizeof probes);
  const int rc = ::connect(fd_, found->ai_addr, found->ai_addrlen);
  const int err = errno;
  freeaddrinfo(found);
  if (rc == 0) {
    on_connected();
    return;
  }
  if (err != EINPROGRESS) {
    close_and_retry(std::string("cannot connect: ") + std::strerror(err));
    return;
  }
  connecting_ = true;
  connect_deadline_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(options_.connect_timeout_s));
  node_.watch_fd(fd_, POLLOUT, [this](short revents) { on_event(revents); });
}

void TcpClient::on_connected() {
  connecting_ = false;
  connected_ = true;
  ++connections_;
  node_.end_lasting_error(endpoint());
  spdlog::info("{}: connected to {}", node_.name(), endpoint());
  if (callbacks_.on_connect) callbacks_.on_connect();
  node_.watch_fd(fd_, POLLIN, [this](short revents) { on_event(revents); });
}

void TcpClient::on_event(short revents) {
  if (connecting_) {
    int so_error = 0;
    socklen_t len = sizeof so_error;
    if (getsockopt(fd_, SOL_SOCKET, SO_ERROR, &so_error, &len) != 0) so_error = errno;
    if (so_error != 0) {
      close_and_retry(std::string("cannot connect: ") + std::strerror(so_error));
      return;
    }
    if (revents & POLLOUT) on_connected();
    return;
  }
  // Bounded per wake-up so that timers and signals are served while a server floods us.
  char buf[16384];
  for (int i = 0; i < 16 && fd_ >= 0; ++i) {
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n > 0) {
      got_bytes_ = true;
      callbacks_.on_bytes(std::string_view(buf, static_cast<size_t>(n)), wall_utime_now());
      if (static_cast<size_t>(n) < sizeof buf) return;
      continue;
    }
    if (n == 0) {
      close_and_retry("the server closed the connection");
      return;
    }
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return;
    close_and_retry(std::string("connection lost: ") + std::strerror(errno));
    return;
  }
}

}  // namespace ips::uwb_tdoa_anchors
