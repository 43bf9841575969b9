#pragma once
// Strings that came off the wire or out of a file (tag names, sources, YAML text) are escaped
// before they reach a terminal or a log: control characters and bytes outside printable ASCII
// become \xNN, so a name cannot move the cursor, clear the screen or forge a log line.
#include <cstdio>
#include <string>
#include <string_view>

namespace ips {

inline std::string printable(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (unsigned char c : s) {
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      char buf[5];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  return out;
}

}  // namespace ips
