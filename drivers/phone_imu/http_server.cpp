#include "drivers/phone_imu/http_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips::phone_imu {

namespace {
constexpr size_t kReadChunk = 16384;
// Responses are small; a client that does not read them is dropped rather than buffered for.
constexpr size_t kMaxPendingOutput = 65536;

std::string error_body(std::string_view reason) {
  return "{\"status\":\"error\",\"reason\":" + json_quote(reason) + "}";
}
}  // namespace

HttpServer::HttpServer(Node& node, HttpServerOptions options, Callbacks callbacks)
    : node_(node),
      options_(std::move(options)),
      callbacks_(std::move(callbacks)),
      alive_(std::make_shared<bool>(true)) {}

HttpServer::~HttpServer() {
  *alive_ = false;
  while (!conns_.empty()) close(conns_.begin());
  if (listen_fd_ >= 0) {
    node_.unwatch_fd(listen_fd_);
    ::close(listen_fd_);
  }
}

bool HttpServer::open(std::string& error) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return false;
  }
  const int on = 1;
  setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(options_.port);
  inet_pton(AF_INET, options_.addr.c_str(), &sa.sin_addr);
  if (::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&sa), sizeof sa) != 0 ||
      ::listen(listen_fd_, 16) != 0) {
    error = "cannot listen on TCP " + options_.addr + ":" + std::to_string(options_.port) + ": " +
            std::strerror(errno);
    ::close(listen_fd_);
    listen_fd_ = -1;
    return false;
  }
  socklen_t len = sizeof sa;
  getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&sa), &len);
  bound_port_ = ntohs(sa.sin_port);
  node_.watch_fd(listen_fd_, POLLIN, [this](short) { on_accept(); });
  std::weak_ptr<bool> alive = alive_;
  node_.add_timer(0.5, [this, alive] {
    if (auto a = alive.lock(); a && *a) sweep();
  });
  return true;
}

void HttpServer::on_accept() {
  for (int i = 0; i < 16; ++i) {
    sockaddr_in from{};
    socklen_t len = sizeof from;
    const int fd = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&from), &len,
                             SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    char text[INET_ADDRSTRLEN] = "?";
    inet_ntop(AF_INET, &from.sin_addr, text, sizeof text);
    if (conns_.size() >= options_.max_connections) {
      static const std::string busy =
          http_response(503, "application/json", error_body("too many connections"), false);
      [[maybe_unused]] const ssize_t n = ::send(fd, busy.data(), busy.size(), MSG_NOSIGNAL);
      ::close(fd);
      if (callbacks_.on_refused)
        callbacks_.on_refused(503, "more than " + std::to_string(options_.max_connections) +
                                       " connections",
                              text);
      continue;
    }
    conns_.emplace_back();
    auto it = std::prev(conns_.end());
    it->fd = fd;
    it->peer = text;
    it->parser = HttpRequestParser(options_.limits);
    it->last_activity = it->request_start = Clock::now();
    watch(it);
  }
}

void HttpServer::watch(std::list<Conn>::iterator it) {
  const short events = static_cast<short>(POLLIN | (it->out.empty() ? 0 : POLLOUT));
  node_.watch_fd(it->fd, events, [this, it](short revents) { on_event(it, revents); });
}

void HttpServer::close(std::list<Conn>::iterator it) {
  node_.unwatch_fd(it->fd);
  ::close(it->fd);
  conns_.erase(it);
}

bool HttpServer::flush(Conn& c) {
  while (!c.out.empty()) {
    const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL);
    if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
    c.out.erase(0, static_cast<size_t>(n));
  }
  return true;
}

void HttpServer::send(Conn& c, int status, const std::string& body, bool keep_alive) {
  c.out += http_response(status, "application/json", body, keep_alive);
  if (!keep_alive) c.close_after = true;
}

void HttpServer::handle_requests(Conn& c) {
  using State = HttpRequestParser::State;
  if (c.parser.state() == State::kError) {
    if (callbacks_.on_refused)
      callbacks_.on_refused(c.parser.error_status(), c.parser.error_reason(), c.peer);
    send(c, c.parser.error_status(), error_body(c.parser.error_reason()), false);
    return;
  }
  if (c.parser.take_continue()) c.out += "HTTP/1.1 100 Continue\r\n\r\n";
  if (c.parser.state() != State::kRequest) return;
  const HttpRequest& r = c.parser.request();
  if (r.target != options_.path) {
    const std::string why = "no such path " + printable(r.target) + " (POST to " +
                            options_.path + ")";
    if (callbacks_.on_refused) callbacks_.on_refused(404, why, c.peer);
    send(c, 404, error_body(why), r.keep_alive);
  } else if (r.method != "POST") {
    const std::string why = "method " + printable(r.method) + " not allowed (POST)";
    if (callbacks_.on_refused) callbacks_.on_refused(405, why, c.peer);
    send(c, 405, error_body(why), r.keep_alive);
  } else {
    const HttpReply reply = callbacks_.on_post(r, c.peer, wall_utime_now());
    send(c, reply.status, reply.body, r.keep_alive);
  }
  c.parser.next();
  c.request_start = Clock::now();
}

bool HttpServer::on_event(std::list<Conn>::iterator it, short revents) {
  Conn& c = *it;
  if (revents & (POLLIN | POLLHUP | POLLERR)) {
    char buf[kReadChunk];
    // Read only while no response is waiting: a client that sends without reading is paced by
    // its own socket buffer, not by our memory.
    while (c.out.empty() && !c.close_after) {
      const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
      if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
        close(it);
        return false;
      }
      if (n < 0) break;
      c.last_activity = Clock::now();
      if (!c.parser.in_progress()) c.request_start = c.last_activity;
      std::string_view bytes(buf, static_cast<size_t>(n));
      while (!bytes.empty() && !c.close_after) {
        const size_t used = c.parser.feed(bytes);
        bytes.remove_prefix(used);
        handle_requests(c);
        if (c.parser.state() == HttpRequestParser::State::kNeedMore && used == 0) break;
      }
      if (!c.out.empty() || c.close_after) break;
    }
  }
  if (!flush(c) || c.out.size() > kMaxPendingOutput || (c.close_after && c.out.empty())) {
    close(it);
    return false;
  }
  watch(it);
  return true;
}

void HttpServer::sweep() {
  const auto now = Clock::now();
  const auto idle = std::chrono::duration<double>(options_.idle_timeout_s);
  const auto slow = std::chrono::duration<double>(options_.request_timeout_s);
  for (auto it = conns_.begin(); it != conns_.end();) {
    auto next = std::next(it);
    Conn& c = *it;
    if (c.parser.in_progress() && now - c.request_start > slow) {
      const std::string why = "request not complete after " +
                              std::to_string(static_cast<int>(options_.request_timeout_s)) + " s";
      if (callbacks_.on_refused) callbacks_.on_refused(408, why, c.peer);
      c.out += http_response(408, "application/json", error_body(why), false);
      flush(c);
      close(it);
    } else if (!c.parser.in_progress() && now - c.last_activity > idle) {
      close(it);
    }
    it = next;
  }
}

}  // namespace ips::phone_imu
