#pragma once
// The progress line of the long-running log tools (ips-sim --out, ips-replay, ips-export, ips-eval)
// on a terminal:
//   ips-replay: [########------------]  42 %  4.3 M events  12 s, about 17 s left
// redrawn in place at most 5 times a second, ended with a newline at 100 %. Not a terminal (a
// pipe, a file, CI): nothing at all, so logs stay clean.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace ips {

class ProgressLine {
 public:
  // Draws only when `out` is a terminal, unless `force` (tests).
  explicit ProgressLine(std::string program, std::FILE* out = stderr, bool force = false);
  // Not finished (an error on the way): ends the line where it stood.
  ~ProgressLine();
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  // fraction in [0, 1] (clamped; NaN as 0), items done so far (events, messages).
  void update(double fraction, int64_t items);
  // Draws 100 % and ends the line, on success. Idempotent.
  void finish();
  bool enabled() const { return enabled_; }

  // The line's text without "\r": pure, for tests. left_s < 0: unknown.
  static std::string render(std::string_view program, double fraction, int64_t items,
                            double elapsed_s, std::string_view unit = "events", int width = 20);

 private:
  void draw(double fraction, int64_t items);

  std::string program_;
  std::FILE* out_;
  bool enabled_;
  bool drawn_ = false;
  bool finished_ = false;
  int64_t last_items_ = 0;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point next_draw_;
};

}  // namespace ips
