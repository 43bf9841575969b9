// HTTP requests as the apps and browsers send them (core/http_request.hpp): whole, byte by byte,
// pipelined, and every refusal with its status.
#include "core/http_request.hpp"

#include <gtest/gtest.h>

namespace ips::http {
namespace {

using State = HttpRequestParser::State;

const std::string kPost =
    "POST /data?x=1 HTTP/1.1\r\nHost: 192.168.1.10:8000\r\nContent-Type: application/json\r\n"
    "Content-Length: 13\r\n\r\n{\"payload\":[]}";

TEST(HttpRequest, ParsesAPostWhole) {
  HttpRequestParser p;
  EXPECT_EQ(p.feed(kPost), kPost.size() - 1);  // the body is 13 bytes: one byte left over
  ASSERT_EQ(p.state(), State::kRequest);
  EXPECT_EQ(p.request().method, "POST");
  EXPECT_EQ(p.request().target, "/data");
  EXPECT_EQ(p.request().query, "x=1");
  EXPECT_EQ(p.request().body, "{\"payload\":[]");
  EXPECT_TRUE(p.request().keep_alive);
}

TEST(HttpRequest, ParsesByteByByteAndPipelined) {
  const std::string one =
      "POST /data HTTP/1.1\r\nContent-Length: 2\r\n\r\n{}";
  const std::string two = "\r\nPOST /data HTTP/1.0\nContent-Length: 3\n\nabc";
  const std::string all = one + two;
  HttpRequestParser p;
  size_t i = 0;
  while (p.state() == State::kNeedMore) i += p.feed(std::string_view(all).substr(i, 1));
  ASSERT_EQ(p.state(), State::kRequest);
  EXPECT_EQ(p.request().body, "{}");
  EXPECT_EQ(i, one.size());
  p.next();
  i += p.feed(std::string_view(all).substr(i));
  ASSERT_EQ(p.state(), State::kRequest);
  EXPECT_EQ(p.request().body, "abc");
  EXPECT_FALSE(p.request().keep_alive);  // HTTP/1.0 without keep-alive
  EXPECT_EQ(i, all.size());
}

TEST(HttpRequest, SplitsTheQueryOffTheTarget) {
  const std::tuple<std::string, const char*, const char*> cases[] = {
      {"GET /api/state?trails=0&x=1 HTTP/1.1\r\n\r\n", "/api/state", "trails=0&x=1"},
      {"GET /api/state?a=%20b#top HTTP/1.1\r\n\r\n", "/api/state", "a=%20b"},
      {"GET /p? HTTP/1.1\r\n\r\n", "/p", ""},
      {"GET /p#a?b HTTP/1.1\r\n\r\n", "/p", ""},
      {"GET http://host:80/p?q=1 HTTP/1.1\r\n\r\n", "/p", "q=1"},
  };
  for (const auto& [text, target, query] : cases) {
    HttpRequestParser p;
    p.feed(text);
    ASSERT_EQ(p.state(), State::kRequest) << text;
    EXPECT_EQ(p.request().target, target) << text;
    EXPECT_EQ(p.request().query, query) << text;
  }
}

TEST(HttpRequest, ConnectionHeadersAndContinue) {
  HttpRequestParser p;
  p.feed("POST /data HTTP/1.1\r\nConnection: Close\r\nExpect: 100-continue\r\n"
         "Content-Length: 1\r\n\r\n");
  EXPECT_EQ(p.state(), State::kNeedMore);
  EXPECT_TRUE(p.in_progress());
  EXPECT_TRUE(p.take_continue());
  EXPECT_FALSE(p.take_continue());
  p.feed("x");
  ASSERT_EQ(p.state(), State::kRequest);
  EXPECT_FALSE(p.request().keep_alive);
  HttpRequestParser q;
  q.feed("GET http://host:80/data HTTP/1.0\r\nConnection: keep-alive\r\n\r\n");
  ASSERT_EQ(q.state(), State::kRequest);
  EXPECT_EQ(q.request().target, "/data");
  EXPECT_TRUE(q.request().keep_alive);
}

TEST(HttpRequest, RefusalsCarryTheirStatus) {
  HttpLimits limits;
  limits.max_head_bytes = 256;
  limits.max_body_bytes = 100;
  const std::tuple<std::string, int, const char*> cases[] = {
      {"POST /data HTTP/1.1\r\nContent-Length: 101\r\n\r\n", 413,
       "body of 101 bytes is over the limit of 100"},
      {"POST /data HTTP/1.1\r\nX: " + std::string(300, 'a'), 431,
       "request head longer than 256 bytes"},
      {"POST /data HTTP/1.1\r\n\r\n", 411, "POST without Content-Length"},
      {"POST /data HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n", 501,
       "Transfer-Encoding is not supported (send Content-Length)"},
      {"POST /data HTTP/2.0\r\n\r\n", 505, "unsupported version 'HTTP/2.0'"},
      {"POST /data FTP\r\n\r\n", 400, "unsupported version 'FTP'"},
      {"POST  /data HTTP/1.1\r\n\r\n", 400,
       "request line is not 'METHOD TARGET HTTP/1.1': 'POST  /data HTTP/1.1'"},
      {"POST /data\r\n\r\n", 400, "request line is not 'METHOD TARGET HTTP/1.1': 'POST /data'"},
      {"PO(ST /data HTTP/1.1\r\n\r\n", 400, "bad method 'PO(ST'"},
      {"POST data HTTP/1.1\r\n\r\n", 400, "bad request target 'data'"},
      {"POST /data HTTP/1.1\r\nContent-Length: -1\r\n\r\n", 400, "bad Content-Length '-1'"},
      {"POST /data HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n", 400,
       "two different Content-Length headers"},
      {"POST /data HTTP/1.1\r\nBad Header: 1\r\n\r\n", 400, "bad header line 'Bad Header: 1'"},
      {"POST /data HTTP/1.1\r\nA: 1\r\n folded\r\n\r\n", 400, "obsolete header line folding"},
      {"POST /data HTTP/1.1\r\nExpect: magic\r\n\r\n", 417, "unsupported Expect 'magic'"},
  };
  for (const auto& [text, status, why] : cases) {
    HttpRequestParser p(limits);
    p.feed(text);
    ASSERT_EQ(p.state(), State::kError) << text;
    EXPECT_EQ(p.error_status(), status) << text;
    EXPECT_EQ(p.error_reason(), why) << text;
    EXPECT_EQ(p.buffered(), 0u);
    p.next();  // stays an error: the connection is closed
    EXPECT_EQ(p.state(), State::kError);
  }
}

TEST(HttpRequest, MemoryIsBoundedByTheLimits) {
  HttpLimits limits;
  limits.max_head_bytes = 1024;
  HttpRequestParser p(limits);
  const std::string junk(1000, 'a');
  for (int i = 0; i < 10 && p.state() == State::kNeedMore; ++i) {
    p.feed(junk);
    EXPECT_LE(p.buffered(), 1024u);
  }
  EXPECT_EQ(p.error_status(), 431);
}

TEST(HttpRequest, Responses) {
  EXPECT_EQ(http_response(200, "application/json", "{}", true),
            "HTTP/1.1 200 OK\r\nContent-Type: application/json\r\nContent-Length: 2\r\n"
            "Connection: keep-alive\r\n\r\n{}");
  EXPECT_EQ(http_response(405, "text/plain", "", false, "Allow: POST\r\n"),
            "HTTP/1.1 405 Method Not Allowed\r\nContent-Type: text/plain\r\nContent-Length: 0\r\n"
            "Allow: POST\r\nConnection: close\r\n\r\n");
  // RFC 9110 section 15.3.5: a 204 has no content, and no Content-Length.
  EXPECT_EQ(http_response(204, "text/plain", "ignored", true),
            "HTTP/1.1 204 No Content\r\nContent-Type: text/plain\r\nConnection: keep-alive\r\n\r\n");
  EXPECT_STREQ(http_status_text(413), "Content Too Large");
}

TEST(HttpRequest, QueryParameters) {
  EXPECT_EQ(query_param("a=1&b=x%20y+z", "b"), "x y z");
  EXPECT_EQ(query_param("a=1&b=2&a=3", "a"), "1");  // the first
  EXPECT_EQ(query_param("flag&a=1", "flag"), "");
  EXPECT_EQ(query_param("source=ips%2Dzones&id=3", "source"), "ips-zones");
  EXPECT_FALSE(query_param("a=1", "b").has_value());
  EXPECT_FALSE(query_param("", "a").has_value());
  EXPECT_FALSE(query_param("a=%4", "a").has_value());   // cut escape
  EXPECT_FALSE(query_param("a=%zz", "a").has_value());  // not hex
  EXPECT_EQ(query_param("a=%00b", "a"), std::string("\0b", 2));
}

}  // namespace
}  // namespace ips::http
