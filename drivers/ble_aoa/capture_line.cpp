#include "drivers/ble_aoa/capture_line.hpp"

#include "core/device_text.hpp"

namespace ips::ble_aoa {

namespace {

// Digits only, 1..max_digits of them -> value.
bool digits(std::string_view s, size_t min_digits, size_t max_digits, int64_t& v) {
  if (s.size() < min_digits || s.size() > max_digits) return false;
  v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + (c - '0');
  }
  return true;
}

bool leap(int64_t y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int days_in_month(int64_t y, int64_t m) {
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return m == 2 && leap(y) ? 29 : kDays[m - 1];
}

// Howard Hinnant's days_from_civil: days since 1970-01-01 of a proleptic Gregorian date.
int64_t days_from_civil(int64_t y, int64_t m, int64_t d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int64_t yoe = y - era * 400;
  const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

bool valid_port(std::string_view p) {
  if (p.empty() || p.size() > kMaxPortLength) return false;
  for (char c : p)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '.' || c == ':' || c == '/' || c == '-'))
      return false;
  return true;
}

bool parse_date(std::string_view s, CivilTime& t) {
  const size_t a = s.find('-');
  const size_t b = a == std::string_view::npos ? a : s.find('-', a + 1);
  if (b == std::string_view::npos) return false;
  int64_t y, m, d;
  if (!digits(s.substr(0, a), 4, 4, y) || !digits(s.substr(a + 1, b - a - 1), 1, 2, m) ||
      !digits(s.substr(b + 1), 1, 2, d))
    return false;
  t.year = static_cast<int>(y);
  t.month = static_cast<int>(m);
  t.day = static_cast<int>(d);
  return true;
}

bool parse_time(std::string_view s, CivilTime& t) {
  const size_t a = s.find(':');
  const size_t b = a == std::string_view::npos ? a : s.find(':', a + 1);
  if (b == std::string_view::npos) return false;
  std::string_view sec = s.substr(b + 1);
  std::string_view frac;
  if (const size_t dot = sec.find('.'); dot != std::string_view::npos) {
    frac = sec.substr(dot + 1);
    sec = sec.substr(0, dot);
    if (frac.empty()) return false;
  }
  int64_t h, mi, se, f = 0;
  if (!digits(s.substr(0, a), 1, 2, h) || !digits(s.substr(a + 1, b - a - 1), 2, 2, mi) ||
      !digits(sec, 2, 2, se) || (!frac.empty() && !digits(frac, 1, 6, f)))
    return false;
  for (size_t k = frac.size(); k < 6; ++k) f *= 10;
  t.hour = static_cast<int>(h);
  t.minute = static_cast<int>(mi);
  t.second = static_cast<int>(se);
  t.micros = f;
  return true;
}

}  // namespace

CaptureParseResult parse_capture_line(std::string_view line) {
  CaptureParseResult r;
  if (line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);
  const size_t c1 = line.find(',');
  if (c1 == std::string_view::npos) {
    r.reason = "capture: not 'date time,port,line': " + quoted_field(line);
    return r;
  }
  const std::string_view stamp = line.substr(0, c1);
  const size_t space = stamp.find(' ');
  CivilTime& t = r.line.pc_time;
  if (space == std::string_view::npos || !parse_date(stamp.substr(0, space), t) ||
      !parse_time(stamp.substr(space + 1), t)) {
    r.reason = "capture: time " + quoted_field(stamp) + " is not YYYY-MM-DD H:MM:SS.fff";
    return r;
  }
  if (t.month < 1 || t.month > 12 || t.day < 1 || t.day > days_in_month(t.year, t.month) ||
      t.hour > 23 || t.minute > 59 || t.second > 59) {
    r.reason = "capture: no such date or time " + quoted_field(stamp);
    return r;
  }
  const size_t c2 = line.find(',', c1 + 1);
  if (c2 == std::string_view::npos) {
    r.reason = "capture: no port field";
    return r;
  }
  r.line.port = line.substr(c1 + 1, c2 - c1 - 1);
  if (!valid_port(r.line.port)) {
    r.reason = "capture: port " + quoted_field(r.line.port) + " is not 1 to 32 of A-Za-z0-9_.:/-";
    return r;
  }
  r.line.payload = line.substr(c2 + 1);
  if (r.line.payload.empty()) {
    r.reason = "capture: nothing after the port";
    return r;
  }
  r.ok = true;
  return r;
}

std::optional<int64_t> utime_from_civil(const CivilTime& t, int64_t utc_offset_s) {
  if (t.year < 1970 || t.year > 2095) return std::nullopt;
  const int64_t days = days_from_civil(t.year, t.month, t.day);
  const int64_t s = days * 86400 + t.hour * 3600 + t.minute * 60 + t.second - utc_offset_s;
  if (s <= 0) return std::nullopt;
  return s * 1'000'000 + t.micros;
}

std::optional<int64_t> parse_utc_offset(std::string_view text) {
  if (text == "UTC" || text == "Z" || text == "utc") return 0;
  if (text.size() < 3 || (text[0] != '+' && text[0] != '-')) return std::nullopt;
  const int64_t sign = text[0] == '-' ? -1 : 1;
  std::string_view rest = text.substr(1);
  int64_t h = 0, m = 0;
  if (rest.size() == 5 && rest[2] == ':') {
    if (!digits(rest.substr(0, 2), 2, 2, h) || !digits(rest.substr(3), 2, 2, m))
      return std::nullopt;
  } else if (rest.size() == 4) {
    if (!digits(rest.substr(0, 2), 2, 2, h) || !digits(rest.substr(2), 2, 2, m))
      return std::nullopt;
  } else if (rest.size() == 2) {
    if (!digits(rest, 2, 2, h)) return std::nullopt;
  } else {
    return std::nullopt;
  }
  if (h > 14 || m > 59) return std::nullopt;
  return sign * (h * 3600 + m * 60);
}

}  // namespace ips::ble_aoa
