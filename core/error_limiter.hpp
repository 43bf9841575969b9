#pragma once
// Rate limit for the reports of bad input: at most one line per `period_us` per kind (udp, http,
// json, file, ...), the next one saying how many of that kind were not shown in between, so a
// flood of garbage costs one log line a second and is still counted. Pure: the caller gives the
// time. Memory: one entry per kind, and kinds are the program's own fixed names.
#include <cstdint>
#include <map>
#include <optional>
#include <string>

namespace ips {

class ErrorLimiter {
 public:
  explicit ErrorLimiter(int64_t period_us = 1'000'000) : period_us_(period_us) {}
  // The text to report now (with "(N more like it since the last report)" when some were held
  // back), or nullopt when this one is only counted.
  std::optional<std::string> admit(const std::string& kind, const std::string& text,
                                   int64_t now_us) {
    State& s = kinds_[kind];
    if (s.reported && now_us - s.last_us < period_us_) {
      ++s.held;
      return std::nullopt;
    }
    std::string out = text;
    if (s.held > 0) out += " (" + std::to_string(s.held) + " more like it since the last report)";
    s.reported = true;
    s.last_us = now_us;
    s.held = 0;
    return out;
  }

 private:
  struct State {
    bool reported = false;
    int64_t last_us = 0;
    int64_t held = 0;
  };
  int64_t period_us_;
  std::map<std::string, State> kinds_;
};

}  // namespace ips
