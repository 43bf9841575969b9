#pragma once
// HTTP/1.1 requests (RFC 9112) as phone apps and browsers send them, read incrementally from one
// connection
// with bounded memory: a request head of at most max_head_bytes, a body (Content-Length only)
// of at most max_body_bytes; anything beyond is refused with the status to answer (400, 413,
// 431, 501, 505) and a reason, and the connection is then closed. Keep-alive: a request that
// does not ask for "Connection: close" (HTTP/1.1) or asks for keep-alive (HTTP/1.0) leaves the
// connection open for the next one. Pure: no I/O, never throws.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace ips::http {

struct HttpLimits {
  size_t max_head_bytes = 8192;
  size_t max_body_bytes = 1 << 20;
};

struct HttpRequest {
  std::string method;  // "POST", "GET", ...
  std::string target;  // "/data": the path, without the query or a fragment
  std::string query;   // "trails=0&x=1": what followed '?' (up to a '#'), still percent-encoded
  std::string body;
  bool keep_alive = true;
};

class HttpRequestParser {
 public:
  enum class State { kNeedMore, kRequest, kError };

  explicit HttpRequestParser(HttpLimits limits = {}) : limits_(limits) {}

  // Takes bytes off the connection; returns how many it used (the rest belong to the next
  // request: call again after take_request()). State kRequest: request() is complete.
  // kError: error_status()/error_reason() say why; the connection is to be answered and closed.
  size_t feed(std::string_view bytes);
  State state() const { return state_; }
  const HttpRequest& request() const { return request_; }
  // Forgets the finished request and gets ready for the next one on the same connection.
  void next();
  int error_status() const { return error_status_; }
  const std::string& error_reason() const { return error_reason_; }
  // True while a request has begun but not ended (bytes held).
  bool in_progress() const { return !head_.empty() || in_body_; }
  // True while the head is complete and the body is arriving.
  bool in_body() const { return in_body_; }
  // True once after a head with "Expect: 100-continue" (curl sends it for bodies over 1 KiB and
  // waits for "100 Continue" before the body); the caller answers it.
  bool take_continue() {
    const bool c = continue_pending_;
    continue_pending_ = false;
    return c;
  }
  // Bytes held now (head so far + body so far).
  size_t buffered() const { return head_.size() + request_.body.size(); }

 private:
  bool parse_head();
  void fail(int status, std::string reason);

  HttpLimits limits_;
  State state_ = State::kNeedMore;
  std::string head_;
  bool in_body_ = false;
  size_t body_length_ = 0;
  HttpRequest request_;
  bool continue_pending_ = false;
  int error_status_ = 0;
  std::string error_reason_;
};

// "HTTP/1.1 <status> <text>" with Content-Type, Content-Length, `extra_headers` (whole lines,
// each ending "\r\n", e.g. "Allow: POST\r\n"), Connection keep-alive/close, and the body. A 204 or
// 304 has neither Content-Length nor body (RFC 9110 sections 8.6, 15.3.5, 15.4.5).
std::string http_response(int status, std::string_view content_type, std::string_view body,
                          bool keep_alive, std::string_view extra_headers = {});
const char* http_status_text(int status);

// The value of `name` in a query string or form body ("a=1&b=x%20y"): percent-decoded, '+' as a
// space; the first occurrence; nullopt when absent or malformed (a bad %XX escape).
std::optional<std::string> query_param(std::string_view query, std::string_view name);

}  // namespace ips::http
