#include "core/progress.hpp"

#include <unistd.h>

#include <cmath>

#include "core/text_escape.hpp"

namespace ips {

namespace {

std::string count_text(int64_t n) {
  char buf[32];
  if (n >= 1'000'000)
    std::snprintf(buf, sizeof buf, "%.1f M", static_cast<double>(n) / 1e6);
  else if (n >= 10'000)
    std::snprintf(buf, sizeof buf, "%.0f k", static_cast<double>(n) / 1e3);
  else
    std::snprintf(buf, sizeof buf, "%lld", static_cast<long long>(n));
  return buf;
}

double clamp_fraction(double f) {
  if (!(f > 0)) return 0;  // NaN too
  return f > 1 ? 1 : f;
}

}  // namespace

ProgressLine::ProgressLine(std::string program, std::FILE* out, bool force)
    : program_(std::move(program)),
      out_(out),
      enabled_(force || (out != nullptr && isatty(fileno(out)))),
      start_(std::chrono::steady_clock::now()),
      next_draw_(start_) {}

std::string ProgressLine::render(std::string_view program, double fraction, int64_t items,
                                 double elapsed_s, std::string_view unit, int width) {
  fraction = clamp_fraction(fraction);
  const int filled = static_cast<int>(std::floor(fraction * width + 1e-9));
  std::string bar(static_cast<size_t>(filled), '#');
  bar.append(static_cast<size_t>(width - filled), '-');
  char pct[16];
  std::snprintf(pct, sizeof pct, "%3d %%", static_cast<int>(std::floor(fraction * 100 + 1e-9)));
  std::string line = printable(program) + ": [" + bar + "] " + pct + "  " + count_text(items) +
                     " " + std::string(unit);
  char tail[64];
  if (fraction >= 1) {
    std::snprintf(tail, sizeof tail, "  %.1f s", elapsed_s);
  } else if (fraction > 0.01 && elapsed_s > 0.5) {
    // A linear forecast: the tools read files front to back at a steady rate.
    std::snprintf(tail, sizeof tail, "  %.0f s, about %.0f s left", elapsed_s,
                  elapsed_s * (1 - fraction) / fraction);
  } else {
    std::snprintf(tail, sizeof tail, "  %.0f s", elapsed_s);
  }
  return line + tail;
}

ProgressLine::~ProgressLine() {
  if (drawn_ && !finished_) std::fprintf(out_, "\n");
}

void ProgressLine::draw(double fraction, int64_t items) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  // Pad with spaces so that a shorter line wipes the end of the previous one.
  std::fprintf(out_, "\r%s   ", render(program_, fraction, items, elapsed).c_str());
  std::fflush(out_);
  drawn_ = true;
}

void ProgressLine::update(double fraction, int64_t items) {
  last_items_ = items;
  if (!enabled_ || finished_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now < next_draw_) return;
  next_draw_ = now + std::chrono::milliseconds(200);
  draw(fraction, items);
}

void ProgressLine::finish() {
  if (!enabled_ || finished_) return;
  finished_ = true;
  draw(1.0, last_items_);
  std::fprintf(out_, "\n");
  std::fflush(out_);
}

}  // namespace ips
