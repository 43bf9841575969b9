#pragma once
// The time of an imported row, shared by every ips-import reader: --time-unit (or the unit guessed
// from the first time's magnitude: an epoch time in s, ms, us or ns; else seconds), --file-start
// (the first row's Unix time), --rate (no time column: row k at file-start + k/rate). Pure.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/table_text.hpp"

namespace ips::import {

struct TimeOptions {
  std::optional<table::TimeUnit> unit;  // nullopt: guessed from the first time
  std::optional<int64_t> file_start_us;
  double rate_hz = 0;  // > 0: rows have no time column
};

class RowTimes {
 public:
  explicit RowTimes(const TimeOptions& options)
      : options_(options), clock_(options.file_start_us, options.rate_hz), unit_(options.unit) {}

  // The utime of the next accepted row from its time field (ignored with a rate). nullopt and
  // `reason` set when the field is not a time.
  std::optional<int64_t> next(std::string_view field, std::string& reason);
  // With a rate, call it only for rows that are otherwise valid: the row index counts them.

  // What was used, for the summary: "ns (guessed)", "s", "ISO-8601", "rate 10 Hz".
  std::string describe() const;
  // True when the times looked relative (before 2001 with no --file-start).
  bool relative() const { return clock_.since_boot(); }

 private:
  TimeOptions options_;
  table::RowClock clock_;
  std::optional<table::TimeUnit> unit_;
  bool guessed_ = false, iso_ = false, defaulted_ = false;
};

// Calls fn(line) for each line of `text`, without its "\n" or "\r\n".
template <class Fn>
void for_each_line(std::string_view text, Fn&& fn) {
  while (!text.empty()) {
    const size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text.remove_prefix(nl == std::string_view::npos ? text.size() : nl + 1);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    fn(line);
  }
}

// A field that means "not given": empty, "-", "nan", "NaN", "null".
bool missing_field(std::string_view field);

// "2024-12-18T05:58:05Z" or a Unix time in s -> us; false when neither.
bool parse_start_time(std::string_view text, int64_t& us);

}  // namespace ips::import
