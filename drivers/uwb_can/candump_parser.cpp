#include "drivers/uwb_can/candump_parser.hpp"

#include <array>
#include <cstdio>
#include <optional>

namespace ips::uwb_can {

namespace {

constexpr uint32_t kErrorFlag = 0x20000000;  // CAN_ERR_FLAG in an 8-digit id
constexpr size_t kMaxTokens = 96;            // 64 data bytes and the fields around them
constexpr size_t kMaxInterfaceName = 15;     // IFNAMSIZ - 1

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

std::optional<uint32_t> parse_hex(std::string_view s) {
  if (s.empty() || s.size() > 8) return std::nullopt;
  uint32_t v = 0;
  for (char c : s) {
    const int h = hex_value(c);
    if (h < 0) return std::nullopt;
    v = v << 4 | static_cast<uint32_t>(h);
  }
  return v;
}

bool all_digits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  return true;
}

// Text quoted back in a reason: at most 40 characters, non-printable bytes as '?', so that a
// reason never carries control characters or a flood of garbage.
std::string quoted(std::string_view s) {
  std::string out = "'";
  for (size_t i = 0; i < s.size() && i < 40; ++i) {
    const char c = s[i];
    out += (c >= 0x20 && c <= 0x7E) ? c : '?';
  }
  if (s.size() > 40) out += "...";
  return out + "'";
}

bool is_space(char c) { return c == ' ' || c == '\t'; }

struct Tokens {
  std::array<std::string_view, kMaxTokens> t;
  size_t n = 0;
  bool overflow = false;
};

Tokens split(std::string_view line) {
  Tokens out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    if (i >= line.size()) break;
    size_t j = i;
    while (j < line.size() && !is_space(line[j])) ++j;
    if (out.n == kMaxTokens) {
      out.overflow = true;
      break;
    }
    out.t[out.n++] = line.substr(i, j - i);
    i = j;
  }
  return out;
}

CandumpLine bad(std::string reason) {
  CandumpLine out;
  out.kind = CandumpLineKind::kBad;
  out.reason = std::move(reason);
  return out;
}

// "(seconds.fraction)" without the parentheses. Returns the reason on failure, else empty.
std::string parse_timestamp(std::string_view ts, CandumpLine& out) {
  const auto dot = ts.find('.');
  if (dot == std::string_view::npos || !all_digits(ts.substr(0, dot)) ||
      !all_digits(ts.substr(dot + 1)))
    return "timestamp " + quoted(ts) + " is not seconds.fraction";
  const std::string_view sec = ts.substr(0, dot), frac = ts.substr(dot + 1);
  if (frac.size() > 9) return "timestamp " + quoted(ts) + ": more than 9 digits of fraction";
  if (sec.size() < 10) return {};  // relative (-t d, -t z): no absolute time
  // 4e18 us (core/time.hpp) is 4e12 s: anything with more digits, or more, is out of range.
  size_t first = 0;
  while (first + 1 < sec.size() && sec[first] == '0') ++first;
  if (sec.size() - first > 13) return "timestamp " + quoted(ts) + " is out of range";
  int64_t s = 0;
  for (size_t i = first; i < sec.size(); ++i) s = s * 10 + (sec[i] - '0');
  int64_t us = 0;
  for (size_t i = 0; i < 6; ++i) us = us * 10 + (i < frac.size() ? frac[i] - '0' : 0);
  if (s >= 4'000'000'000'000) return "timestamp " + quoted(ts) + " is out of range";
  const utime_t t = s * 1'000'000 + us;
  if (!plausible_utime(t)) return "timestamp " + quoted(ts) + " is out of range";
  out.has_time = true;
  out.utime = t;
  return {};
}

bool valid_interface(std::string_view s) {
  if (s.empty() || s.size() > kMaxInterfaceName) return false;
  for (char c : s)
    if (c < 0x21 || c > 0x7E || c == '#' || c == '(' || c == ')' || c == '[' || c == ']')
      return false;
  return true;
}

// Hex byte pairs with an optional '.' before each byte, into data[0..max). Returns the reason on
// failure, else empty; `len` gets the byte count.
std::string parse_data(std::string_view s, size_t max, CanFrame& f, size_t& len) {
  len = 0;
  size_t i = 0;
  size_t digits = 0;
  for (char c : s)
    if (c != '.') ++digits;
  if (digits % 2 != 0) return "odd number of hex digits in the data " + quoted(s);
  while (i < s.size()) {
    if (s[i] == '.') ++i;
    if (i >= s.size()) return "data " + quoted(s) + " ends with '.'";
    if (i + 1 >= s.size()) return "odd number of hex digits in the data " + quoted(s);
    const int hi = hex_value(s[i]), lo = hex_value(s[i + 1]);
    if (hi < 0 || lo < 0) return "data " + quoted(s) + " is not hex";
    if (len == max) return "more than " + std::to_string(max) + " data bytes in " + quoted(s);
    f.data[len++] = static_cast<uint8_t>(hi << 4 | lo);
    i += 2;
  }
  return {};
}

// The id part of a compact frame or of a screen-format line. `digits_decide`: 3 digits standard,
// 8 extended or error (compact format); otherwise up to 3 digits is standard (old candump
// versions padded ids with spaces).
std::string parse_id(std::string_view s, bool digits_decide, CanFrame& f) {
  if (digits_decide && s.size() != 3 && s.size() != 8)
    return "id " + quoted(s) + " must have 3 (standard) or 8 (extended) hex digits";
  const auto v = parse_hex(s);
  if (!v) return "id " + quoted(s) + " is not hex";
  if (s.size() <= 3) {
    if (*v > kMaxStandardId) return "standard id " + quoted(s) + " is above 7FF";
    f.id = *v;
    return {};
  }
  if (*v & ~(kErrorFlag | kMaxExtendedId)) return "id " + quoted(s) + " has bits above bit 29";
  if (*v & kErrorFlag) {
    f.error = true;
    f.id = *v & kMaxExtendedId;
  } else {
    f.extended = true;
    f.id = *v;
  }
  return {};
}

// `<id>#...` of can-utils' compact frame syntax.
std::string parse_compact(std::string_view s, CanFrame& f) {
  const auto hash = s.find('#');
  if (std::string reason = parse_id(s.substr(0, hash), true, f); !reason.empty()) return reason;
  std::string_view rest = s.substr(hash + 1);
  if (rest.size() >= 2 && rest[0] == '#' && rest[1] == '#')
    return "CAN XL frames (###) are not supported";
  if (!rest.empty() && (rest[0] == 'R' || rest[0] == 'r')) {
    if (f.error) return "an error frame cannot be a remote request";
    f.remote = true;
    rest.remove_prefix(1);
    if (!rest.empty() && rest[0] >= '0' && rest[0] <= '8') {
      f.len = static_cast<uint8_t>(rest[0] - '0');
      rest.remove_prefix(1);
    }
    if (rest.size() == 2 && rest[0] == '_' && f.len == 8 && hex_value(rest[1]) >= 9) {
      f.len8_dlc = static_cast<uint8_t>(hex_value(rest[1]));
      rest.remove_prefix(2);
    }
    if (!rest.empty()) return "unexpected " + quoted(rest) + " after a remote request";
    return {};
  }
  size_t len = 0;
  if (!rest.empty() && rest[0] == '#') {
    if (f.error) return "an error frame cannot be CAN FD";
    if (rest.size() < 2 || hex_value(rest[1]) < 0) return "CAN FD frame without a flags digit";
    f.fd = true;
    f.fd_flags = static_cast<uint8_t>(hex_value(rest[1]));
    if (std::string reason = parse_data(rest.substr(2), kMaxFdLen, f, len); !reason.empty())
      return reason;
    if (!valid_fd_len(static_cast<unsigned>(len)))
      return std::to_string(len) +
             " bytes is not a CAN FD length (0..8, 12, 16, 20, 24, 32, 48, 64)";
    f.len = static_cast<uint8_t>(len);
    return {};
  }
  const auto underscore = rest.find('_');
  if (std::string reason = parse_data(rest.substr(0, underscore), kMaxClassicLen, f, len);
      !reason.empty())
    return reason;
  f.len = static_cast<uint8_t>(len);
  if (underscore != std::string_view::npos) {
    const std::string_view dlc = rest.substr(underscore + 1);
    if (len != 8 || dlc.size() != 1 || hex_value(dlc[0]) < 9)
      return "raw DLC " + quoted(rest.substr(underscore)) + ": only _9.._F after 8 data bytes";
    f.len8_dlc = static_cast<uint8_t>(hex_value(dlc[0]));
  }
  return {};
}

// The screen format after the interface: [RX|TX flag flag] id [len] bytes... [ascii|ERRORFRAME]
std::string parse_screen(const Tokens& tk, size_t i, CanFrame& f) {
  if (i < tk.n && (tk.t[i] == "RX" || tk.t[i] == "TX")) {
    if (i + 2 >= tk.n) return "truncated line after " + std::string(tk.t[i]);
    for (size_t k = i + 1; k <= i + 2; ++k)
      if (tk.t[k] != "-" && tk.t[k] != "B" && tk.t[k] != "E")
        return "unexpected " + quoted(tk.t[k]) + " in the -x fields";
    i += 3;
  }
  if (i >= tk.n) return "truncated line: no CAN id";
  if (std::string reason = parse_id(tk.t[i], false, f); !reason.empty()) return reason;
  ++i;
  if (i >= tk.n) return "truncated line: no [length] after the id";
  const std::string_view lt = tk.t[i++];
  if (lt.size() < 3 || lt.front() != '[' || lt.back() != ']' ||
      !all_digits(lt.substr(1, lt.size() - 2)) || lt.size() > 4)
    return "length " + quoted(lt) + " is not [N] or [NN]";
  const unsigned n = lt.size() == 3 ? static_cast<unsigned>(lt[1] - '0')
                                    : static_cast<unsigned>((lt[1] - '0') * 10 + (lt[2] - '0'));
  f.fd = lt.size() == 4;
  if (f.fd ? !valid_fd_len(n) : n > kMaxClassicLen)
    return "length " + quoted(lt) + " is not a " + std::string(f.fd ? "CAN FD" : "CAN") + " length";
  if (f.fd && f.error) return "an error frame cannot be CAN FD";
  f.len = static_cast<uint8_t>(n);
  if (!f.fd && i < tk.n && tk.t[i] == "remote") {
    if (f.error) return "an error frame cannot be a remote request";
    if (i + 1 >= tk.n || tk.t[i + 1] != "request" || i + 2 != tk.n)
      return "unexpected text after 'remote'";
    f.remote = true;
    return {};
  }
  for (unsigned b = 0; b < n; ++b, ++i) {
    if (i >= tk.n)
      return "DLC mismatch: length " + std::to_string(n) + " but " + std::to_string(b) +
             " data bytes";
    const std::string_view byte = tk.t[i];
    if (byte.size() != 2 || hex_value(byte[0]) < 0 || hex_value(byte[1]) < 0)
      return "data byte " + quoted(byte) + " is not two hex digits (length " + std::to_string(n) +
             ", DLC mismatch?)";
    f.data[b] = static_cast<uint8_t>(hex_value(byte[0]) << 4 | hex_value(byte[1]));
  }
  if (i < tk.n) {
    const std::string_view extra = tk.t[i];
    const bool ascii = extra.front() == '\'' || extra.front() == '`';
    const bool marker = f.error && extra == "ERRORFRAME" && i + 1 == tk.n;
    if (!ascii && !marker)
      return "unexpected " + quoted(extra) + " after " + std::to_string(n) + " data bytes";
  }
  return {};
}

}  // namespace

CandumpLine parse_candump_line(std::string_view line) {
  if (line.size() > kMaxCandumpLineBytes)
    return bad("line longer than " + std::to_string(kMaxCandumpLineBytes) + " bytes");
  while (!line.empty() && (is_space(line.back()) || line.back() == '\r')) line.remove_suffix(1);
  CandumpLine out;
  if (line.find_first_not_of(" \t") == std::string_view::npos) {
    out.kind = CandumpLineKind::kEmpty;
    return out;
  }
  if (line.front() == '\t') {
    out.kind = CandumpLineKind::kNote;
    return out;
  }
  if (line.substr(0, 10) == "DROPCOUNT:") {
    const Tokens tk = split(line.substr(10));
    if (tk.n >= 2 && tk.t[0] == "dropped" && all_digits(tk.t[1]) && tk.t[1].size() <= 9) {
      out.kind = CandumpLineKind::kDropCount;
      for (char c : tk.t[1]) out.dropped = out.dropped * 10 + static_cast<uint64_t>(c - '0');
      return out;
    }
    return bad("DROPCOUNT line without a count");
  }
  const Tokens tk = split(line);
  if (tk.overflow) return bad("too many fields");
  size_t i = 0;
  if (tk.t[0].front() == '(') {
    if (tk.t[0].back() == ')' && tk.t[0].size() >= 2) {
      if (std::string reason = parse_timestamp(tk.t[0].substr(1, tk.t[0].size() - 2), out);
          !reason.empty())
        return bad(reason);
      i = 1;
    } else if (tk.n >= 2 && tk.t[1].back() == ')') {
      i = 2;  // -t A: "(2015-07-10 08:17:32.249713)", local time: no absolute time
    } else {
      return bad("timestamp " + quoted(tk.t[0]) + " has no closing ')'");
    }
  }
  if (i >= tk.n) return bad("truncated line: no interface");
  if (tk.t[i].find('#') != std::string_view::npos) return bad("no interface name before the frame");
  if (!valid_interface(tk.t[i])) return bad("interface name " + quoted(tk.t[i]) + " is not valid");
  out.interface = std::string(tk.t[i]);
  ++i;
  if (i >= tk.n) return bad("truncated line: no frame after the interface");
  std::string reason;
  if (tk.t[i].find('#') != std::string_view::npos) {
    reason = parse_compact(tk.t[i], out.frame);
    if (reason.empty() && i + 1 < tk.n &&
        !(i + 2 == tk.n && (tk.t[i + 1] == "T" || tk.t[i + 1] == "R")))
      reason = "unexpected " + quoted(tk.t[i + 1]) + " after the frame";
  } else {
    reason = parse_screen(tk, i, out.frame);
  }
  if (!reason.empty()) return bad(reason);
  out.kind = CandumpLineKind::kFrame;
  return out;
}

std::string format_candump_line(const CanFrame& f, utime_t utime, std::string_view interface) {
  if (utime < 0) utime = 0;
  char buf[64];
  std::snprintf(buf, sizeof buf, "(%010lld.%06lld) ", static_cast<long long>(utime / 1'000'000),
                static_cast<long long>(utime % 1'000'000));
  std::string out = buf;
  out += interface;
  out += ' ';
  if (f.error)
    std::snprintf(buf, sizeof buf, "%08X#",
                  static_cast<unsigned>((f.id & kMaxExtendedId) | kErrorFlag));
  else if (f.extended)
    std::snprintf(buf, sizeof buf, "%08X#", static_cast<unsigned>(f.id & kMaxExtendedId));
  else
    std::snprintf(buf, sizeof buf, "%03X#", static_cast<unsigned>(f.id & kMaxStandardId));
  out += buf;
  const size_t max = f.fd ? kMaxFdLen : kMaxClassicLen;
  const size_t len = f.len > max ? max : f.len;
  if (f.remote && !f.fd) {
    out += 'R';
    if (len > 0) out += static_cast<char>('0' + len);
  } else {
    if (f.fd) {
      std::snprintf(buf, sizeof buf, "#%X", static_cast<unsigned>(f.fd_flags & 0xF));
      out += buf;
    }
    for (size_t i = 0; i < len; ++i) {
      std::snprintf(buf, sizeof buf, "%02X", static_cast<unsigned>(f.data[i]));
      out += buf;
    }
  }
  // A raw DLC 9..15 on 8 bytes, after the data or the remote request's length (can-utils).
  if (!f.fd && len == 8 && f.len8_dlc >= 9 && f.len8_dlc <= 15) {
    std::snprintf(buf, sizeof buf, "_%X", static_cast<unsigned>(f.len8_dlc));
    out += buf;
  }
  return out;
}

}  // namespace ips::uwb_can
