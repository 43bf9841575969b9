#pragma once
// A bound UDP socket on a Node's loop: hands every datagram over whole, with its host reception
// time. Datagrams the kernel dropped because the socket's receive queue was full are counted
// (SO_RXQ_OVFL) and reported, so none is lost silently; a datagram longer than the 64 KiB read
// buffer is reported as cut.
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace ips {
class Node;
}

namespace ips::uwb_tdoa_anchors {

// "[ADDR:]PORT" (ADDR: IPv4, default 127.0.0.1, so nothing off the host reaches us unless asked
// for, e.g. 0.0.0.0:PORT). The reason when it is not.
std::string parse_udp_bind(const std::string& text, std::string& addr, uint16_t& port);

class UdpReceiver {
 public:
  struct Callbacks {
    std::function<void(std::string_view datagram, utime_t utime)> on_datagram;
    std::function<void(int64_t n)> on_dropped;  // datagrams the kernel dropped since last time
    std::function<void(size_t bytes)> on_truncated;
  };
  UdpReceiver(Node& node, Callbacks callbacks);
  ~UdpReceiver();
  UdpReceiver(const UdpReceiver&) = delete;
  UdpReceiver& operator=(const UdpReceiver&) = delete;

  // Binds and starts watching; false with the reason in `error` (e.g. address in use).
  bool open(const std::string& addr, uint16_t port, std::string& error);
  uint16_t bound_port() const { return bound_port_; }

 private:
  void on_readable();

  Node& node_;
  Callbacks callbacks_;
  int fd_ = -1;
  uint16_t bound_port_ = 0;
  uint32_t dropped_seen_ = 0;
};

}  // namespace ips::uwb_tdoa_anchors
