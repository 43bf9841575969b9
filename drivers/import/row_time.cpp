#include "drivers/import/row_time.hpp"

#include <cmath>

namespace ips::import {

std::optional<int64_t> RowTimes::next(std::string_view field, std::string& reason) {
  if (options_.rate_hz > 0) {
    auto t = clock_.next(std::nullopt);
    if (!t) reason = "row time beyond the representable range";
    return t;
  }
  int64_t us = 0;
  if (table::parse_iso8601_us(field, us)) {
    iso_ = true;
  } else {
    double v = 0;
    if (!table::parse_number(field, v)) {
      reason = "time '" + table::excerpt(field, 24) + "' is not a number nor ISO-8601";
      return std::nullopt;
    }
    if (!unit_) {
      unit_ = table::guess_epoch_unit(v);
      if (unit_) {
        guessed_ = true;
      } else {
        unit_ = table::TimeUnit::kS;
        defaulted_ = true;
      }
    }
    if (!table::parse_time_us(field, *unit_, us)) {
      reason = "time '" + table::excerpt(field, 24) + "' is out of range";
      return std::nullopt;
    }
  }
  auto t = clock_.next(us);
  if (!t) reason = "time '" + table::excerpt(field, 24) + "' is out of range";
  return t;
}

std::string RowTimes::describe() const {
  if (options_.rate_hz > 0) {
    char buf[48];
    std::snprintf(buf, sizeof buf, "rate %g Hz", options_.rate_hz);
    return buf;
  }
  if (iso_ && !unit_) return "ISO-8601";
  if (!unit_) return "-";
  std::string s = table::time_unit_name(*unit_);
  if (guessed_) s += " (guessed from the magnitude)";
  if (defaulted_) s += " (not an epoch time: taken as s)";
  return s;
}

bool missing_field(std::string_view f) {
  return f.empty() || f == "-" || f == "nan" || f == "NaN" || f == "NAN" || f == "null";
}

bool parse_start_time(std::string_view text, int64_t& us) {
  if (table::parse_iso8601_us(text, us)) return true;
  return table::parse_time_us(text, table::TimeUnit::kS, us);
}

}  // namespace ips::import
