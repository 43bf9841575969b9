// The HTTP server on a real Node's loop (LCM memq) with real TCP clients on 127.0.0.1: routes,
// HEAD, 404/405, keep-alive, Server-Sent Events streams and every bound (connections, a client
// that does not read a response, a stream client that falls behind); the slot policy
// (decide_slot) alone, and on sockets: eviction, per-peer bounds (clients bound to 127.0.0.2 and
// up), header timeouts (short ones, injected through the options).
#include "core/http_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/node.hpp"

namespace ips::http {
namespace {

CommonOptions memq() {
  CommonOptions o;
  o.lcm_url = "memq://";
  return o;
}

HttpServerOptions any_port() {
  HttpServerOptions o;
  o.port = 0;
  return o;
}

// Spins the node until `done` (called once per turn) or 30 s have passed; false on the latter
// (a generous bound: a loaded machine running the sanitizer build can take a while).
bool spin_until(Node& node, const std::function<bool()>& done) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    node.spin_once(5);
  }
  return true;
}

// A non-blocking client socket; what it receives accumulates in `received`.
class Client {
 public:
  // rcvbuf_bytes > 0: a small receive buffer, so that a client that does not read is soon full.
  // source: the address to connect from (any 127.x.y.z is loopback on Linux: distinct peers).
  explicit Client(uint16_t port, int rcvbuf_bytes = 0, const char* source = nullptr) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (rcvbuf_bytes > 0)
      setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf_bytes, sizeof rcvbuf_bytes);
    if (source != nullptr) {
      sockaddr_in from{};
      from.sin_family = AF_INET;
      inet_pton(AF_INET, source, &from.sin_addr);
      EXPECT_EQ(::bind(fd_, reinterpret_cast<const sockaddr*>(&from), sizeof from), 0) << source;
    }
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(port);
    inet_pton(AF_INET, "127.0.0.1", &sa.sin_addr);
    // The kernel completes the handshake from the listen queue: no need to spin for it.
    connected_ = ::connect(fd_, reinterpret_cast<const sockaddr*>(&sa), sizeof sa) == 0;
    fcntl(fd_, F_SETFL, fcntl(fd_, F_GETFL) | O_NONBLOCK);
  }
  ~Client() { close(); }
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  bool connected() const { return connected_; }
  void send(std::string_view bytes) {
    ASSERT_EQ(::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  // Sends what the socket takes now (none once the server has closed it).
  void try_send(std::string_view bytes) {
    [[maybe_unused]] const ssize_t n = ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  // Takes what has arrived; false once the server has closed the connection.
  bool pump() {
    char buf[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n > 0) {
        received.append(buf, static_cast<size_t>(n));
        continue;
      }
      if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) eof_ = true;
      return !eof_;
    }
  }
  // Spins the node and reads until `received` holds `n` bytes or more.
  bool read_at_least(Node& node, size_t n) {
    return spin_until(node, [&] {
      pump();
      return received.size() >= n;
    });
  }
  // Spins the node and reads until `text` has arrived.
  bool read_until(Node& node, std::string_view text) {
    return spin_until(node, [&] {
      pump();
      return received.find(text) != std::string::npos;
    });
  }
  // Spins the node and reads until the server closes the connection.
  bool read_to_eof(Node& node) {
    return spin_until(node, [&] { return !pump(); });
  }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

  std::string received;

 private:
  int fd_ = -1;
  bool connected_ = false;
  bool eof_ = false;
};

struct Response {
  int status = 0;
  std::string head;  // status line and headers, up to and with the blank line
  std::string body;
};

// Takes one response off the front of `bytes` once it is complete (Content-Length, or none for
// HEAD); false while it is not.
bool take_response(std::string& bytes, Response& r, bool head_only = false) {
  const size_t end = bytes.find("\r\n\r\n");
  if (end == std::string::npos) return false;
  r.head = bytes.substr(0, end + 4);
  r.status = std::stoi(r.head.substr(9, 3));
  size_t length = 0;
  if (const size_t cl = r.head.find("Content-Length: "); cl != std::string::npos && !head_only)
    length = std::stoul(r.head.substr(cl + 16));
  if (bytes.size() < end + 4 + length) return false;
  r.body = bytes.substr(end + 4, length);
  bytes.erase(0, end + 4 + length);
  return true;
}

Response get_response(Node& node, Client& c, bool head_only = false) {
  Response r;
  EXPECT_TRUE(spin_until(node, [&] {
    c.pump();
    return take_response(c.received, r, head_only);
  })) << c.received;
  return r;
}

struct Refusal {
  int status;
  std::string reason, peer;
};

struct Fixture {
  explicit Fixture(HttpServerOptions options = any_port())
      : node("test", memq()),
        server(
            node, options,
            {.on_refused = [this](int status, const std::string& reason, const std::string& peer) {
              refused.push_back({status, reason, peer});
            }}) {}
  bool open() {
    std::string error;
    const bool ok = server.open(error);
    EXPECT_TRUE(ok) << error;
    return ok;
  }
  Node node;
  HttpServer server;
  std::vector<Refusal> refused;
};

HttpReply page(const HttpRequest&, const std::string&, utime_t) {
  return {200, "text/html; charset=utf-8", "<p>hi</p>", "Cache-Control: no-cache\r\n"};
}

TEST(HttpServer, GetRouteAnswersWithItsTypeHeadersAndBody) {
  Fixture f;
  std::string seen_peer;
  f.server.route("GET", "/", [&](const HttpRequest& r, const std::string& peer, utime_t t) {
    seen_peer = peer;
    EXPECT_GT(t, 0);
    return page(r, peer, t);
  });
  ASSERT_TRUE(f.open());
  EXPECT_NE(f.server.bound_port(), 0);
  Client c(f.server.bound_port());
  ASSERT_TRUE(c.connected());
  c.send("GET / HTTP/1.1\r\nHost: x\r\n\r\n");
  const Response r = get_response(f.node, c);
  EXPECT_EQ(r.head,
            "HTTP/1.1 200 OK\r\nContent-Type: text/html; charset=utf-8\r\nContent-Length: 9\r\n"
            "Cache-Control: no-cache\r\nConnection: keep-alive\r\n\r\n");
  EXPECT_EQ(r.body, "<p>hi</p>");
  EXPECT_EQ(seen_peer, "127.0.0.1");
  EXPECT_TRUE(f.refused.empty());
}

TEST(HttpServer, HeadHasGetsHeadersWithoutTheBodyAndKeepsTheConnection) {
  Fixture f;
  int calls = 0;
  f.server.route("GET", "/", [&](const HttpRequest& r, const std::string& peer, utime_t t) {
    ++calls;
    return page(r, peer, t);
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("HEAD / HTTP/1.1\r\n\r\n");
  const Response head = get_response(f.node, c, true);
  EXPECT_EQ(head.status, 200);
  EXPECT_NE(head.head.find("Content-Length: 9\r\n"), std::string::npos);
  // No body follows: the next bytes on the connection are the next response.
  c.send("GET / HTTP/1.1\r\n\r\n");
  const Response get = get_response(f.node, c);
  EXPECT_EQ(get.status, 200);
  EXPECT_EQ(get.body, "<p>hi</p>");
  EXPECT_EQ(c.received, "");
  EXPECT_EQ(calls, 2);
  EXPECT_EQ(f.server.connections(), 1u);
}

TEST(HttpServer, KeepAliveServesPipelinedRequestsOnOneConnectionInOrder) {
  Fixture f;
  f.server.route("POST", "/echo", [](const HttpRequest& r, const std::string&, utime_t) {
    return HttpReply{200, "text/plain", r.body, {}};
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send(
      "POST /echo HTTP/1.1\r\nContent-Length: 3\r\n\r\none"
      "POST /echo HTTP/1.1\r\nContent-Length: 3\r\nConnection: close\r\n\r\ntwo");
  const Response one = get_response(f.node, c);
  const Response two = get_response(f.node, c);
  EXPECT_EQ(one.body, "one");
  EXPECT_NE(one.head.find("Connection: keep-alive\r\n"), std::string::npos);
  EXPECT_EQ(two.body, "two");
  EXPECT_NE(two.head.find("Connection: close\r\n"), std::string::npos);
  EXPECT_TRUE(c.read_to_eof(f.node));  // closed after the request that asked for it
  EXPECT_TRUE(spin_until(f.node, [&] { return f.server.connections() == 0; }));
}

TEST(HttpServer, QueryIsNotPartOfTheMatchAndReachesTheHandler) {
  Fixture f;
  std::string target, query;
  f.server.route("GET", "/api/state", [&](const HttpRequest& r, const std::string&, utime_t) {
    target = r.target;
    query = r.query;
    return HttpReply{200, "application/json", "{}", {}};
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET /api/state?trails=0&n=2 HTTP/1.1\r\n\r\n");
  const Response r = get_response(f.node, c);
  EXPECT_EQ(r.status, 200);
  EXPECT_NE(r.head.find("Content-Type: application/json\r\n"), std::string::npos);
  EXPECT_EQ(target, "/api/state");
  EXPECT_EQ(query, "trails=0&n=2");
}

TEST(HttpServer, UnknownPathIs404WithTheRoutesInTheReason) {
  Fixture f;
  f.server.route("POST", "/data",
                 [](const HttpRequest&, const std::string&, utime_t) { return HttpReply{}; });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET /other HTTP/1.1\r\n\r\n");
  const Response r = get_response(f.node, c);
  EXPECT_EQ(r.status, 404);
  EXPECT_EQ(r.body, R"j({"status":"error","reason":"no such path /other (POST to /data)"})j");
  ASSERT_EQ(f.refused.size(), 1u);
  EXPECT_EQ(f.refused[0].status, 404);
  EXPECT_EQ(f.refused[0].reason, "no such path /other (POST to /data)");
  EXPECT_EQ(f.refused[0].peer, "127.0.0.1");
  // With several paths, the reason lists them.
  f.server.route("GET", "/", page);
  f.server.stream("/events", [](HttpServer::StreamId) {});
  c.send("GET /x HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, c).status, 404);
  EXPECT_EQ(f.refused.back().reason, "no such path /x (paths: /, /data, /events)");
  EXPECT_EQ(f.server.connections(), 1u);  // a 404 keeps the connection
}

TEST(HttpServer, MethodThePathDoesNotTakeIs405WithAllow) {
  Fixture f;
  f.server.route("POST", "/data",
                 [](const HttpRequest&, const std::string&, utime_t) { return HttpReply{}; });
  f.server.route("GET", "/", page);
  f.server.route("PUT", "/", page);
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET /data HTTP/1.1\r\n\r\n");
  const Response r = get_response(f.node, c);
  EXPECT_EQ(r.status, 405);
  EXPECT_NE(r.head.find("\r\nAllow: POST\r\n"), std::string::npos) << r.head;
  EXPECT_EQ(r.body, R"j({"status":"error","reason":"method GET not allowed on /data (POST)"})j");
  c.send("DELETE / HTTP/1.1\r\n\r\n");
  const Response d = get_response(f.node, c);
  EXPECT_EQ(d.status, 405);
  EXPECT_NE(d.head.find("\r\nAllow: GET, HEAD, PUT\r\n"), std::string::npos) << d.head;
  ASSERT_EQ(f.refused.size(), 2u);
  EXPECT_EQ(f.refused[1].reason, "method DELETE not allowed on / (GET, HEAD, PUT)");
}

TEST(HttpServer, HandlerThatThrowsGets500) {
  Fixture f;
  f.server.route("GET", "/", [](const HttpRequest&, const std::string&, utime_t) -> HttpReply {
    throw std::runtime_error("no model yet");
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, c).status, 500);
  ASSERT_EQ(f.refused.size(), 1u);
  EXPECT_EQ(f.refused[0].reason, "GET / failed: no model yet");
}

const std::string kStreamHead =
    "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\r\n";

TEST(HttpServer, EventStreamSendsItsHeadThenTheOpeningEvent) {
  Fixture f;
  std::vector<HttpServer::StreamId> opened;
  f.server.stream("/events", [&](HttpServer::StreamId id) {
    opened.push_back(id);
    EXPECT_TRUE(f.server.send_event(id, "state", "{\"a\":1}\nsecond line"));
    EXPECT_TRUE(f.server.send_event(id, "", "no name"));
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET /events HTTP/1.1\r\nAccept: text/event-stream\r\n\r\n");
  const std::string events =
      "event: state\ndata: {\"a\":1}\ndata: second line\n\ndata: no name\n\n";
  ASSERT_TRUE(c.read_at_least(f.node, kStreamHead.size() + events.size()));
  EXPECT_EQ(c.received, kStreamHead + events);
  ASSERT_EQ(opened.size(), 1u);
  EXPECT_EQ(f.server.stream_count("/events"), 1u);
  // Requests after the head are ignored; the stream stays open.
  c.send("GET /events HTTP/1.1\r\n\r\n");
  for (int i = 0; i < 5; ++i) f.node.spin_once(2);
  c.pump();
  EXPECT_EQ(c.received, kStreamHead + events);
  EXPECT_EQ(opened.size(), 1u);
  EXPECT_EQ(f.server.stream_count("/events"), 1u);
  EXPECT_TRUE(f.refused.empty());
}

TEST(HttpServer, BroadcastReachesEveryStreamAndAClosedClientIsRemoved) {
  Fixture f;
  std::vector<HttpServer::StreamId> ids;
  f.server.stream("/events", [&](HttpServer::StreamId id) { ids.push_back(id); });
  f.server.stream("/other", [](HttpServer::StreamId) {});
  ASSERT_TRUE(f.open());
  Client a(f.server.bound_port()), b(f.server.bound_port());
  a.send("GET /events HTTP/1.1\r\n\r\n");
  b.send("GET /events HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(a.read_at_least(f.node, kStreamHead.size()));
  ASSERT_TRUE(b.read_at_least(f.node, kStreamHead.size()));
  ASSERT_EQ(ids.size(), 2u);
  EXPECT_NE(ids[0], ids[1]);
  EXPECT_EQ(f.server.stream_count("/events"), 2u);
  EXPECT_EQ(f.server.stream_count("/other"), 0u);
  EXPECT_EQ(f.server.broadcast("/events", "tick", "1"), 2u);
  EXPECT_EQ(f.server.broadcast("/other", "tick", "1"), 0u);
  ASSERT_TRUE(a.read_at_least(f.node, kStreamHead.size() + 20));
  ASSERT_TRUE(b.read_at_least(f.node, kStreamHead.size() + 20));
  EXPECT_EQ(a.received, kStreamHead + "event: tick\ndata: 1\n\n");
  EXPECT_EQ(b.received, kStreamHead + "event: tick\ndata: 1\n\n");
  // The client closing is noticed without anything being sent to it.
  const HttpServer::StreamId gone = ids[0];
  a.close();
  EXPECT_TRUE(spin_until(f.node, [&] { return f.server.stream_count("/events") == 1; }));
  EXPECT_EQ(f.server.connections(), 1u);
  EXPECT_FALSE(f.server.send_event(gone, "tick", "2"));
  EXPECT_EQ(f.server.broadcast("/events", "tick", "2"), 1u);
  EXPECT_EQ(f.server.streams_dropped(), 0);
  EXPECT_TRUE(f.refused.empty());
}

TEST(HttpServer, IdleStreamGetsAKeepaliveComment) {
  HttpServerOptions o = any_port();
  o.stream_keepalive_s = 0.05;
  o.idle_timeout_s = 0.05;  // streams are exempt
  Fixture f(o);
  f.server.stream("/events", [](HttpServer::StreamId) {});
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET /events HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(c.read_until(f.node, ": keepalive\n\n"));
  EXPECT_EQ(c.received.substr(0, kStreamHead.size() + 13), kStreamHead + ": keepalive\n\n");
  EXPECT_EQ(f.server.stream_count("/events"), 1u);
}

TEST(HttpServer, StreamClientThatFallsBehindIsClosedOthersKeepTheirs) {
  HttpServerOptions o = any_port();
  o.max_stream_backlog_bytes = 64 * 1024;
  Fixture f(o);
  std::vector<HttpServer::StreamId> ids;
  f.server.stream("/events", [&](HttpServer::StreamId id) { ids.push_back(id); });
  ASSERT_TRUE(f.open());
  Client slow(f.server.bound_port(), 4096), fast(f.server.bound_port());
  slow.send("GET /events HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(spin_until(f.node, [&] { return ids.size() == 1; }));
  fast.send("GET /events HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(spin_until(f.node, [&] { return ids.size() == 2; }));
  // The kernel's buffers take the first few hundred KiB the slow client does not read; the
  // backlog bound is passed after that, whatever their size.
  const std::string event(16 * 1024, 'x');
  const auto event_size = [](const std::string& data) {
    return std::string("event: map\ndata: ").size() + data.size() + 2;
  };
  size_t fast_events = 0;
  int sent = 0;
  for (; sent < 4000 && f.server.streams_dropped() == 0; ++sent) {
    f.server.broadcast("/events", "map", event);
    f.node.spin_once(0);
    fast.pump();
  }
  ASSERT_EQ(f.server.streams_dropped(), 1) << sent << " events";
  EXPECT_FALSE(f.server.send_event(ids[0], "map", "x"));
  EXPECT_EQ(f.server.stream_count("/events"), 1u);
  EXPECT_TRUE(f.server.send_event(ids[1], "map", "last"));
  ASSERT_TRUE(fast.read_until(f.node, "data: last\n\n"));
  for (size_t at = fast.received.find("data: x"); at != std::string::npos;
       at = fast.received.find("data: x", at + event.size()))
    ++fast_events;
  EXPECT_EQ(fast_events, static_cast<size_t>(sent));  // every one, the last included
  const size_t one = event_size(event);
  ASSERT_EQ(f.refused.size(), 1u);
  EXPECT_EQ(f.refused[0].status, 503);
  const std::string prefix = "event stream /events fell behind by ";
  ASSERT_EQ(f.refused[0].reason.substr(0, prefix.size()), prefix) << f.refused[0].reason;
  const size_t behind = std::stoul(f.refused[0].reason.substr(prefix.size()));
  EXPECT_GE(behind, o.max_stream_backlog_bytes);
  EXPECT_LT(behind, o.max_stream_backlog_bytes + one);  // held at most the bound plus one event
  EXPECT_TRUE(slow.read_to_eof(f.node));
}

TEST(HttpServer, ClientNotReadingALargeResponseIsClosedAndNotServedMore) {
  HttpServerOptions o = any_port();
  o.idle_timeout_s = 0.2;
  Fixture f(o);
  int calls = 0;
  // Larger than the most the kernel buffers for a socket that sends (tcp_wmem's maximum), so
  // that part of it waits in the server.
  size_t wmem_min = 0, wmem_default = 0, wmem_max = 4 << 20;
  if (std::FILE* file = std::fopen("/proc/sys/net/ipv4/tcp_wmem", "r")) {
    [[maybe_unused]] const int n =
        std::fscanf(file, "%zu %zu %zu", &wmem_min, &wmem_default, &wmem_max);
    std::fclose(file);
  }
  const std::string big(std::max<size_t>(wmem_max * 2, 4 << 20), 'p');
  f.server.route("GET", "/big", [&](const HttpRequest&, const std::string&, utime_t) {
    ++calls;
    return HttpReply{200, "text/plain", big, {}};
  });
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port(), 4096);
  c.send("GET /big HTTP/1.1\r\n\r\nGET /big HTTP/1.1\r\n\r\nGET /big HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(spin_until(f.node, [&] { return calls == 1; }));
  // One response at a time: the next requests wait until this one has been taken.
  EXPECT_TRUE(spin_until(f.node, [&] { return f.server.connections() == 0; }));
  EXPECT_EQ(calls, 1);
}

// --- the slot policy alone ---------------------------------------------------------------------

using Use = SlotView::Use;

TEST(DecideSlot, AdmitsWhileThereIsRoom) {
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kWaiting, 9}, {"10.0.0.2", Use::kBusy, 0}};
  const SlotDecision d = decide_slot(conns, "10.0.0.3", 3, 2);
  EXPECT_TRUE(d.admit);
  EXPECT_EQ(d.evict, SlotDecision::kNone);
}

TEST(DecideSlot, FullEvictsTheLongestWaitingOfThePeerHoldingTheMost) {
  // 10.0.0.1 has waited longest, but 10.0.0.2 holds two slots.
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kWaiting, 9},
                                       {"10.0.0.2", Use::kWaiting, 1},
                                       {"10.0.0.2", Use::kWaiting, 3},
                                       {"10.0.0.3", Use::kBusy, 0}};
  const SlotDecision d = decide_slot(conns, "10.0.0.4", 4, 4);
  EXPECT_TRUE(d.admit);
  EXPECT_EQ(d.evict, 2u);
  EXPECT_EQ(d.reason, "all 4 connections are taken");
  // Peers holding as many: the longest waiting of them.
  const std::vector<SlotView> even = {{"10.0.0.1", Use::kWaiting, 2},
                                      {"10.0.0.2", Use::kWaiting, 5},
                                      {"10.0.0.3", Use::kWaiting, 0.5}};
  EXPECT_EQ(decide_slot(even, "10.0.0.4", 3, 4).evict, 1u);
}

TEST(DecideSlot, WaitingGoesBeforeABodyArriving) {
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kBody, 9}, {"10.0.0.2", Use::kWaiting, 1}};
  EXPECT_EQ(decide_slot(conns, "10.0.0.3", 2, 2).evict, 1u);
  const std::vector<SlotView> bodies = {{"10.0.0.1", Use::kBody, 9}, {"10.0.0.2", Use::kBusy, 1}};
  EXPECT_EQ(decide_slot(bodies, "10.0.0.3", 2, 2).evict, 0u);
}

TEST(DecideSlot, BusyOnesAreNeverEvictedThenTheNewOneIsRefused) {
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kBusy, 9}, {"10.0.0.2", Use::kBusy, 9}};
  const SlotDecision d = decide_slot(conns, "10.0.0.3", 2, 2);
  EXPECT_FALSE(d.admit);
  EXPECT_EQ(d.reason, "more than 2 connections (none idle or unfinished to evict)");
}

TEST(DecideSlot, APeerAtItsLimitTakesOneOfItsOwnEvenWithRoomLeft) {
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kWaiting, 1},
                                       {"10.0.0.2", Use::kWaiting, 9},
                                       {"10.0.0.1", Use::kWaiting, 3}};
  const SlotDecision d = decide_slot(conns, "10.0.0.1", 8, 2);
  EXPECT_TRUE(d.admit);
  EXPECT_EQ(d.evict, 2u);
  EXPECT_EQ(d.reason, "the 2 connections of 10.0.0.1 are taken");
  // Its own all busy: refused, though another peer's connection waits.
  const std::vector<SlotView> busy = {
      {"10.0.0.1", Use::kBusy, 1}, {"10.0.0.2", Use::kWaiting, 9}, {"10.0.0.1", Use::kBusy, 3}};
  const SlotDecision r = decide_slot(busy, "10.0.0.1", 8, 2);
  EXPECT_FALSE(r.admit);
  EXPECT_EQ(r.reason, "more than 2 connections from 10.0.0.1 (none idle or unfinished to evict)");
  // 0: no bound per peer but the total.
  EXPECT_EQ(decide_slot(conns, "10.0.0.1", 8, 0).evict, SlotDecision::kNone);
}

TEST(DecideSlot, OneWithBytesWaitingToBeReadIsSkipped) {
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kWaiting, 9},
                                       {"10.0.0.2", Use::kWaiting, 5},
                                       {"10.0.0.3", Use::kWaiting, 1}};
  std::vector<size_t> asked;
  const SlotDecision d = decide_slot(conns, "10.0.0.4", 3, 3, [&](size_t i) {
    asked.push_back(i);
    return i == 0;
  });
  EXPECT_EQ(d.evict, 1u);
  EXPECT_EQ(asked, (std::vector<size_t>{0, 1}));
  const SlotDecision none = decide_slot(conns, "10.0.0.4", 3, 3, [](size_t) { return true; });
  EXPECT_FALSE(none.admit);
}

TEST(DecideSlot, StatsText) {
  HttpServerStats s;
  s.accepted = 7;
  s.refused = 1;
  s.evicted = 2;
  s.header_timeouts = 3;
  s.request_timeouts = 4;
  EXPECT_EQ(stats_text(s),
            "7 accepted, 1 refused (no slot), 2 evicted (0 not reading, 0 streams), 3 header "
            "timeouts, 4 request timeouts, 0 idle closed, 0 aborted mid-request");
  s.evicted_readers = 1;
  s.evicted_streams = 1;
  s.idle_closed = 5;
  s.aborted = 6;
  s.refusals = {{408, 5}, {400, 2}, {503, 1}};
  EXPECT_EQ(stats_text(s),
            "7 accepted, 1 refused (no slot), 2 evicted (1 not reading, 1 streams), 3 header "
            "timeouts, 4 request timeouts, 5 idle closed, 6 aborted mid-request; refusals: 400 x2, "
            "408 x5, 503 x1");
}

TEST(DecideSlot, StreamsGoLastAndOnlyFromAPeerHoldingTwoMore) {
  // 10.0.0.1 holds three streams, 10.0.0.2 one stream and one idle connection.
  const std::vector<SlotView> conns = {{"10.0.0.1", Use::kStream, 9},
                                       {"10.0.0.1", Use::kStream, 5},
                                       {"10.0.0.2", Use::kStream, 20},
                                       {"10.0.0.1", Use::kStream, 7},
                                       {"10.0.0.2", Use::kWaiting, 1}};
  // The idle one first, whoever holds the most.
  EXPECT_EQ(decide_slot(conns, "10.0.0.3", 5, 5).evict, 4u);
  // Then the longest open stream of the peer holding the most.
  const std::vector<SlotView> streams(conns.begin(), conns.end() - 1);
  const SlotDecision d = decide_slot(streams, "10.0.0.3", 4, 4);
  EXPECT_TRUE(d.admit);
  EXPECT_EQ(d.evict, 0u);
  // Not from a peer holding fewer than two more than the new one's: one page per address
  // keeps its stream, and the new one is refused.
  const std::vector<SlotView> pages = {{"10.0.0.1", Use::kStream, 9},
                                       {"10.0.0.2", Use::kStream, 5}};
  EXPECT_FALSE(decide_slot(pages, "10.0.0.3", 2, 2).admit);
  const std::vector<SlotView> two = {{"10.0.0.1", Use::kStream, 9},
                                     {"10.0.0.1", Use::kStream, 5},
                                     {"10.0.0.3", Use::kWaiting, 1}};
  EXPECT_EQ(decide_slot(two, "10.0.0.3", 3, 3, [](size_t i) { return i == 2; }).admit, false);
  // A peer at its own limit takes its own longest open stream (a page reloaded).
  EXPECT_EQ(decide_slot(pages, "10.0.0.1", 8, 1).evict, 0u);
}

// --- slots on sockets ----------------------------------------------------------------------------

TEST(HttpServer, ANewConnectionEvictsTheLongestIdleWhenAllAreTaken) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 60;  // only eviction here, however slow the machine
  o.max_connections = 2;
  Fixture f(o);
  f.server.route("GET", "/", page);
  ASSERT_TRUE(f.open());
  Client a(f.server.bound_port(), 0, "127.0.0.2");
  ASSERT_TRUE(spin_until(f.node, [&] { return f.server.connections() == 1; }));
  Client b(f.server.bound_port(), 0, "127.0.0.3");
  ASSERT_TRUE(spin_until(f.node, [&] { return f.server.connections() == 2; }));
  Client c(f.server.bound_port());
  c.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, c).body, "<p>hi</p>");
  // a, the longest waiting, got a 408 and was closed; b is served.
  ASSERT_TRUE(a.read_to_eof(f.node));
  Response r;
  ASSERT_TRUE(take_response(a.received, r));
  EXPECT_EQ(r.status, 408);
  // Told why, but not the other client's address.
  EXPECT_NE(r.body.find("for a new connection: all 2 connections are taken"), std::string::npos)
      << r.body;
  EXPECT_EQ(r.body.find("127.0.0.1"), std::string::npos) << r.body;
  b.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, b).body, "<p>hi</p>");
  ASSERT_EQ(f.refused.size(), 1u);
  EXPECT_EQ(f.refused[0].status, 408);
  EXPECT_EQ(f.refused[0].peer, "127.0.0.2");
  const std::string prefix = "evicted (no request after ";
  EXPECT_EQ(f.refused[0].reason.substr(0, prefix.size()), prefix) << f.refused[0].reason;
  EXPECT_NE(f.refused[0].reason.find(
                ") for a new connection from 127.0.0.1: all 2 connections are taken"),
            std::string::npos)
      << f.refused[0].reason;
  EXPECT_EQ(f.server.stats().evicted, 1);
  EXPECT_EQ(f.server.stats().accepted, 3);
  EXPECT_EQ(f.server.stats().refused, 0);
}

TEST(HttpServer, ConnectionsOverTheLimitAre503WhenNoneCanBeEvicted) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 60;  // only eviction here, however slow the machine
  o.max_connections = 2;
  Fixture f(o);
  f.server.stream("/events", [](HttpServer::StreamId) {});
  ASSERT_TRUE(f.open());
  Client a(f.server.bound_port()), b(f.server.bound_port(), 0, "127.0.0.2");
  a.send("GET /events HTTP/1.1\r\n\r\n");
  b.send("GET /events HTTP/1.1\r\n\r\n");
  ASSERT_TRUE(spin_until(f.node, [&] { return f.server.stream_count("/events") == 2; }));
  Client c(f.server.bound_port(), 0, "127.0.0.3");
  ASSERT_TRUE(c.read_to_eof(f.node));
  Response r;
  ASSERT_TRUE(take_response(c.received, r));
  EXPECT_EQ(r.status, 503);
  EXPECT_EQ(r.body, R"j({"status":"error","reason":"too many connections"})j");
  ASSERT_EQ(f.refused.size(), 1u);
  EXPECT_EQ(f.refused[0].status, 503);
  EXPECT_EQ(f.refused[0].reason, "more than 2 connections (none idle or unfinished to evict)");
  EXPECT_EQ(f.refused[0].peer, "127.0.0.3");
  EXPECT_EQ(f.server.stats().refused, 1);
  EXPECT_EQ(f.server.stream_count("/events"), 2u);
}

TEST(HttpServer, APeerOverItsLimitEvictsItsOwnNotAnothers) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 60;  // only eviction here, however slow the machine
  o.max_connections = 8;
  o.max_connections_per_peer = 2;
  Fixture f(o);
  f.server.route("GET", "/", page);
  ASSERT_TRUE(f.open());
  Client other(f.server.bound_port(), 0, "127.0.0.9");  // waits longest of all
  ASSERT_TRUE(spin_until(f.node, [&] { return f.server.connections() == 1; }));
  std::vector<std::unique_ptr<Client>> flood;
  for (int i = 0; i < 6; ++i) {
    flood.push_back(std::make_unique<Client>(f.server.bound_port(), 0, "127.0.0.2"));
    ASSERT_TRUE(spin_until(f.node, [&] { return f.server.stats().accepted == i + 2; }));
  }
  EXPECT_EQ(f.server.connections(), 3u);  // other and the flood's last two
  EXPECT_EQ(f.server.stats().evicted, 4);
  for (const Refusal& r : f.refused) EXPECT_EQ(r.peer, "127.0.0.2");
  other.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, other).body, "<p>hi</p>");
  flood[5]->send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, *flood[5]).body, "<p>hi</p>");
  ASSERT_TRUE(flood[0]->read_to_eof(f.node));
}

TEST(HttpServer, AHeadNotCompleteInTimeIs408EvenDribbled) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 0.2;
  Fixture f(o);
  f.server.route("GET", "/", page);
  ASSERT_TRUE(f.open());
  const auto start = std::chrono::steady_clock::now();
  Client silent(f.server.bound_port()), dribbler(f.server.bound_port(), 0, "127.0.0.2");
  // A byte every 5 ms: never a whole head, always a byte more.
  const std::string head = "GET / HTTP/1.1\r\nHost: x\r\nX-Padding: ";
  size_t sent = 0;
  auto next_byte = start;
  ASSERT_TRUE(spin_until(f.node, [&] {
    if (std::chrono::steady_clock::now() < next_byte) return !dribbler.pump();
    next_byte += std::chrono::milliseconds(5);
    if (sent < head.size()) {
      dribbler.try_send(head.substr(sent, 1));
      ++sent;
    } else {
      dribbler.try_send("a");
    }
    return !dribbler.pump();
  }));
  ASSERT_TRUE(silent.read_to_eof(f.node));
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(200));
  Response r;
  ASSERT_TRUE(take_response(silent.received, r));
  EXPECT_EQ(r.status, 408);
  EXPECT_EQ(r.body, R"j({"status":"error","reason":"no request after 0.2 s"})j");
  ASSERT_TRUE(take_response(dribbler.received, r));
  EXPECT_EQ(r.status, 408);
  EXPECT_EQ(r.body, R"j({"status":"error","reason":"request head incomplete after 0.2 s"})j");
  EXPECT_EQ(f.server.stats().header_timeouts, 2);
  EXPECT_EQ(f.server.connections(), 0u);
}

TEST(HttpServer, HeaderTimeoutDoesNotCutAnIdleKeptAliveConnection) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 0.05;
  Fixture f(o);
  f.server.route("GET", "/", page);
  ASSERT_TRUE(f.open());
  Client c(f.server.bound_port());
  c.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, c).body, "<p>hi</p>");
  // Well past the header timeout (the sweep runs every 12.5 ms): still open, and served.
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(300);
  while (std::chrono::steady_clock::now() < until) f.node.spin_once(5);
  EXPECT_TRUE(c.pump());
  c.send("GET / HTTP/1.1\r\n\r\n");
  EXPECT_EQ(get_response(f.node, c).body, "<p>hi</p>");
  EXPECT_EQ(f.server.stats().header_timeouts, 0);
  // Then a head begun and not finished is cut, counted from its first byte.
  c.send("GET / HT");
  ASSERT_TRUE(c.read_to_eof(f.node));
  Response r;
  ASSERT_TRUE(take_response(c.received, r));
  EXPECT_EQ(r.status, 408);
  EXPECT_EQ(f.server.stats().header_timeouts, 1);
}

TEST(HttpServer, AFloodOfIdleConnectionsFromOtherPeersDoesNotStarveAClient) {
  HttpServerOptions o = any_port();
  o.header_timeout_s = 60;  // only eviction here, however slow the machine
  o.max_connections = 8;
  o.max_connections_per_peer = 4;
  Fixture f(o);
  f.server.route("GET", "/", page);
  ASSERT_TRUE(f.open());
  std::vector<std::unique_ptr<Client>> flood;
  const char* sources[] = {"127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"};
  for (int i = 0; i < 40; ++i)
    flood.push_back(std::make_unique<Client>(f.server.bound_port(), 0, sources[i % 4]));
  ASSERT_TRUE(spin_until(f.node, [&] { return f.server.stats().accepted == 40; }));
  EXPECT_EQ(f.server.connections(), 8u);
  for (int k = 0; k < 5; ++k) {
    Client c(f.server.bound_port());
    c.send("GET / HTTP/1.1\r\n\r\n");
    // More of the flood while the request is on its way.
    Client more(f.server.bound_port(), 0, sources[k % 4]);
    EXPECT_EQ(get_response(f.node, c).body, "<p>hi</p>");
  }
  EXPECT_EQ(f.server.stats().refused, 0);
}

}  // namespace
}  // namespace ips::http
