#include "core/table_text.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <system_error>

namespace ips::table {

namespace {

constexpr double kMaxUs = 4e18;

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

std::string_view unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = trim(s.substr(1, s.size() - 2));
  return s;
}

char lower(char c) { return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c; }

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (lower(a[i]) != lower(b[i])) return false;
  return true;
}

// Counts of each candidate separator outside double quotes.
std::array<int, 3> separator_counts(std::string_view line) {
  std::array<int, 3> n{0, 0, 0};  // tab ; ,
  bool quoted = false;
  for (char c : line) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == '\t') ++n[0];
    if (c == ';') ++n[1];
    if (c == ',') ++n[2];
  }
  return n;
}

int64_t us_per(TimeUnit u) {
  switch (u) {
    case TimeUnit::kS:
      return 1'000'000;
    case TimeUnit::kMs:
      return 1'000;
    case TimeUnit::kUs:
    case TimeUnit::kNs:
      return 1;
  }
  return 1;
}

bool digits(std::string_view s, size_t n, int& out) {
  if (s.size() < n) return false;
  int v = 0;
  for (size_t i = 0; i < n; ++i) {
    if (s[i] < '0' || s[i] > '9') return false;
    v = v * 10 + (s[i] - '0');
  }
  out = v;
  return true;
}

// Days from 1970-01-01 to y-m-d (proleptic Gregorian; Howard Hinnant's days_from_civil).
int64_t days_from_civil(int64_t y, int64_t m, int64_t d) {
  y -= m <= 2;
  const int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int64_t yoe = y - era * 400;
  const int64_t doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int64_t doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

struct UnitEntry {
  const char* name;
  double factor;
  double offset;
};

}  // namespace

// --- fields ----------------------------------------------------------------------------------

std::optional<char> separator_from_name(std::string_view name) {
  if (name == "," || iequals(name, "comma")) return ',';
  if (name == ";" || iequals(name, "semicolon")) return ';';
  if (name == "\t" || name == "\\t" || iequals(name, "tab")) return '\t';
  if (name == " " || iequals(name, "space") || iequals(name, "whitespace") ||
      iequals(name, "blank"))
    return kBlanks;
  return std::nullopt;
}

const char* separator_name(char separator) {
  switch (separator) {
    case ',':
      return "comma";
    case ';':
      return "semicolon";
    case '\t':
      return "tab";
    default:
      return "whitespace";
  }
}

const char* separator_flag(char separator) {
  switch (separator) {
    case ',':
      return ",";
    case ';':
      return ";";
    case '\t':
      return "tab";
    default:
      return "space";
  }
}

char detect_separator(std::string_view line) {
  const auto n = separator_counts(line);
  int best = 0;
  char sep = kBlanks;
  const char order[3] = {'\t', ';', ','};
  for (size_t i = 0; i < 3; ++i)
    if (n[i] > best) {
      best = n[i];
      sep = order[i];
    }
  return sep;
}

bool split_fields(std::string_view line, char separator, std::vector<std::string_view>& out) {
  out.clear();
  if (separator == kBlanks) {
    size_t i = 0;
    for (;;) {
      while (i < line.size() && is_blank(line[i])) ++i;
      if (i >= line.size()) return true;
      size_t j = i;
      while (j < line.size() && !is_blank(line[j])) ++j;
      if (out.size() == kMaxFields) return false;
      out.push_back(unquote(line.substr(i, j - i)));
      i = j;
    }
  }
  size_t start = 0;
  bool quoted = false;
  for (size_t i = 0; i <= line.size(); ++i) {
    if (i < line.size() && line[i] == '"') quoted = !quoted;
    if (i == line.size() || (!quoted && line[i] == separator)) {
      if (out.size() == kMaxFields) return false;
      out.push_back(unquote(line.substr(start, i - start)));
      start = i + 1;
    }
  }
  return true;
}

bool parse_number(std::string_view field, double& value) {
  field = trim(field);
  if (field.empty() || field.size() > 64) return false;
  if (field.front() == '+') field.remove_prefix(1);
  if (field.empty()) return false;
  // from_chars also takes "inf", "nan" and hex digits after 0x in some modes: only ours.
  bool digit = false;
  for (char c : field) {
    if (c >= '0' && c <= '9') {
      digit = true;
    } else if (!(c == '.' || c == '-' || c == '+' || c == 'e' || c == 'E')) {
      return false;
    }
  }
  if (!digit) return false;
  double v = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
  if (ec != std::errc() || end != field.data() + field.size() || !std::isfinite(v)) return false;
  value = v;
  return true;
}

bool is_number(std::string_view field) {
  double v = 0;
  return parse_number(field, v);
}

// --- units -----------------------------------------------------------------------------------

std::optional<UnitScale> parse_unit(std::string_view spec, Quantity q) {
  spec = trim(spec);
  // A leading factor: the longest prefix that is a number.
  double factor = 1.0;
  size_t cut = 0;
  for (size_t i = spec.size(); i > 0; --i) {
    double v = 0;
    const std::string_view head = spec.substr(0, i);
    if ((head.back() >= '0' && head.back() <= '9') || head.back() == '.') {
      if (parse_number(head, v)) {
        cut = i;
        factor = v;
        break;
      }
    }
  }
  if (cut > 0 && !(factor > 0)) return std::nullopt;
  std::string_view name = trim(spec.substr(cut));
  if (!name.empty() && name.front() == '*') name = trim(name.substr(1));
  static constexpr UnitEntry kLength[] = {{"m", 1, 0},      {"cm", 0.01, 0}, {"mm", 0.001, 0},
                                          {"km", 1000, 0},  {"ft", 0.3048, 0},
                                          {"in", 0.0254, 0}};
  static constexpr UnitEntry kPressure[] = {
      {"Pa", 1, 0},         {"hPa", 100, 0},       {"kPa", 1000, 0},     {"mbar", 100, 0},
      {"bar", 100000, 0},   {"mmHg", 133.322387415, 0}, {"inHg", 3386.389, 0}};
  static constexpr UnitEntry kTemperature[] = {
      {"degC", 1, 0}, {"C", 1, 0}, {"K", 1, -273.15}, {"degF", 5.0 / 9.0, -32.0 * 5.0 / 9.0}};
  static constexpr UnitEntry kAcceleration[] = {
      {"m/s2", 1, 0}, {"m/s^2", 1, 0}, {"m/s/s", 1, 0}, {"g", 9.80665, 0}, {"mg", 0.00980665, 0}};
  static constexpr UnitEntry kAngularRate[] = {
      {"rad/s", 1, 0}, {"deg/s", 0.017453292519943295, 0}, {"dps", 0.017453292519943295, 0}};
  static constexpr UnitEntry kMagnetic[] = {
      {"uT", 1, 0}, {"nT", 0.001, 0}, {"mT", 1000, 0}, {"T", 1e6, 0}, {"G", 100, 0},
      {"mG", 0.1, 0}};
  static constexpr UnitEntry kAngle[] = {{"rad", 1, 0}, {"deg", 0.017453292519943295, 0}};
  static constexpr UnitEntry kRatio[] = {{"1", 1, 0}, {"%", 0.01, 0}};
  const UnitEntry* table = nullptr;
  size_t n = 0;
  switch (q) {
    case Quantity::kLength:
      table = kLength, n = std::size(kLength);
      break;
    case Quantity::kPressure:
      table = kPressure, n = std::size(kPressure);
      break;
    case Quantity::kTemperature:
      table = kTemperature, n = std::size(kTemperature);
      break;
    case Quantity::kAcceleration:
      table = kAcceleration, n = std::size(kAcceleration);
      break;
    case Quantity::kAngularRate:
      table = kAngularRate, n = std::size(kAngularRate);
      break;
    case Quantity::kMagnetic:
      table = kMagnetic, n = std::size(kMagnetic);
      break;
    case Quantity::kAngle:
      table = kAngle, n = std::size(kAngle);
      break;
    case Quantity::kRatio:
      table = kRatio, n = std::size(kRatio);
      break;
  }
  if (name.empty() && cut > 0 && q == Quantity::kRatio) return UnitScale{factor, 0};
  // Case matters for SI prefixes (mG against MG is moot, but mbar/Mbar and mT/T are not).
  for (size_t i = 0; i < n; ++i)
    if (name == table[i].name) return UnitScale{factor * table[i].factor, table[i].offset};
  for (size_t i = 0; i < n; ++i)
    if (iequals(name, table[i].name) && std::string_view(table[i].name) != "T" &&
        std::string_view(table[i].name) != "G" && std::string_view(table[i].name) != "mG" &&
        std::string_view(table[i].name) != "mT")
      return UnitScale{factor * table[i].factor, table[i].offset};
  return std::nullopt;
}

const char* unit_names(Quantity q) {
  switch (q) {
    case Quantity::kLength:
      return "m, cm, mm, km, ft, in";
    case Quantity::kPressure:
      return "Pa, hPa, kPa, mbar, bar, mmHg, inHg";
    case Quantity::kTemperature:
      return "degC, K, degF";
    case Quantity::kAcceleration:
      return "m/s2, g, mg";
    case Quantity::kAngularRate:
      return "rad/s, deg/s";
    case Quantity::kMagnetic:
      return "uT, nT, mT, T, G, mG";
    case Quantity::kAngle:
      return "rad, deg";
    case Quantity::kRatio:
      return "1, %";
  }
  return "";
}

// --- time ------------------------------------------------------------------------------------

std::optional<TimeUnit> time_unit_from_name(std::string_view name) {
  if (name == "s") return TimeUnit::kS;
  if (name == "ms") return TimeUnit::kMs;
  if (name == "us") return TimeUnit::kUs;
  if (name == "ns") return TimeUnit::kNs;
  return std::nullopt;
}

const char* time_unit_name(TimeUnit unit) {
  switch (unit) {
    case TimeUnit::kS:
      return "s";
    case TimeUnit::kMs:
      return "ms";
    case TimeUnit::kUs:
      return "us";
    case TimeUnit::kNs:
      return "ns";
  }
  return "s";
}

std::optional<TimeUnit> guess_epoch_unit(double value) {
  // 2001-09-09 (1e9 s) to 2286-11-20 (1e10 s) in each unit.
  const double a = std::fabs(value);
  if (a >= 1e9 && a < 1e10) return TimeUnit::kS;
  if (a >= 1e12 && a < 1e13) return TimeUnit::kMs;
  if (a >= 1e15 && a < 1e16) return TimeUnit::kUs;
  if (a >= 1e18 && a < 1e19) return TimeUnit::kNs;
  return std::nullopt;
}

bool parse_iso8601_us(std::string_view f, int64_t& us) {
  f = trim(f);
  int y = 0, mo = 0, d = 0, h = 0, mi = 0, s = 0;
  // YYYY-MM-DD[T| ]hh:mm[:ss[.fff]][Z|+hh:mm|-hh:mm|+hhmm]
  if (f.size() < 16 || !digits(f, 4, y) || f[4] != '-' || !digits(f.substr(5), 2, mo) ||
      f[7] != '-' || !digits(f.substr(8), 2, d) || (f[10] != 'T' && f[10] != ' ') ||
      !digits(f.substr(11), 2, h) || f[13] != ':' || !digits(f.substr(14), 2, mi))
    return false;
  size_t i = 16;
  int64_t frac_us = 0;
  if (i < f.size() && f[i] == ':') {
    if (!digits(f.substr(i + 1), 2, s)) return false;
    i += 3;
    if (i < f.size() && (f[i] == '.' || f[i] == ',')) {
      ++i;
      int64_t scale = 100000;
      const size_t start = i;
      while (i < f.size() && f[i] >= '0' && f[i] <= '9') {
        frac_us += (f[i] - '0') * scale;
        scale /= 10;
        ++i;
      }
      if (i == start) return false;
    }
  }
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || s > 60) return false;
  int64_t offset_s = 0;
  if (i < f.size()) {
    if (f[i] == 'Z' || f[i] == 'z') {
      ++i;
    } else if (f[i] == '+' || f[i] == '-') {
      const int sign = f[i] == '+' ? 1 : -1;
      int oh = 0, om = 0;
      if (!digits(f.substr(i + 1), 2, oh)) return false;
      i += 3;
      if (i < f.size() && f[i] == ':') ++i;
      if (i < f.size()) {
        if (!digits(f.substr(i), 2, om)) return false;
        i += 2;
      }
      if (oh > 23 || om > 59) return false;
      offset_s = sign * (oh * 3600 + om * 60);
    } else {
      return false;
    }
  }
  if (i != f.size()) return false;
  const int64_t secs = days_from_civil(y, mo, d) * 86400 + h * 3600 + mi * 60 + s - offset_s;
  us = secs * 1'000'000 + frac_us;
  return true;
}

bool parse_time_us(std::string_view field, TimeUnit unit, int64_t& us) {
  field = trim(field);
  if (field.size() >= 16 && field[4] == '-') return parse_iso8601_us(field, us);
  // Integers exactly (ns stamps do not fit a double's 53 bits).
  int64_t i = 0;
  const auto [end, ec] = std::from_chars(field.data(), field.data() + field.size(), i);
  if (ec == std::errc() && end == field.data() + field.size() && !field.empty()) {
    if (unit == TimeUnit::kNs) {
      us = i / 1000;
      return true;
    }
    const double v = static_cast<double>(i) * static_cast<double>(us_per(unit));
    if (std::fabs(v) > kMaxUs) return false;
    us = i * us_per(unit);
    return true;
  }
  double v = 0;
  if (!parse_number(field, v)) return false;
  const double u = unit == TimeUnit::kNs ? v / 1000.0 : v * static_cast<double>(us_per(unit));
  if (!(std::fabs(u) <= kMaxUs)) return false;
  us = static_cast<int64_t>(std::llround(u));
  return true;
}

std::optional<int64_t> RowClock::next(std::optional<int64_t> t_us) {
  const int64_t k = rows_++;
  if (rate_hz_ > 0) {
    const double offset_us = static_cast<double>(k) * 1e6 / rate_hz_;
    if (!(offset_us < kMaxUs)) return std::nullopt;
    return start_.value_or(0) + static_cast<int64_t>(std::llround(offset_us));
  }
  if (!t_us) return std::nullopt;
  if (!have_first_) {
    have_first_ = true;
    first_t_ = *t_us;
    since_boot_ = !start_ && *t_us < 1'000'000'000LL * 1'000'000LL;
  }
  if (start_) {
    // Spacing kept from the first row; saturate rather than overflow on absurd input.
    const double d = static_cast<double>(*t_us) - static_cast<double>(first_t_) +
                     static_cast<double>(*start_);
    if (!(std::fabs(d) < kMaxUs)) return std::nullopt;
    return *start_ + (*t_us - first_t_);
  }
  return *t_us;
}

// --- column mappings -------------------------------------------------------------------------

std::string normalise_header_name(std::string_view name) {
  name = unquote(name);
  if (!name.empty() && name.front() == '%') name.remove_prefix(1);
  if (name.size() > 6 && iequals(name.substr(0, 6), "field.")) name.remove_prefix(6);
  std::string out;
  for (char c : name) {
    if (c == '(' || c == '[' || c == '{') break;
    if (c == '_' || c == ' ' || c == '-' || c == '.' || c == '\t') continue;
    out.push_back(lower(c));
  }
  return out;
}

std::string Columns::set_from_list(std::string_view list, const std::vector<KnownColumn>& known) {
  names_.clear();
  needed_ = 0;
  std::vector<std::string_view> parts;
  if (!split_fields(list, ',', parts)) return "too many columns";
  int column = 0;
  for (std::string_view p : parts) {
    if (p == "-" || p.empty()) {
      ++column;
      continue;
    }
    const auto it = std::find_if(known.begin(), known.end(),
                                 [&](const KnownColumn& k) { return k.name == p; });
    if (it == known.end()) {
      std::string names;
      for (const KnownColumn& k : known) names += (names.empty() ? "" : ", ") + std::string(k.name);
      return "unknown column '" + excerpt(p, 24) + "' (known: " + names + ", - to skip)";
    }
    if (index(p) >= 0) return "column '" + std::string(p) + "' given twice";
    names_.emplace_back(std::string(p), column);
    needed_ = column + 1;
    ++column;
  }
  if (names_.empty()) return "no column named";
  return "";
}

int Columns::set_from_header(const std::vector<std::string_view>& header,
                             const std::vector<KnownColumn>& known) {
  names_.clear();
  needed_ = 0;
  std::vector<std::string> norm;
  norm.reserve(header.size());
  for (std::string_view h : header) norm.push_back(normalise_header_name(h));
  std::vector<bool> taken(header.size(), false);
  int mapped = 0;
  for (const KnownColumn& k : known) {
    std::string_view aliases = k.aliases;
    bool found = false;
    while (!found) {
      const size_t bar = aliases.find('|');
      const std::string alias = normalise_header_name(aliases.substr(0, bar));
      for (size_t c = 0; c < norm.size() && !alias.empty(); ++c)
        if (!taken[c] && norm[c] == alias) {
          taken[c] = true;
          names_.emplace_back(std::string(k.name), static_cast<int>(c));
          needed_ = std::max(needed_, static_cast<int>(c) + 1);
          ++mapped;
          found = true;
          break;
        }
      if (bar == std::string_view::npos) break;
      aliases.remove_prefix(bar + 1);
    }
  }
  return mapped;
}

int Columns::index(std::string_view name) const {
  for (const auto& [n, c] : names_)
    if (n == name) return c;
  return -1;
}

std::string Columns::describe() const {
  std::vector<std::string> cols(static_cast<size_t>(needed_), "-");
  for (const auto& [n, c] : names_) cols[static_cast<size_t>(c)] = n;
  std::string out;
  for (size_t i = 0; i < cols.size(); ++i) out += (i ? "," : "") + cols[i];
  return out;
}

// --- reading lines ---------------------------------------------------------------------------

bool TableReader::looks_like_data(std::string_view line, char separator) {
  if (!split_fields(line, separator, fields_)) return false;
  size_t numbers = 0, nonempty = 0;
  for (std::string_view f : fields_) {
    if (f.empty()) continue;
    ++nonempty;
    int64_t us = 0;
    if (is_number(f) || (f.size() >= 16 && parse_iso8601_us(f, us))) ++numbers;
  }
  return numbers > 0 && 2 * numbers >= nonempty;
}

std::vector<std::string_view> TableReader::header_views() const {
  return {header_.begin(), header_.end()};
}

TableReader::Kind TableReader::feed(std::string_view line) {
  ++line_number_;
  just_first_ = false;
  fields_.clear();
  if (line.size() >= 3 && static_cast<unsigned char>(line[0]) == 0xEF &&
      static_cast<unsigned char>(line[1]) == 0xBB && static_cast<unsigned char>(line[2]) == 0xBF)
    line.remove_prefix(3);  // a UTF-8 byte order mark
  const std::string_view t = trim(line);
  if (t.empty()) return Kind::kEmpty;
  if (t.front() == '#' || t.substr(0, 2) == "//") return Kind::kComment;
  if (!options_.row_tag.empty()) {
    const char sep = options_.separator.value_or(detect_separator(t));
    if (!split_fields(t, sep, fields_)) return Kind::kTooWide;
    if (fields_.empty() || fields_[0] != options_.row_tag) {
      fields_.clear();
      return Kind::kOtherRow;
    }
    if (separator_ == 0) separator_ = sep;
    ++data_rows_;
    just_first_ = data_rows_ == 1;
    return Kind::kData;
  }
  if (data_rows_ == 0) {
    const char sep = options_.separator.value_or(detect_separator(t));
    bool data = false;
    if (options_.header == HeaderMode::kNone) {
      data = true;
    } else if (options_.header == HeaderMode::kPresent) {
      data = preamble_ > 0;
    } else {
      data = looks_like_data(t, sep) || preamble_ >= static_cast<int64_t>(
                                                         options_.max_preamble_lines);
      // A given separator that is wrong for the file: its data lines are still data (to be
      // rejected, from the first one, with a hint), not a preamble to skip.
      if (!data && options_.separator) data = looks_like_data(t, detect_separator(t));
    }
    if (!data) {
      if (preamble_ == 0) first_preamble_ = excerpt(t, 80);
      ++preamble_;
      candidate_header_.assign(t);
      return Kind::kPreamble;
    }
    separator_ = sep;
    if (!split_fields(t, separator_, fields_)) return Kind::kTooWide;
    if (!candidate_header_.empty()) {
      std::vector<std::string_view> h;
      const size_t n = fields_.size();
      if (split_fields(candidate_header_, separator_, h) && h.size() == n)
        for (std::string_view f : h) header_.emplace_back(f);
      // fields_ still views `t`, split above.
    }
    ++data_rows_;
    just_first_ = true;
    return Kind::kData;
  }
  if (!split_fields(t, separator_, fields_)) return Kind::kTooWide;
  ++data_rows_;
  return Kind::kData;
}

// --- nothing silent --------------------------------------------------------------------------

std::string excerpt(std::string_view text, size_t max) {
  std::string out;
  for (char c : text) {
    if (out.size() >= max) {
      out += "...";
      break;
    }
    out.push_back(c >= 0x20 && c < 0x7f ? c : '?');
  }
  return out;
}

void ImportTally::reject(int64_t line_number, std::string_view line, std::string_view reason) {
  if (bad++ == 0) {
    first_bad_line = line_number;
    first_bad_text = excerpt(trim(line));
    first_bad_reason = excerpt(reason, 200);
  }
}

void ImportTally::note(const TableReader& reader, TableReader::Kind kind, std::string_view line) {
  ++lines;
  switch (kind) {
    case TableReader::Kind::kPreamble:
      if (preamble++ == 0) first_preamble = excerpt(trim(line));
      break;
    case TableReader::Kind::kEmpty:
    case TableReader::Kind::kComment:
    case TableReader::Kind::kOtherRow:
      ++skipped;
      break;
    case TableReader::Kind::kTooWide:
      reject(reader.line_number(), line, "more than 512 fields");
      break;
    case TableReader::Kind::kData:
      break;
  }
}

std::string separator_hint(std::string_view line, std::optional<char> used) {
  const char best = detect_separator(line);
  std::vector<std::string_view> a, b;
  if (!used || best == *used) return "";
  split_fields(line, best, a);
  split_fields(line, *used, b);
  if (a.size() <= b.size()) return "";
  return std::string("looks ") + separator_name(best) + "-separated: try --separator " +
         separator_flag(best);
}

std::string import_verdict(const ImportTally& t, const ImportExpectation& e) {
  const int64_t data = t.rows + t.bad;
  const bool nothing = t.messages == 0 && t.lines > t.skipped;
  const bool mostly_bad = data > 0 && 2 * t.bad > data;
  if (!nothing && !mostly_bad) return "";
  std::string out = e.input + ": ";
  if (nothing)
    out += "0 messages from " + std::to_string(t.lines) + " lines";
  else
    out += std::to_string(t.bad) + " of " + std::to_string(data) + " rows rejected";
  std::string hint;
  if (t.bad > 0) {
    out += "; line " + std::to_string(t.first_bad_line) + " '" + t.first_bad_text +
           "': " + t.first_bad_reason;
    hint = separator_hint(t.first_bad_text, e.separator);
  } else if (data == 0 && t.preamble > 0) {
    out += "; no line looks like data (the first reads '" + t.first_preamble + "')";
    hint = separator_hint(t.first_preamble, e.separator);
  }
  if (!e.columns.empty() && t.bad > 0) out += " (columns " + e.columns + ")";
  if (hint.empty() && t.bad > 0 && e.time_needed &&
      t.first_bad_reason.find("time") != std::string::npos)
    hint = "check --time-unit, or give --rate HZ for a file without times";
  if (hint.empty() && t.bad > 0 && t.first_bad_reason.find("fields") != std::string::npos)
    hint = "check --columns";
  if (hint.empty() && data == 0)
    hint = "is this the right file? check --separator, --columns and the header";
  if (!hint.empty()) out += "; " + hint;
  return out;
}

}  // namespace ips::table
