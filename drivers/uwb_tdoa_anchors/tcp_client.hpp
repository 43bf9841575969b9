#pragma once
// A TCP client on a Node's loop that stays connected: connects to HOST:PORT without blocking the
// loop, hands received bytes over with their host reception time, and when the server is not
// there or goes away (refused, reset, closed, a connect that takes longer than connect_timeout_s)
// says so in health_t (state degraded, last_error "HOST:PORT: <why>; reconnecting in N s") and
// tries again after a backoff that doubles from backoff_min_s to backoff_max_s; the backoff
// starts again from the minimum once a connection has delivered bytes. TCP keep-alive is on, so
// a server that vanishes without closing is noticed too (after about 30 s).
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace ips {
class Node;
}

namespace ips::uwb_tdoa_anchors {

struct TcpClientOptions {
  std::string host;  // a name or a numeric IPv4/IPv6 address
  uint16_t port = 0;
  double backoff_min_s = 0.25;
  double backoff_max_s = 8.0;
  double connect_timeout_s = 5.0;
};

// "HOST:PORT" or "[V6]:PORT" into host and port; the reason when it is not.
std::string parse_host_port(const std::string& text, std::string& host, uint16_t& port);

class TcpClient {
 public:
  struct Callbacks {
    std::function<void()> on_connect;
    std::function<void(std::string_view bytes, utime_t utime)> on_bytes;
    std::function<void(const std::string& why)> on_disconnect;  // after a connection was up
  };
  // Arms a timer on `node`; the first attempt is made by start(). Must be destroyed before the
  // node and must outlive node.run().
  TcpClient(Node& node, TcpClientOptions options, Callbacks callbacks);
  ~TcpClient();
  TcpClient(const TcpClient&) = delete;
  TcpClient& operator=(const TcpClient&) = delete;

  void start();
  bool connected() const { return connected_; }
  int64_t connections() const { return connections_; }
  std::string endpoint() const;

 private:
  using Clock = std::chrono::steady_clock;
  void attempt();
  void on_event(short revents);
  void on_connected();
  void close_and_retry(const std::string& why);
  void close_fd();

  Node& node_;
  TcpClientOptions options_;
  Callbacks callbacks_;
  int fd_ = -1;
  bool connecting_ = false;
  bool connected_ = false;
  bool got_bytes_ = false;
  int64_t connections_ = 0;
  double backoff_s_;
  Clock::time_point next_attempt_;
  Clock::time_point connect_deadline_;
  bool retry_pending_ = false;
  std::shared_ptr<bool> alive_;  // the node's timer outlives us
};

}  // namespace ips::uwb_tdoa_anchors
