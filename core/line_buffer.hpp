#pragma once
// Bytes from a stream (serial port, TCP, stdin) into text lines for the line-based wire formats.
// Lines end at LF; a CR before it is dropped (CRLF and LF devices alike; a lone CR, as the
// DWM1001 shell echoes, also ends a line). A line longer than max_line_bytes is not kept: it is
// skipped up to its end and counted, so that a device streaming garbage without newlines cannot
// grow memory. Pure: no I/O.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace ips {

class LineBuffer {
 public:
  explicit LineBuffer(size_t max_line_bytes = 4096) : max_(max_line_bytes) {}

  // Appends bytes and calls on_line for every line they complete (without its terminator;
  // empty lines are not reported).
  template <class OnLine>
  void feed(std::string_view bytes, OnLine&& on_line) {
    for (char c : bytes) {
      if (c == '\n' || c == '\r') {
        if (overlong_) {
          overlong_ = false;
        } else if (!line_.empty()) {
          on_line(std::string_view(line_));
        }
        line_.clear();
        continue;
      }
      if (overlong_) continue;
      if (line_.size() >= max_) {
        ++overlong_lines_;
        overlong_ = true;
        line_.clear();
        continue;
      }
      line_ += c;
    }
  }

  // The unterminated rest (e.g. at the end of a file), then cleared.
  std::string take_partial() {
    std::string rest;
    if (!overlong_) rest.swap(line_);
    line_.clear();
    overlong_ = false;
    return rest;
  }
  // Forgets a partial line (after a reconnect: its start belongs to another stream).
  void reset() {
    line_.clear();
    overlong_ = false;
  }
  int64_t overlong_lines() const { return overlong_lines_; }

 private:
  size_t max_;
  std::string line_;
  bool overlong_ = false;
  int64_t overlong_lines_ = 0;
};

}  // namespace ips
