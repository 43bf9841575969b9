#include "core/http_server.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace ips::http {

namespace {
constexpr size_t kReadChunk = 16384;
// The kernel's queue of connections not yet accepted (capped by net.core.somaxconn): a burst of
// connections from a flood must not fill it, or a client's handshake waits for a retransmission
// (a second or more).
constexpr int kListenBacklog = 1024;
// Connections accepted per readiness event, to let the loop go round under a flood.
constexpr int kMaxAcceptsPerEvent = 64;
// Reads per readiness event: a client that never stops sending still lets the loop go round.
constexpr int kMaxReadsPerEvent = 4;
// A connection's output buffer keeps up to this much capacity between responses.
constexpr size_t kKeptOutputCapacity = 65536;
constexpr const char* kStreamHead =
    "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n";

std::string error_body(std::string_view reason) {
  return "{\"status\":\"error\",\"reason\":" + json_quote(reason) + "}";
}

bool would_block(int e) { return e == EAGAIN || e == EWOULDBLOCK || e == EINTR; }

std::string seconds_text(double s) {
  char text[32];
  std::snprintf(text, sizeof text, "%g s", s);
  return text;
}

// One event in the text/event-stream format (WHATWG HTML section 9.2.6): a field line per line of
// data, split where the client would split it (CR, LF or CRLF), and a blank line to dispatch.
std::string event_text(std::string_view name, std::string_view data) {
  std::string t;
  t.reserve(name.size() + data.size() + 16);
  if (!name.empty()) {
    t += "event: ";
    for (char ch : name)
      if (ch != '\r' && ch != '\n') t += ch;
    t += '\n';
  }
  size_t start = 0;
  for (;;) {
    const size_t end = data.find_first_of("\r\n", start);
    t += "data: ";
    t.append(data.substr(start, end == std::string_view::npos ? end : end - start));
    t += '\n';
    if (end == std::string_view::npos) break;
    start = end + (data[end] == '\r' && end + 1 < data.size() && data[end + 1] == '\n' ? 2 : 1);
  }
  t += '\n';
  return t;
}
}  // namespace

std::string stats_text(const HttpServerStats& s) {
  std::string t = std::to_string(s.accepted) + " accepted, " + std::to_string(s.refused) +
         " refused (no slot), " + std::to_string(s.evicted) + " evicted (" +
         std::to_string(s.evicted_readers) + " not reading, " + std::to_string(s.evicted_streams) +
         " streams), " +
         std::to_string(s.header_timeouts) + " header timeouts, " +
         std::to_string(s.request_timeouts) + " request timeouts, " +
         std::to_string(s.idle_closed) + " idle closed, " + std::to_string(s.aborted) +
         " aborted mid-request";
  if (s.refusals.empty()) return t;
  t += "; refusals:";
  const char* sep = " ";
  for (const auto& [status, n] : s.refusals) {
    t += sep + std::to_string(status) + " x" + std::to_string(n);
    sep = ", ";
  }
  return t;
}

SlotDecision decide_slot(const std::vector<SlotView>& conns, std::string_view peer,
                         size_t max_total, size_t max_per_peer,
                         const std::function<bool(size_t)>& has_unread) {
  if (max_per_peer == 0 || max_per_peer > max_total) max_per_peer = max_total;
  std::map<std::string_view, size_t> per_peer;
  for (const SlotView& c : conns) ++per_peer[c.peer];
  const auto count = [&](std::string_view p) {
    const auto found = per_peer.find(p);
    return found == per_peer.end() ? size_t{0} : found->second;
  };
  SlotDecision d;
  const bool own = count(peer) >= max_per_peer;
  if (!own && conns.size() < max_total) return d;
  std::vector<size_t> order;
  for (size_t i = 0; i < conns.size(); ++i) {
    const SlotView& c = conns[i];
    if (c.use == SlotView::Use::kBusy || (own && c.peer != peer)) continue;
    if (c.use == SlotView::Use::kStream && !own && count(c.peer) < count(peer) + 2) continue;
    order.push_back(i);
  }
  // Streams last; the peer holding the most first, then waiting before body, then the longest
  // waiting.
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const SlotView &x = conns[a], &y = conns[b];
    const bool sx = x.use == SlotView::Use::kStream, sy = y.use == SlotView::Use::kStream;
    if (sx != sy) return sy;
    const size_t nx = count(x.peer), ny = count(y.peer);
    if (nx != ny) return nx > ny;
    if (x.use != y.use) return x.use < y.use;
    if (x.waiting_s != y.waiting_s) return x.waiting_s > y.waiting_s;
    return a < b;
  });
  const std::string taken = own ? "the " + std::to_string(max_per_peer) + " connections of " +
                                      std::string(peer) + " are taken"
                                : "all " + std::to_string(max_total) + " connections are taken";
  for (size_t i : order) {
    if (has_unread && has_unread(i)) continue;
    d.evict = i;
    d.reason = taken;
    return d;
  }
  d.admit = false;
  d.reason = "more than " + std::to_string(own ? max_per_peer : max_total) + " connections" +
             (own ? " from " + std::string(peer) : std::string()) +
             " (none idle or unfinished to evict)";
  return d;
}

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

void HttpServer::route(std::string method, std::string path, Handler handler) {
  routes_[std::move(path)].handlers[std::move(method)] = std::move(handler);
}

void HttpServer::stream(std::string path, std::function<void(StreamId)> on_open) {
  routes_[std::move(path)].on_open = std::move(on_open);
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
      ::listen(listen_fd_, kListenBacklog) != 0) {
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
  // The timeouts are kept to within a quarter of the shortest.
  const double shortest = std::min({options_.header_timeout_s, options_.idle_timeout_s,
                                    options_.request_timeout_s, options_.stream_keepalive_s});
  std::weak_ptr<bool> alive = alive_;
  node_.add_timer(std::clamp(shortest / 4, 0.01, 0.5), [this, alive] {
    if (auto a = alive.lock(); a && *a) sweep();
  });
  return true;
}

void HttpServer::on_accept() {
  for (int i = 0; i < kMaxAcceptsPerEvent; ++i) {
    sockaddr_in from{};
    socklen_t len = sizeof from;
    const int fd = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&from), &len,
                             SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;
    char text[INET_ADDRSTRLEN] = "?";
    inet_ntop(AF_INET, &from.sin_addr, text, sizeof text);
    std::string why;
    if (!make_room(text, why)) {
      static const std::string busy =
          http_response(503, "application/json", error_body("too many connections"), false);
      [[maybe_unused]] const ssize_t n = ::send(fd, busy.data(), busy.size(), MSG_NOSIGNAL);
      ::close(fd);
      ++stats_.refused;
      note_refusal(503, why, text);
      continue;
    }
    ++stats_.accepted;
    conns_.emplace_back();
    const ConnIt it = std::prev(conns_.end());
    it->fd = fd;
    it->peer = text;
    it->parser = HttpRequestParser(options_.limits);
    it->accepted = it->last_activity = it->request_start = it->last_event = Clock::now();
    watch(it);
  }
}

bool HttpServer::make_room(const std::string& peer, std::string& why) {
  const auto now = Clock::now();
  // A client that has taken nothing of its response for this long is as evictable as an idle one.
  const auto stall = std::chrono::duration<double>(options_.header_timeout_s);
  std::vector<SlotView> views;
  std::vector<ConnIt> its;
  std::vector<bool> stalled;
  views.reserve(conns_.size());
  its.reserve(conns_.size());
  for (auto it = conns_.begin(); it != conns_.end(); ++it) {
    const Conn& c = *it;
    SlotView v;
    v.peer = c.peer;
    Clock::time_point since = c.last_activity;
    if (c.stream_id != 0 && !c.dead) {
      v.use = SlotView::Use::kStream;
      since = c.accepted;
    } else if (c.stream_id == 0 && !c.dead && !c.out.empty() && now - c.last_activity > stall) {
      v.use = SlotView::Use::kWaiting;  // its bytes waiting to be read are requests it pipelined
    } else if (c.stream_id != 0 || !c.out.empty() || c.close_after || c.dead) {
      v.use = SlotView::Use::kBusy;
    } else if (c.parser.in_body()) {
      v.use = SlotView::Use::kBody;
      since = c.request_start;
    } else {
      since = !c.answered ? c.accepted : c.parser.in_progress() ? c.request_start : c.last_activity;
    }
    v.waiting_s = std::chrono::duration<double>(now - since).count();
    views.push_back(v);
    its.push_back(it);
    stalled.push_back(c.stream_id == 0 && !c.out.empty() && v.use == SlotView::Use::kWaiting);
  }
  const SlotDecision d = decide_slot(
      views, peer, options_.max_connections, options_.max_connections_per_peer, [&](size_t i) {
        if (stalled[i]) return false;
        int unread = 0;
        return ::ioctl(its[i]->fd, FIONREAD, &unread) == 0 && unread > 0;
      });
  if (!d.admit) {
    why = d.reason;
    return false;
  }
  if (d.evict != SlotDecision::kNone) {
    const Conn& c = *its[d.evict];
    char waited[32];
    std::snprintf(waited, sizeof waited, "%.1f s", views[d.evict].waiting_s);
    const std::string what = c.stream_id != 0         ? "an event stream open for "
                             : stalled[d.evict]       ? "its response not taken for "
                             : c.parser.in_body()     ? "its request body incomplete after "
                             : c.parser.in_progress() ? "its request head incomplete after "
                             : !c.answered            ? "no request after "
                                                      : "idle for ";
    ++stats_.evicted;
    if (c.stream_id != 0) ++stats_.evicted_streams;
    else if (stalled[d.evict]) ++stats_.evicted_readers;
    // The evicted client is not told the other's address.
    cut(its[d.evict],
        "evicted (" + what + waited + ") for a new connection from " + peer + ": " + d.reason,
        "evicted (" + what + waited + ") for a new connection: " + d.reason);
  }
  return true;
}

void HttpServer::note_refusal(int status, const std::string& reason, const std::string& peer) {
  ++stats_.refusals[status];
  if (callbacks_.on_refused) callbacks_.on_refused(status, reason, peer);
}

void HttpServer::cut(ConnIt it, const std::string& why, const std::string& told) {
  Conn& c = *it;
  note_refusal(408, why, c.peer);
  if (c.stream_id != 0) {  // its head was sent: a comment (ignored by EventSource) says why
    std::string line = told.empty() ? why : told;
    std::replace(line.begin(), line.end(), '\n', ' ');
    c.out += ": closed: " + line + "\n\n";
  } else if (c.out.empty()) {  // else in the middle of a response (not taken): only closed
    c.out += http_response(408, "application/json", error_body(told.empty() ? why : told), false);
  }
  flush(c);
  close_soon(it);
}

void HttpServer::watch(ConnIt it) {
  const Conn& c = *it;
  // An ordinary connection is read only while no response is waiting; a stream always, to notice
  // its client closing.
  short events = 0;
  if (c.stream_id != 0 || (c.out.empty() && !c.close_after)) events |= POLLIN;
  if (!c.out.empty()) events |= POLLOUT;
  node_.watch_fd(c.fd, events, [this, it](short revents) { on_event(it, revents); });
}

void HttpServer::close(ConnIt it) {
  if (it->stream_id != 0) streams_.erase(it->stream_id);
  node_.unwatch_fd(it->fd);
  ::close(it->fd);
  conns_.erase(it);
}

void HttpServer::close_soon(ConnIt it) {
  if (&*it != busy_) {
    close(it);
    return;
  }
  it->dead = true;
  if (it->stream_id != 0) streams_.erase(it->stream_id);
}

bool HttpServer::flush(Conn& c) {
  size_t sent = 0;
  while (sent < c.out.size()) {
    const ssize_t n = ::send(c.fd, c.out.data() + sent, c.out.size() - sent, MSG_NOSIGNAL);
    if (n < 0) {
      if (!would_block(errno)) return false;
      break;
    }
    sent += static_cast<size_t>(n);
  }
  if (sent == 0) return true;
  c.last_activity = Clock::now();
  if (sent < c.out.size()) {
    c.out.erase(0, sent);
  } else if (c.out.capacity() > kKeptOutputCapacity) {
    std::string().swap(c.out);
  } else {
    c.out.clear();
  }
  return true;
}

void HttpServer::on_event(ConnIt it, short /*revents: the reads and writes say what happened*/) {
  Conn& c = *it;
  bool ok = false;
  {
    // Events sent meanwhile (on_open, a handler's broadcast) are only queued on this connection.
    busy_ = &c;
    struct ClearBusy {
      const Conn*& busy;
      ~ClearBusy() { busy = nullptr; }
    } clear_busy{busy_};
    ok = c.stream_id != 0 ? drain_stream_input(c) && flush(c) : serve(it);
  }
  if (!ok || c.dead || (c.close_after && c.out.empty())) {
    close(it);
    return;
  }
  watch(it);
}

bool HttpServer::drain_stream_input(Conn& c) {
  char buf[4096];
  for (int i = 0; i < kMaxReadsPerEvent; ++i) {
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n == 0) return false;
    if (n < 0) return would_block(errno);
  }
  return true;
}

bool HttpServer::serve(ConnIt it) {
  Conn& c = *it;
  if (!flush(c)) return false;
  int reads = 0;
  while (c.out.empty() && !c.close_after && c.stream_id == 0 && !c.dead) {
    if (c.in_used < c.in.size()) {
      if (!c.parser.in_progress()) c.request_start = Clock::now();
      c.in_used += c.parser.feed(std::string_view(c.in).substr(c.in_used));
      if (c.in_used == c.in.size()) {
        c.in.clear();
        c.in_used = 0;
      }
      answer(it);
      if (!flush(c)) return false;
      continue;
    }
    if (reads++ == kMaxReadsPerEvent) break;
    char buf[kReadChunk];
    const ssize_t n = ::recv(c.fd, buf, sizeof buf, 0);
    if (n == 0 || (n < 0 && !would_block(errno))) {
      if (c.parser.in_progress() || c.in_used < c.in.size()) ++stats_.aborted;
      return false;
    }
    if (n < 0) break;
    c.in.assign(buf, static_cast<size_t>(n));
    c.in_used = 0;
    c.last_activity = Clock::now();
  }
  if (c.stream_id != 0) {
    c.in.clear();
    c.in_used = 0;
  }
  return true;
}

void HttpServer::refuse(Conn& c, int status, const std::string& reason, bool keep_alive,
                        std::string_view extra_headers) {
  note_refusal(status, reason, c.peer);
  c.out += http_response(status, "application/json", error_body(reason), keep_alive, extra_headers);
  if (!keep_alive) c.close_after = true;
}

std::string HttpServer::not_found_hint() const {
  if (routes_.size() == 1) {
    const auto& [path, route] = *routes_.begin();
    std::string methods;
    for (const auto& [method, handler] : route.handlers)
      methods += (methods.empty() ? "" : " or ") + method;
    if (route.on_open) methods += methods.empty() ? "GET" : " or GET";
    return " (" + methods + " to " + path + ")";
  }
  constexpr size_t kShown = 8;
  std::string paths;
  size_t n = 0;
  for (const auto& [path, route] : routes_) {
    if (n++ == kShown) {
      paths += ", ...";
      break;
    }
    paths += (paths.empty() ? "" : ", ") + path;
  }
  return paths.empty() ? "" : " (paths: " + paths + ")";
}

void HttpServer::answer(ConnIt it) {
  using State = HttpRequestParser::State;
  Conn& c = *it;
  if (c.parser.state() == State::kError) {
    refuse(c, c.parser.error_status(), c.parser.error_reason(), false);
    return;
  }
  if (c.parser.take_continue()) c.out += "HTTP/1.1 100 Continue\r\n\r\n";
  if (c.parser.state() != State::kRequest) return;
  c.answered = true;
  const HttpRequest& r = c.parser.request();
  const bool head = r.method == "HEAD";
  const auto found = routes_.find(r.target);
  if (found == routes_.end()) {
    refuse(c, 404, "no such path " + printable(r.target) + not_found_hint(), r.keep_alive);
    c.parser.next();
    return;
  }
  const Route& route = found->second;
  if (route.on_open && (r.method == "GET" || head)) {
    if (head) {
      c.out += std::string(kStreamHead) + "Connection: close\r\n\r\n";
      c.close_after = true;
    } else {
      open_stream(it, found->first, route);
    }
    c.parser.next();
    return;
  }
  auto handler = route.handlers.find(r.method);
  if (handler == route.handlers.end() && head) handler = route.handlers.find("GET");
  if (handler == route.handlers.end()) {
    std::set<std::string> allowed;
    for (const auto& [method, h] : route.handlers) allowed.insert(method);
    if (allowed.contains("GET") || route.on_open) allowed.insert({"GET", "HEAD"});
    std::string allow;
    for (const std::string& m : allowed) allow += (allow.empty() ? "" : ", ") + m;
    refuse(c, 405,
           "method " + printable(r.method) + " not allowed on " + found->first + " (" + allow + ")",
           r.keep_alive, "Allow: " + allow + "\r\n");
    c.parser.next();
    return;
  }
  HttpReply reply;
  const Handler call = handler->second;  // a copy: the handler may add routes
  try {
    reply = call(r, c.peer, wall_utime_now());
  } catch (const std::exception& e) {
    refuse(c, 500, r.method + " " + found->first + " failed: " + printable(e.what()), r.keep_alive);
    c.parser.next();
    return;
  }
  std::string response = http_response(reply.status, reply.content_type, reply.body, r.keep_alive,
                                       reply.extra_headers);
  if (head) response.resize(response.find("\r\n\r\n") + 4);
  if (c.out.empty()) {
    c.out = std::move(response);
  } else {
    c.out += response;
  }
  if (!r.keep_alive) c.close_after = true;
  c.parser.next();
}

void HttpServer::open_stream(ConnIt it, const std::string& path, const Route& route) {
  Conn& c = *it;
  c.out += std::string(kStreamHead) + "\r\n";
  c.stream_id = next_stream_id_++;
  c.stream_path = path;
  c.last_event = Clock::now();
  streams_[c.stream_id] = it;
  const auto on_open = route.on_open;  // a copy: it may add routes
  try {
    on_open(c.stream_id);
  } catch (const std::exception& e) {
    const std::string why = "event stream " + path + ": opening failed: " + printable(e.what());
    const std::string peer = c.peer;
    close_soon(it);
    note_refusal(500, why, peer);
  }
}

bool HttpServer::queue_event(ConnIt it, std::string_view text) {
  Conn& c = *it;
  if (c.dead) return false;
  if (c.out.size() >= options_.max_stream_backlog_bytes) {
    ++streams_dropped_;
    const std::string peer = c.peer;
    const std::string why = "event stream " + c.stream_path + " fell behind by " +
                            std::to_string(c.out.size()) + " bytes";
    close_soon(it);
    note_refusal(503, why, peer);
    return false;
  }
  c.out += text;
  c.last_event = Clock::now();
  if (&c == busy_) return true;  // sent when its event handler returns
  if (!flush(c)) {               // the client is gone
    close(it);
    return false;
  }
  watch(it);
  return true;
}

bool HttpServer::send_event(StreamId id, std::string_view name, std::string_view data) {
  const auto found = streams_.find(id);
  return found != streams_.end() && queue_event(found->second, event_text(name, data));
}

size_t HttpServer::broadcast(const std::string& path, std::string_view name,
                             std::string_view data) {
  std::vector<StreamId> ids;
  for (const auto& [id, it] : streams_)
    if (it->stream_path == path) ids.push_back(id);
  if (ids.empty()) return 0;
  const std::string text = event_text(name, data);
  size_t sent = 0;
  for (StreamId id : ids)
    if (const auto found = streams_.find(id); found != streams_.end())
      sent += queue_event(found->second, text) ? 1 : 0;
  return sent;
}

size_t HttpServer::stream_count(const std::string& path) const {
  return static_cast<size_t>(std::count_if(streams_.begin(), streams_.end(), [&](const auto& s) {
    return s.second->stream_path == path;
  }));
}

void HttpServer::sweep() {
  const auto now = Clock::now();
  const auto header = std::chrono::duration<double>(options_.header_timeout_s);
  const auto idle = std::chrono::duration<double>(options_.idle_timeout_s);
  const auto slow = std::chrono::duration<double>(options_.request_timeout_s);
  const auto keepalive = std::chrono::duration<double>(options_.stream_keepalive_s);
  for (auto it = conns_.begin(); it != conns_.end();) {
    const auto next = std::next(it);
    Conn& c = *it;
    // The first head is due from the accept, a later one from its first byte.
    const bool awaiting_head = c.out.empty() && !c.close_after && !c.parser.in_body() &&
                               (!c.answered || c.parser.in_progress());
    const auto head_start = !c.answered ? c.accepted : c.request_start;
    if (c.stream_id != 0) {
      // A comment line (ignored by EventSource): keeps idle streams open through proxies, and a
      // dead peer shows as a send error or a growing backlog.
      if (now - c.last_event > keepalive) queue_event(it, ": keepalive\n\n");
    } else if (awaiting_head && now - head_start > header) {
      ++stats_.header_timeouts;
      cut(it, std::string(c.parser.in_progress() ? "request head incomplete" : "no request") +
                  " after " + seconds_text(options_.header_timeout_s));
    } else if (c.parser.in_progress() && now - c.request_start > slow) {
      ++stats_.request_timeouts;
      cut(it, "request not complete after " + seconds_text(options_.request_timeout_s));
    } else if (!c.parser.in_progress() && now - c.last_activity > idle) {
      ++stats_.idle_closed;
      close(it);
    }
    it = next;
  }
}

}  // namespace ips::http
