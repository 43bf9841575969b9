#pragma once
// A minimal HTTP/1.1 server on a Node's loop (non-blocking sockets, no threads): exact-path routes
// for the phone apps that POST their readings and for a dashboard's pages and JSON, and
// Server-Sent Events streams (the WHATWG HTML "text/event-stream" format) that push to browsers.
// A path without a route is 404, a method the path does not take 405 (with Allow); what
// http_request.hpp refuses gets its status (400, 411, 413, 431, 501, ...) and the connection is
// closed.
//
// Memory is bounded whatever the clients do: at most max_connections, at most
// max_connections_per_peer of them from one IPv4 address. An ordinary connection holds at most one
// read chunk (16 KiB) of bytes not yet parsed, one request head and body within the limits, and
// one response: the next request is read only once the previous response has been taken by the
// client, however large it is.
//
// Slots cannot be starved by clients that connect and send nothing, or too little (slowloris):
//  - a request head must be complete within header_timeout_s of the connection's accept (or of the
//    request's first byte, on a kept-alive connection), else 408 and closed (a byte a second does
//    not keep it open);
//  - a whole request (head and body) within request_timeout_s of its first byte, else 408;
//  - a kept-alive connection silent for idle_timeout_s (reading nothing of a response counts as
//    silent) is closed;
//  - when a new connection finds no free slot (all taken, or its peer's all taken), it takes the
//    slot of an idle or unfinished connection (evicted with a 408): of the peer holding the most
//    connections, one idle or whose head is incomplete before one whose body is arriving, the
//    longest waiting first. One whose bytes are waiting to be read is not evicted, nor one being
//    answered, unless its client has taken nothing of the response for header_timeout_s (a slow
//    reader: then it counts as idle, and is closed without a 408). An event stream is evicted
//    only when no idle or unfinished connection is left, and only one of the new connection's
//    own address or of an address holding at least two connections more than it (so a few
//    addresses opening streams and never reading them cannot hold every slot, while one page
//    per address keeps its stream); only when none is left is the new connection refused (503).
// So a flood from a few addresses churns through its own slots; a client from another address
// gets a slot at once (one sharing its address, e.g. behind the same NAT, shares its fate).
// stats() counts what was refused (by status), evicted, timed out and aborted by the client.
//
// An event stream holds at most max_stream_backlog_bytes of events its client has not
// taken, plus one event: an event sent when that much is waiting closes the stream instead
// (counted in streams_dropped()). Streams are exempt from the idle timeout; a ": keepalive"
// comment every stream_keepalive_s keeps proxies from closing them and finds dead peers.
#include <chrono>
#include <cstdint>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/http_request.hpp"
#include "core/time.hpp"

namespace ips {
class Node;
}

namespace ips::http {

struct HttpServerOptions {
  std::string addr = "127.0.0.1";
  uint16_t port = 8000;  // 0: any free port (bound_port() says which)
  HttpLimits limits;
  size_t max_connections = 8;
  size_t max_connections_per_peer = 4;  // from one IPv4 address; 0: max_connections
  double header_timeout_s = 2.0;        // from accept (or a request's first byte) to a whole head
  double idle_timeout_s = 30.0;
  double request_timeout_s = 10.0;
  size_t max_stream_backlog_bytes = 1 << 20;  // an SSE client that falls further behind is closed
  double stream_keepalive_s = 15.0;           // ": keepalive\n\n" comment on idle streams
};

// Connections: counted since open().
struct HttpServerStats {
  int64_t accepted = 0;
  int64_t refused = 0;           // 503 at once: no slot free and none that could be freed
  int64_t evicted = 0;           // idle or unfinished, closed (408) to give a new one its slot
  int64_t evicted_readers = 0;   // of evicted: its client took nothing of a response (slow reader)
  int64_t evicted_streams = 0;   // of evicted: an event stream
  int64_t header_timeouts = 0;   // no whole request head within header_timeout_s (408)
  int64_t request_timeouts = 0;  // no whole request within request_timeout_s (408)
  int64_t idle_closed = 0;       // kept alive and silent for idle_timeout_s
  int64_t aborted = 0;           // closed or reset by the client with a request begun
  // Every refusal, by status (what Callbacks::on_refused is told): a request refused before
  // reaching a handler (400, 404, 405, 411, 413, 417, 431, 501, 505), a handler that threw
  // (500), a connection cut (408) or given no slot (503), an event stream that fell behind (503).
  std::map<int, int64_t> refusals;
};
// "N accepted, N refused (no slot), N evicted (N not reading, N streams), N header timeouts, N
// request timeouts, N idle closed, N aborted mid-request; refusals: 400 xN, 408 xN, ..." (the
// last part when any).
std::string stats_text(const HttpServerStats& s);

// The slot policy (pure, for testing): what it knows of each open connection.
struct SlotView {
  enum class Use {
    kWaiting,  // idle between requests, or nothing / part of a head received: evictable first
    kBody,     // head complete, body arriving: evictable after every kWaiting of its peer
    kBusy,     // being answered: never evicted
    kStream,   // an event stream: evicted last, and only from a peer holding 2 more (see above)
  };
  std::string_view peer;
  Use use = Use::kWaiting;
  double waiting_s = 0;  // kWaiting, kBody: for how long (since the last response or accept,
                         // or since the request's first byte); kStream: since the accept
};
struct SlotDecision {
  static constexpr size_t kNone = static_cast<size_t>(-1);
  bool admit = true;
  size_t evict = kNone;  // index into the views: close it first
  std::string reason;    // admit false: why (for the 503); evict: why it was chosen
};
// Admits a new connection from `peer` into `conns` (max_total slots, max_per_peer of one peer; 0:
// max_total), evicting one when there is no free slot (see above). has_unread(i): bytes from
// connection i are waiting to be read (it is asked of the candidates in order, to skip them).
SlotDecision decide_slot(const std::vector<SlotView>& conns, std::string_view peer,
                         size_t max_total, size_t max_per_peer,
                         const std::function<bool(size_t)>& has_unread = {});

struct HttpReply {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  // Whole header lines, each ending "\r\n" (e.g. "Cache-Control: no-store\r\n").
  std::string extra_headers;
};

class HttpServer {
 public:
  // A route's answer to a request; `peer` is the client's IPv4 address, `utime` the wall-clock
  // time the request was complete. A handler that throws gets a 500 (reported as refused).
  using Handler =
      std::function<HttpReply(const HttpRequest& request, const std::string& peer, utime_t utime)>;
  using StreamId = uint64_t;
  struct Callbacks {
    // A request refused before reaching a handler (bad request, no such path (404), a method the
    // path does not take (405, with an Allow header), too big), a handler that threw (500), an
    // event stream closed for falling behind (503), and the connections cut: no request head or
    // no whole request in time, or evicted for a new one (408), or refused for want of a slot
    // (503): for counting and reporting.
    std::function<void(int status, const std::string& reason, const std::string& peer)> on_refused;
  };

  HttpServer(Node& node, HttpServerOptions options, Callbacks callbacks = {});
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Exact-path routes (the query string is not part of the match; it is in HttpRequest::query).
  // Several methods may share a path. A GET route also answers HEAD (same headers, no body).
  void route(std::string method, std::string path, Handler handler);
  // A GET of `path` becomes a Server-Sent Events stream: "200 text/event-stream", Cache-Control:
  // no-store, no Content-Length, kept open; on_open(id) runs right after (e.g. to send the first
  // snapshot). Requests after the head on that connection are ignored; the client closing it is
  // noticed. A HEAD of `path` gets the same head and the connection is closed.
  void stream(std::string path, std::function<void(StreamId)> on_open);
  // Sends one event ("event: NAME\n" when name is not empty, then "data: LINE\n" per line of data,
  // then "\n"). False when the stream no longer exists (or was closed by this event: it fell
  // behind, or its client is gone).
  bool send_event(StreamId id, std::string_view name, std::string_view data);
  // Sends to every open stream of `path`; returns how many got it.
  size_t broadcast(const std::string& path, std::string_view name, std::string_view data);
  size_t stream_count(const std::string& path) const;

  bool open(std::string& error);
  uint16_t bound_port() const { return bound_port_; }
  size_t connections() const { return conns_.size(); }
  // Event streams closed for a backlog over max_stream_backlog_bytes.
  int64_t streams_dropped() const { return streams_dropped_; }
  const HttpServerStats& stats() const { return stats_; }

 private:
  using Clock = std::chrono::steady_clock;
  struct Route {
    std::map<std::string, Handler> handlers;  // by method
    std::function<void(StreamId)> on_open;    // set: GET is an event stream
  };
  struct Conn {
    int fd = -1;
    std::string peer;
    HttpRequestParser parser;
    std::string in;            // bytes received and not yet parsed (at most one read chunk)
    size_t in_used = 0;        // of `in`, already parsed
    std::string out;           // response or event bytes not yet sent
    bool close_after = false;  // once `out` is sent
    bool dead = false;         // to be closed when its event handler returns
    StreamId stream_id = 0;    // 0: not an event stream
    std::string stream_path;
    Clock::time_point accepted, last_activity, request_start, last_event;
    bool answered = false;  // a response has been sent (then last_activity marks the wait)
  };
  using ConnIt = std::list<Conn>::iterator;

  void on_accept();
  // Counts a refusal (stats().refusals) and tells Callbacks::on_refused.
  void note_refusal(int status, const std::string& reason, const std::string& peer);
  // A slot for a new connection from `peer` (evicting one if need be); false: refuse it.
  bool make_room(const std::string& peer, std::string& why);
  // 408, best effort, then closed: `why` for on_refused, `told` (or `why`) to the client.
  void cut(ConnIt it, const std::string& why, const std::string& told = {});
  void on_event(ConnIt it, short revents);
  // Parses and answers while no response is waiting; false when the connection is to be closed.
  bool serve(ConnIt it);
  bool drain_stream_input(Conn& c);
  void answer(ConnIt it);
  void refuse(Conn& c, int status, const std::string& reason, bool keep_alive,
              std::string_view extra_headers = {});
  void open_stream(ConnIt it, const std::string& path, const Route& route);
  // Queues an event (or comment) on a stream; false when the stream was closed instead.
  bool queue_event(ConnIt it, std::string_view text);
  bool flush(Conn& c);
  void close(ConnIt it);
  // Closes at once, or marks for closing when `it` is the connection being handled.
  void close_soon(ConnIt it);
  void sweep();
  void watch(ConnIt it);
  std::string not_found_hint() const;

  Node& node_;
  HttpServerOptions options_;
  Callbacks callbacks_;
  std::map<std::string, Route> routes_;
  int listen_fd_ = -1;
  uint16_t bound_port_ = 0;
  std::list<Conn> conns_;
  std::map<StreamId, ConnIt> streams_;
  StreamId next_stream_id_ = 1;
  int64_t streams_dropped_ = 0;
  HttpServerStats stats_;
  const Conn* busy_ = nullptr;  // the connection whose event handler is running
  std::shared_ptr<bool> alive_;
};

}  // namespace ips::http
