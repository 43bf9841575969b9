#pragma once
// Fields of the text that devices print on serial ports (UWB tags and listeners, XPLR-AOA
// anchors) and of capture files: plain decimal numbers ("2.55", "-68", "-30.5": the whole field,
// an optional minus sign, digits with an optional decimal point; no exponent, no '+', no spaces,
// no nan/inf), integers, and a field quoted safely for a parse error's reason. Pure.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>

namespace ips {


// True and `value` set when `field` is a finite plain decimal number.
inline bool parse_decimal(std::string_view field, double& value) {
  if (field.empty() || field.size() > 64) return false;
  // from_chars would also take "inf" and "nan": only digits, one '.', a leading '-' are ours.
  bool digit = false;
  for (size_t i = 0; i < field.size(); ++i) {
    const char c = field[i];
    if (c >= '0' && c <= '9') {
      digit = true;
    } else if (!(c == '.' || (c == '-' && i == 0))) {
      return false;
    }
  }
  if (!digit) return false;
  double v = 0;
  const auto [end, ec] =
      std::from_chars(field.data(), field.data() + field.size(), v, std::chars_format::fixed);
  if (ec != std::errc() || end != field.data() + field.size() || !std::isfinite(v)) return false;
  value = v;
  return true;
}

// True and `value` set when `field` is a decimal integer (optional '-') that fits in int64.
inline bool parse_integer(std::string_view field, int64_t& value) {
  if (field.empty() || field.size() > 20 || field[0] == '+') return false;
  int64_t v = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
  if (ec != std::errc() || end != field.data() + field.size()) return false;
  value = v;
  return true;
}

// An id a device reports or a user gives (anchor, tag, sensor): 1 to max_length characters of
// [A-Za-z0-9_.:-], so that it is safe in a channel table, a log line and a file name.
inline bool valid_device_id(std::string_view id, size_t max_length = 32) {
  if (id.empty() || id.size() > max_length) return false;
  for (char c : id)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '.' || c == ':' || c == '-'))
      return false;
  return true;
}

inline bool printable_ascii(std::string_view s) {
  for (char c : s)
    if (c < 0x20 || c > 0x7e) return false;
  return true;
}

// 'field' for a reason text: at most max_chars characters, anything but printable ASCII as '?',
// so that a garbled line cannot put control bytes into health_t or a terminal.
inline std::string quoted_field(std::string_view field, size_t max_chars = 24) {
  std::string out = "'";
  for (size_t i = 0; i < field.size() && i < max_chars; ++i) {
    const char c = field[i];
    out += (c >= 0x20 && c < 0x7f) ? c : '?';
  }
  if (field.size() > max_chars) out += "...";
  out += "'";
  return out;
}

}  // namespace ips
