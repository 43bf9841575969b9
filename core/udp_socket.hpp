#pragma once
// A bound UDP socket on a Node's loop: every datagram whole, with its sender's IPv4 address and
// the host reception time. Datagrams longer than max_bytes are reported as cut, not parsed;
// datagrams the kernel dropped (receive queue full, SO_RXQ_OVFL) are counted. Memory: one
// buffer of max_bytes and the kernel's queue, whatever the sender's rate.
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/time.hpp"

namespace ips {
class Node;
}

namespace ips {

// "[ADDR:]PORT" (ADDR: IPv4, default 127.0.0.1, so nothing off the host reaches us unless asked
// for, e.g. 0.0.0.0:PORT). The reason when it is not.
std::string parse_udp_bind(const std::string& text, std::string& addr, uint16_t& port);

class UdpSocket {
 public:
  struct Callbacks {
    std::function<void(std::string_view datagram, const std::string& sender, utime_t utime)>
        on_datagram;
    std::function<void(int64_t n)> on_dropped;
    std::function<void(const std::string& sender)> on_truncated;
  };
  UdpSocket(Node& node, size_t max_bytes, Callbacks callbacks);
  ~UdpSocket();
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;

  bool open(const std::string& addr, uint16_t port, std::string& error);
  uint16_t bound_port() const { return bound_port_; }

 private:
  void on_readable();
  Node& node_;
  Callbacks callbacks_;
  std::vector<char> buf_;
  int fd_ = -1;
  uint16_t bound_port_ = 0;
  uint32_t dropped_seen_ = 0;
};

}  // namespace ips
