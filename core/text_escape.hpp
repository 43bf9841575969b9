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

// A JSON string literal (quotes included): quote and backslash escaped, control characters and
// DEL as \u00XX; other bytes (UTF-8 included) as they are.
inline std::string json_quote(std::string_view s) {
  std::string out = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + "\"";
}

// Untrusted text for XML/HTML character data and attribute values (ips-eval's report, ips-view's
// map): bytes outside printable ASCII as \xNN (printable()), then & < > " ' as character
// references.
inline std::string xml_text(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : printable(s)) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace ips
