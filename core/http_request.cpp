#include "core/http_request.hpp"

#include <algorithm>
#include <cctype>
#include <vector>

#include "core/device_text.hpp"

namespace ips::http {

namespace {

bool is_tchar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) ||
         std::string_view("!#$%&'*+-.^_`|~").find(c) != std::string_view::npos;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view trim_ows(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

bool has_token(std::string_view list, std::string_view token) {
  const std::string l = lower(list);
  size_t start = 0;
  for (;;) {
    const size_t comma = l.find(',', start);
    if (trim_ows(std::string_view(l).substr(start, comma == std::string::npos ? std::string::npos
                                                                               : comma - start)) ==
        token)
      return true;
    if (comma == std::string::npos) return false;
    start = comma + 1;
  }
}

}  // namespace

void HttpRequestParser::fail(int status, std::string reason) {
  state_ = State::kError;
  error_status_ = status;
  error_reason_ = std::move(reason);
  head_.clear();
  request_.body.clear();
  in_body_ = false;
}

void HttpRequestParser::next() {
  if (state_ == State::kError) return;  // the connection is closed after an error
  state_ = State::kNeedMore;
  head_.clear();
  in_body_ = false;
  body_length_ = 0;
  request_ = HttpRequest{};
  continue_pending_ = false;
}

size_t HttpRequestParser::feed(std::string_view bytes) {
  size_t used = 0;
  while (used < bytes.size() && state_ == State::kNeedMore) {
    if (in_body_) {
      const size_t want = body_length_ - request_.body.size();
      const size_t n = std::min(want, bytes.size() - used);
      request_.body.append(bytes.data() + used, n);
      used += n;
      if (request_.body.size() == body_length_) {
        in_body_ = false;
        state_ = State::kRequest;
      }
      continue;
    }
    const char c = bytes[used++];
    // Empty lines before a request line are ignored (RFC 9112 section 2.2).
    if (head_.empty() && (c == '\r' || c == '\n')) continue;
    if (head_.size() >= limits_.max_head_bytes) {
      fail(431, "request head longer than " + std::to_string(limits_.max_head_bytes) + " bytes");
      break;
    }
    head_ += c;
    if (c == '\n' && (head_.ends_with("\r\n\r\n") || head_.ends_with("\n\n"))) {
      if (!parse_head()) break;
      if (body_length_ == 0) {
        state_ = State::kRequest;
      } else {
        in_body_ = true;
        request_.body.reserve(body_length_);
      }
    }
  }
  return used;
}

bool HttpRequestParser::parse_head() {
  std::string_view h(head_);
  std::vector<std::string_view> lines;
  size_t start = 0;
  while (start < h.size()) {
    size_t end = h.find('\n', start);
    if (end == std::string_view::npos) end = h.size();
    std::string_view line = h.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) break;
    lines.push_back(line);
    start = end + 1;
  }
  if (lines.empty()) {
    fail(400, "empty request");
    return false;
  }
  // Request line: method SP target SP version.
  const std::string_view rl = lines[0];
  const size_t sp1 = rl.find(' ');
  const size_t sp2 = sp1 == std::string_view::npos ? sp1 : rl.find(' ', sp1 + 1);
  if (sp2 == std::string_view::npos || rl.find(' ', sp2 + 1) != std::string_view::npos) {
    fail(400, "request line is not 'METHOD TARGET HTTP/1.1': " + quoted_field(rl, 60));
    return false;
  }
  const std::string_view method = rl.substr(0, sp1);
  std::string_view target = rl.substr(sp1 + 1, sp2 - sp1 - 1);
  const std::string_view version = rl.substr(sp2 + 1);
  bool token = !method.empty();
  for (char c : method) token = token && is_tchar(c);
  if (!token) {
    fail(400, "bad method " + quoted_field(method));
    return false;
  }
  if (version != "HTTP/1.1" && version != "HTTP/1.0") {
    fail(version.starts_with("HTTP/") ? 505 : 400, "unsupported version " + quoted_field(version));
    return false;
  }
  if (target.starts_with("http://")) {  // absolute form: keep the path
    const size_t slash = target.find('/', 7);
    target = slash == std::string_view::npos ? std::string_view("/") : target.substr(slash);
  }
  if (target.empty() || target[0] != '/' || !printable_ascii(target)) {
    fail(400, "bad request target " + quoted_field(target));
    return false;
  }
  std::string_view query;
  if (const size_t hash = target.find('#'); hash != std::string_view::npos)
    target = target.substr(0, hash);
  if (const size_t q = target.find('?'); q != std::string_view::npos) {
    query = target.substr(q + 1);
    target = target.substr(0, q);
  }
  request_.method = std::string(method);
  request_.target = std::string(target);
  request_.query = std::string(query);
  request_.keep_alive = version == "HTTP/1.1";
  bool has_length = false;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string_view line = lines[i];
    if (line[0] == ' ' || line[0] == '\t') {
      fail(400, "obsolete header line folding");
      return false;
    }
    const size_t colon = line.find(':');
    bool ok = colon != std::string_view::npos && colon > 0;
    for (size_t k = 0; ok && k < colon; ++k) ok = is_tchar(line[k]);
    if (!ok) {
      fail(400, "bad header line " + quoted_field(line, 40));
      return false;
    }
    const std::string name = lower(line.substr(0, colon));
    const std::string_view value = trim_ows(line.substr(colon + 1));
    if (name == "content-length") {
      int64_t n = -1;
      if (value.empty() || value.find_first_not_of("0123456789") != std::string_view::npos ||
          !parse_integer(value, n)) {
        fail(400, "bad Content-Length " + quoted_field(value));
        return false;
      }
      if (has_length && static_cast<size_t>(n) != body_length_) {
        fail(400, "two different Content-Length headers");
        return false;
      }
      has_length = true;
      body_length_ = static_cast<size_t>(n);
    } else if (name == "transfer-encoding") {
      fail(501, "Transfer-Encoding is not supported (send Content-Length)");
      return false;
    } else if (name == "connection") {
      if (has_token(value, "close")) request_.keep_alive = false;
      else if (has_token(value, "keep-alive")) request_.keep_alive = true;
    } else if (name == "expect") {
      if (lower(value) != "100-continue") {
        fail(417, "unsupported Expect " + quoted_field(value));
        return false;
      }
      continue_pending_ = true;
    }
  }
  if (!has_length && request_.method == "POST") {
    fail(411, "POST without Content-Length");
    return false;
  }
  if (body_length_ > limits_.max_body_bytes) {
    fail(413, "body of " + std::to_string(body_length_) + " bytes is over the limit of " +
                  std::to_string(limits_.max_body_bytes));
    return false;
  }
  if (body_length_ == 0) continue_pending_ = false;
  head_.clear();
  return true;
}

const char* http_status_text(int status) {
  switch (status) {
    case 100: return "Continue";
    case 200: return "OK";
    case 204: return "No Content";
    case 304: return "Not Modified";
    case 400: return "Bad Request";
    case 404: return "Not Found";
    case 405: return "Method Not Allowed";
    case 408: return "Request Timeout";
    case 411: return "Length Required";
    case 413: return "Content Too Large";
    case 417: return "Expectation Failed";
    case 431: return "Request Header Fields Too Large";
    case 500: return "Internal Server Error";
    case 501: return "Not Implemented";
    case 503: return "Service Unavailable";
    case 505: return "HTTP Version Not Supported";
    default: return "Error";
  }
}

std::string http_response(int status, std::string_view content_type, std::string_view body,
                          bool keep_alive, std::string_view extra_headers) {
  const bool no_body = status == 204 || status == 304;
  std::string r = "HTTP/1.1 " + std::to_string(status) + " " + http_status_text(status) + "\r\n";
  r.reserve(r.size() + 120 + extra_headers.size() + (no_body ? 0 : body.size()));
  r += "Content-Type: ";
  r += content_type;
  r += "\r\n";
  if (!no_body) r += "Content-Length: " + std::to_string(body.size()) + "\r\n";
  r += extra_headers;
  r += keep_alive ? "Connection: keep-alive\r\n\r\n" : "Connection: close\r\n\r\n";
  if (!no_body) r += body;
  return r;
}

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::optional<std::string> percent_decode(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%') {
      if (i + 2 >= s.size()) return std::nullopt;
      const int hi = hex_digit(s[i + 1]), lo = hex_digit(s[i + 2]);
      if (hi < 0 || lo < 0) return std::nullopt;
      out += static_cast<char>(hi * 16 + lo);
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

}  // namespace

std::optional<std::string> query_param(std::string_view query, std::string_view name) {
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view{} : query.substr(amp + 1);
    const size_t eq = pair.find('=');
    const auto key = percent_decode(pair.substr(0, eq));
    if (!key || *key != name) continue;
    return percent_decode(eq == std::string_view::npos ? std::string_view{} : pair.substr(eq + 1));
  }
  return std::nullopt;
}

}  // namespace ips::http
