#include "core/udp_socket.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips {

std::string parse_udp_bind(const std::string& text, std::string& addr, uint16_t& port) {
  const size_t colon = text.rfind(':');
  const std::string a = colon == std::string::npos ? "127.0.0.1" : text.substr(0, colon);
  const std::string p = colon == std::string::npos ? text : text.substr(colon + 1);
  in_addr probe{};
  if (inet_pton(AF_INET, a.c_str(), &probe) != 1)
    return "'" + printable(a) + "' is not an IPv4 address (e.g. 127.0.0.1 or 0.0.0.0)";
  if (p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos)
    return "port '" + printable(p) + "' is not a number";
  const long v = std::stol(p);
  if (v < 1 || v > 65535) return "port " + p + " is not in 1..65535";
  addr = a;
  port = static_cast<uint16_t>(v);
  return "";
}

UdpSocket::UdpSocket(Node& node, size_t max_bytes, Callbacks callbacks)
    : node_(node), callbacks_(std::move(callbacks)), buf_(max_bytes + 1) {}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) {
    node_.unwatch_fd(fd_);
    ::close(fd_);
  }
}

bool UdpSocket::open(const std::string& addr, uint16_t port, std::string& error) {
  fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  const int on = 1;
  setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
  // A fixed queue (the kernel caps it at net.core.rmem_max) rides out bursts; beyond it datagrams
  // are dropped and counted, never buffered by us.
  const int queue_bytes = 1 << 20;
  setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &queue_bytes, sizeof queue_bytes);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(port);
  inet_pton(AF_INET, addr.c_str(), &sa.sin_addr);
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&sa), sizeof sa) != 0) {
    error = "cannot bind UDP " + addr + ":" + std::to_string(port) + ": " + std::strerror(errno);
    ::close(fd_);
    fd_ = -1;
    return false;
  }
  socklen_t len = sizeof sa;
  getsockname(fd_, reinterpret_cast<sockaddr*>(&sa), &len);
  bound_port_ = ntohs(sa.sin_port);
  node_.watch_fd(fd_, POLLIN, [this](short) { on_readable(); });
  return true;
}

void UdpSocket::on_readable() {
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(uint32_t))];
  // Bounded per wake-up so that timers, HTTP and signals are served during a flood.
  for (int i = 0; i < 256; ++i) {
    iovec iov{buf_.data(), buf_.size()};
    sockaddr_in from{};
    msghdr msg{};
    msg.msg_name = &from;
    msg.msg_namelen = sizeof from;
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
        node_.report_error(std::string("UDP receive failed: ") + std::strerror(errno));
      return;
    }
    const utime_t now = wall_utime_now();
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
        uint32_t total = 0;
        std::memcpy(&total, CMSG_DATA(c), sizeof total);
        if (total != dropped_seen_ && callbacks_.on_dropped)
          callbacks_.on_dropped(static_cast<int64_t>(total - dropped_seen_));
        dropped_seen_ = total;
      }
    }
    char text[INET_ADDRSTRLEN] = "?";
    inet_ntop(AF_INET, &from.sin_addr, text, sizeof text);
    const std::string sender(text);
    // One byte more than allowed was asked for: a datagram that filled it is too long.
    if ((msg.msg_flags & MSG_TRUNC) || static_cast<size_t>(n) >= buf_.size()) {
      if (callbacks_.on_truncated) callbacks_.on_truncated(sender);
      continue;
    }
    callbacks_.on_datagram(std::string_view(buf_.data(), static_cast<size_t>(n)), sender, now);
  }
}

}  // namespace ips
