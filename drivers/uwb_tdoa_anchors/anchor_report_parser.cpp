#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "core/text_escape.hpp"

namespace ips::uwb_tdoa_anchors {

namespace {

constexpr size_t kFixedFields = 11;  // ids, flag, kind, group, seq, 5 counter bytes
// Values after the counter: a decimal number with at most 9 digits before the point and 9 after
// (the examples have up to 4 and 4), so no value can be huge, NaN or infinite.
constexpr size_t kMaxIntDigits = 9;
constexpr size_t kMaxFracDigits = 9;

bool is_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F');
}
int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return c - 'A' + 10;
}
bool is_digit(char c) { return c >= '0' && c <= '9'; }

// A field quoted for a reason: escaped, cut at 24 characters.
std::string quoted(std::string_view field) {
  constexpr size_t kMax = 24;
  if (field.size() > kMax) return "'" + printable(field.substr(0, kMax)) + "...'";
  return "'" + printable(field) + "'";
}

AnchorReportParse fail(std::string reason) {
  AnchorReportParse p;
  p.reason = std::move(reason);
  return p;
}

bool parse_decimal_int(std::string_view f, int32_t& out) {
  if (f.empty() || f.size() > 3) return false;
  int32_t v = 0;
  for (char c : f) {
    if (!is_digit(c)) return false;
    v = v * 10 + (c - '0');
  }
  out = v;
  return true;
}

bool parse_value(std::string_view f, double& out) {
  std::string_view body = f;
  if (!body.empty() && body.front() == '-') body.remove_prefix(1);
  const size_t dot = body.find('.');
  const std::string_view int_part = body.substr(0, dot);
  const std::string_view frac_part =
      dot == std::string_view::npos ? std::string_view() : body.substr(dot + 1);
  if (int_part.empty() || int_part.size() > kMaxIntDigits) return false;
  if (dot != std::string_view::npos && (frac_part.empty() || frac_part.size() > kMaxFracDigits))
    return false;
  for (char c : int_part)
    if (!is_digit(c)) return false;
  for (char c : frac_part)
    if (!is_digit(c)) return false;
  double v = 0;
  const auto [ptr, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
  if (ec != std::errc() || ptr != f.data() + f.size() || !std::isfinite(v)) return false;
  out = v;
  return true;
}

}  // namespace

bool is_wire_id(std::string_view text) {
  if (text.size() != 4) return false;
  for (char c : text)
    if (!is_hex(c)) return false;
  return true;
}

AnchorReportParse parse_anchor_report(std::string_view record) {
  while (!record.empty() && (record.front() == ' ' || record.front() == '\t'))
    record.remove_prefix(1);
  while (!record.empty() && (record.back() == ' ' || record.back() == '\t'))
    record.remove_suffix(1);
  if (record.empty()) return fail("empty record");
  if (record.size() > kMaxRecordBytes)
    return fail("record of " + std::to_string(record.size()) + " bytes (at most " +
                std::to_string(kMaxRecordBytes) + ")");
  if (record.front() != '|') return fail("record does not start with '|': " + quoted(record));
  if (record.size() < 2 || record.back() != '|')
    return fail("record does not end with '|' (cut short?): " + quoted(record));

  std::vector<std::string_view> fields;
  fields.reserve(20);
  const std::string_view inner = record.substr(1, record.size() - 2);
  size_t start = 0;
  while (true) {
    const size_t bar = inner.find('|', start);
    fields.push_back(inner.substr(start, bar == std::string_view::npos ? bar : bar - start));
    if (bar == std::string_view::npos) break;
    start = bar + 1;
  }
  const size_t n = fields.size();
  if (n != kFixedFields + 1 && n != kFixedFields + 1 + kDiagnosticCount)
    return fail(std::to_string(n) + " fields (expected 12: a transmit record, or 20: with 8 " +
                "diagnostics)");
  for (size_t i = 0; i < n; ++i)
    if (fields[i].empty()) return fail("field " + std::to_string(i + 1) + " is empty");

  AnchorReport r;
  if (!is_wire_id(fields[0]))
    return fail("anchor id " + quoted(fields[0]) + " is not 4 hex digits");
  if (!is_wire_id(fields[2]))
    return fail("sender id " + quoted(fields[2]) + " is not 4 hex digits");
  r.anchor_id = std::string(fields[0]);
  r.sender_id = std::string(fields[2]);

  const std::string_view flag = fields[1];
  if (flag == "E" || flag == "e")
    r.transmit = true;
  else if (flag != "A" && flag != "a")
    return fail("record flag " + quoted(flag) + " is not E (master's transmit) or A (reception)");

  const std::string_view kind = fields[3];
  if (kind == "aa" || kind == "AA")
    r.is_sync = true;
  else if (kind != "bb" && kind != "BB")
    return fail("message kind " + quoted(kind) + " is not aa (sync) or bb (blink)");

  // uwb_rx_t has no flag for 'E': the master's own record is the one that names itself (the
  // simulator's convention), so both must hold and nothing else may look like it.
  // The master's transmit record has no reception, so no diagnostics (004's 'E' example); every
  // reception has all eight. A reception cut short after its temperature is thus refused.
  const size_t expected = r.transmit ? kFixedFields + 1 : kFixedFields + 1 + kDiagnosticCount;
  if (n != expected)
    return fail(std::string(r.transmit ? "'E' (transmit) record" : "'A' (reception) record") +
                " of " + std::to_string(n) + " fields (expected " + std::to_string(expected) + ")");

  const bool self = r.anchor_id == r.sender_id;
  if (r.transmit && !r.is_sync) return fail("'E' (transmit) record of a blink (bb), not a sync");
  if (r.transmit && !self)
    return fail("'E' (transmit) record of anchor " + r.anchor_id + " names another sender " +
                r.sender_id);
  if (!r.transmit && self)
    return fail("'A' record of anchor " + r.anchor_id + " names itself as sender (only the " +
                "master's 'E' record may)");

  if (!parse_decimal_int(fields[4], r.group))
    return fail("group " + quoted(fields[4]) + " is not 1 to 3 decimal digits");
  if (!parse_decimal_int(fields[5], r.seq_in_group))
    return fail("sequence number " + quoted(fields[5]) + " is not 1 to 3 decimal digits");

  int64_t counter = 0;
  for (size_t i = 0; i < 5; ++i) {
    const std::string_view b = fields[6 + i];
    if (b.size() != 2 || !is_hex(b[0]) || !is_hex(b[1]))
      return fail("counter byte " + std::to_string(i) + " " + quoted(b) + " is not 2 hex digits");
    counter = counter << 8 | (hex_value(b[0]) << 4 | hex_value(b[1]));
  }
  r.rx_counter = counter;

  if (!parse_value(fields[kFixedFields], r.temperature_c))
    return fail("temperature " + quoted(fields[kFixedFields]) + " is not a decimal number");
  r.diagnostic_count = n - kFixedFields - 1;
  for (size_t i = 0; i < r.diagnostic_count; ++i) {
    const std::string_view f = fields[kFixedFields + 1 + i];
    if (!parse_value(f, r.diagnostics[i]))
      return fail("diagnostic value " + std::to_string(i + 1) + " " + quoted(f) +
                  " is not a decimal number");
  }
  AnchorReportParse p;
  p.ok = true;
  p.report = std::move(r);
  return p;
}

ReceivePower receive_power(const AnchorReport& r, PowerModel model) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  ReceivePower p{kNaN, kNaN};
  if (model == PowerModel::kNone || r.diagnostic_count != kDiagnosticCount) return p;
  const double a_db = model == PowerModel::kDw1000Prf16 ? 113.77 : 121.74;
  const auto& d = r.diagnostics;
  const double f1 = d[1], f2 = d[3], f3 = d[4], c = d[5], n = d[6];
  if (!(n > 0)) return p;
  const double rx = 10 * std::log10(c * 131072.0 / (n * n)) - a_db;
  const double fp = 10 * std::log10((f1 * f1 + f2 * f2 + f3 * f3) / (n * n)) - a_db;
  // The values are at most 9+9 digits, so both are finite unless a logarithm is of 0 or less.
  if (std::isfinite(rx) && c > 0) p.rx_power_dbm = static_cast<float>(rx);
  if (std::isfinite(fp)) p.fp_power_dbm = static_cast<float>(fp);
  return p;
}

uwb_rx_t to_uwb_rx(const AnchorReport& r, utime_t utime, const std::string& source,
                   const std::string& anchor_name, const std::string& sender_name,
                   PowerModel power) {
  uwb_rx_t m;
  m.utime = utime;
  m.source = source;
  m.anchor_id = anchor_name;
  m.sender_id = sender_name;
  m.is_sync = r.is_sync;
  m.seq = r.seq();
  m.rx_counter = r.rx_counter;
  m.counter_hz = kCounterHz;
  const ReceivePower p = receive_power(r, power);
  m.rx_power_dbm = p.rx_power_dbm;
  m.fp_power_dbm = p.fp_power_dbm;
  m.quality = std::numeric_limits<float>::quiet_NaN();
  return m;
}

AnchorReportEncode encode_anchor_report(const uwb_rx_t& m, double temperature_c) {
  AnchorReportEncode e;
  if (!is_wire_id(m.anchor_id)) {
    e.reason = "anchor id " + quoted(m.anchor_id) + " is not 4 hex digits";
    return e;
  }
  if (!is_wire_id(m.sender_id)) {
    e.reason = "sender id " + quoted(m.sender_id) + " is not 4 hex digits";
    return e;
  }
  const bool self = m.anchor_id == m.sender_id;
  if (self && !m.is_sync) {
    e.reason = "a blink of anchor " + m.anchor_id + " received by itself has no record";
    return e;
  }
  if (m.seq < 0) {
    e.reason = "seq " + std::to_string(m.seq) + " is negative";
    return e;
  }
  if (m.rx_counter < 0 || m.rx_counter >= kCounterModulus) {
    e.reason = "rx_counter " + std::to_string(m.rx_counter) + " is not a 40-bit counter";
    return e;
  }
  if (m.counter_hz != kCounterHz) {
    e.reason = "counter_hz " + std::to_string(m.counter_hz) + " is not 63.8976e9";
    return e;
  }
  if (!(temperature_c >= -100 && temperature_c <= 200)) {
    e.reason = "temperature " + std::to_string(temperature_c) + " C is out of range";
    return e;
  }
  const int32_t wire_seq = m.seq % kSeqModulus;
  const auto c = static_cast<uint64_t>(m.rx_counter);
  char buf[160];
  std::snprintf(buf, sizeof buf, "|%s|%c|%s|%s|%03d|%03d|%02x|%02x|%02x|%02x|%02x|%.2f|%s",
                m.anchor_id.c_str(), self ? 'E' : 'A', m.sender_id.c_str(), m.is_sync ? "aa" : "bb",
                wire_seq / 1000, wire_seq % 1000, static_cast<unsigned>(c >> 32 & 0xff),
                static_cast<unsigned>(c >> 24 & 0xff), static_cast<unsigned>(c >> 16 & 0xff),
                static_cast<unsigned>(c >> 8 & 0xff), static_cast<unsigned>(c & 0xff),
                temperature_c, self ? "" : "0|0|0|0|0|0|0|0|");
  e.ok = true;
  e.record = buf;
  return e;
}

}  // namespace ips::uwb_tdoa_anchors
