// libFuzzer target: arbitrary bytes as what an HTTP client sends ips-phone-imu (the request
// parser fed in pieces of varying size, with small limits) and every complete body as a Sensor
// Logger JSON batch. Checks that nothing crashes or throws, that memory held stays within the
// limits, that every refusal has a 4xx/5xx status and a printable reason, and that accepted
// batches hold only finite readings with times >= 0. Query strings and bodies also go through
// query_param (ips-view's POST parameters).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/http_request.hpp"
#include "drivers/phone_imu/sensor_logger_json.hpp"

namespace {
using namespace ips::phone_imu;
using ips::http::HttpLimits;
using ips::http::HttpRequestParser;
void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}
bool printable(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}
void check_batch(std::string_view body) {
  const JsonBatch b = parse_sensor_logger_batch(body, {});
  if (!b.ok) {
    check(printable(b.reason) && b.samples.empty(), "json reason");
    return;
  }
  if (b.bad_entries > 0) check(printable(b.first_bad), "entry reason");
  for (const SensorSample& s : b.samples) {
    check(s.device_us >= 0, "time");
    for (double v : s.xyz) check(std::isfinite(v), "value");
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  check_batch(bytes);  // the whole input as a body too
  HttpLimits limits;
  limits.max_head_bytes = 512;
  limits.max_body_bytes = 2048;
  HttpRequestParser p(limits);
  size_t i = 0, step = 1;
  while (i < bytes.size()) {
    const size_t n = std::min(step, bytes.size() - i);
    i += p.feed(bytes.substr(i, n));
    step = step % 7 + 1;
    check(p.buffered() <= limits.max_head_bytes + limits.max_body_bytes, "memory");
    if (p.state() == HttpRequestParser::State::kError) {
      check(p.error_status() >= 400 && p.error_status() < 600, "status");
      check(printable(p.error_reason()), "http reason");
      break;
    }
    if (p.state() == HttpRequestParser::State::kRequest) {
      check(!p.request().target.empty() && p.request().target[0] == '/', "target");
      check_batch(p.request().body);
      // ips-view's POST routes read their parameters from the query and the form body.
      for (const char* name : {"source", "id", "action", "t", "speed"}) {
        const auto q = ips::http::query_param(p.request().query, name);
        const auto f = ips::http::query_param(p.request().body, name);
        check(!q || q->size() <= p.request().query.size(), "query value");
        check(!f || f->size() <= p.request().body.size(), "form value");
      }
      p.next();
    }
  }
  return 0;
}
