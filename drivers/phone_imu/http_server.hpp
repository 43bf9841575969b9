#pragma once
// A minimal HTTP/1.1 server on a Node's loop (non-blocking sockets, no threads) for the apps that
// POST their readings: one path (e.g. /data) takes POST; other paths are 404, other methods on it
// 405; what http_request.hpp refuses gets its status (400, 411, 413, 431, 501, ...) and the
// connection is closed. Memory is bounded whatever the clients do: at most max_connections
// (more are closed at once), each holding at most one request head and body within the limits;
// a connection silent for idle_timeout_s, or whose request takes longer than request_timeout_s
// to arrive (a slow client), is closed (408 for the latter).
#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <string>

#include "core/time.hpp"
#include "drivers/phone_imu/http_request.hpp"

namespace ips {
class Node;
}

namespace ips::phone_imu {

struct HttpServerOptions {
  std::string addr = "127.0.0.1";
  uint16_t port = 8000;
  std::string path = "/data";
  HttpLimits limits;
  size_t max_connections = 8;
  double idle_timeout_s = 30.0;
  double request_timeout_s = 10.0;
};

struct HttpReply {
  int status = 200;
  std::string body;  // JSON
};

class HttpServer {
 public:
  struct Callbacks {
    // A POST to the path: the reply to send.
    std::function<HttpReply(const HttpRequest& request, const std::string& peer, utime_t utime)>
        on_post;
    // A request refused before it reached on_post (bad request, wrong path or method, too big,
    // too slow, too many connections): for counting and reporting.
    std::function<void(int status, const std::string& reason, const std::string& peer)>
        on_refused;
  };
  HttpServer(Node& node, HttpServerOptions options, Callbacks callbacks);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  bool open(std::string& error);
  uint16_t bound_port() const { return bound_port_; }
  size_t connections() const { return conns_.size(); }

 private:
  using Clock = std::chrono::steady_clock;
  struct Conn {
    int fd = -1;
    std::string peer;
    HttpRequestParser parser;
    std::string out;  // response bytes not yet sent
    bool close_after = false;
    Clock::time_point last_activity, request_start;
  };
  void on_accept();
  // false when the connection was closed (and erased).
  bool on_event(std::list<Conn>::iterator it, short revents);
  void handle_requests(Conn& c);
  void send(Conn& c, int status, const std::string& body, bool keep_alive);
  bool flush(Conn& c);
  void close(std::list<Conn>::iterator it);
  void sweep();
  void watch(std::list<Conn>::iterator it);

  Node& node_;
  HttpServerOptions options_;
  Callbacks callbacks_;
  int listen_fd_ = -1;
  uint16_t bound_port_ = 0;
  std::list<Conn> conns_;
  std::shared_ptr<bool> alive_;
};

}  // namespace ips::phone_imu
