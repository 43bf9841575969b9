#include "drivers/baro/baro_line_parser.hpp"

#include "core/device_text.hpp"

namespace ips::baro {

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// The next blank-separated word of `s` from `i` (empty at the end).
std::string_view next_word(std::string_view s, size_t& i) {
  while (i < s.size() && is_blank(s[i])) ++i;
  const size_t start = i;
  while (i < s.size() && !is_blank(s[i])) ++i;
  return s.substr(start, i - start);
}

struct Field {
  char key;
  const char* what;
  double* value;
  bool seen = false;
};

}  // namespace

BaroLineResult parse_baro_line(std::string_view line) {
  BaroLineResult r;
  size_t i = 0;
  while (i < line.size() && is_blank(line[i])) ++i;
  if (i == line.size()) {
    r.reason = "empty line";
    return r;
  }
  if (line[i] == '#') {
    r.kind = BaroLineResult::Kind::kComment;
    return r;
  }
  BaroReading& reading = r.reading;
  Field fields[] = {{'P', "pressure", &reading.pressure_pa},
                    {'T', "temperature", &reading.temperature_c},
                    {'H', "humidity", &reading.humidity_pct}};
  for (;;) {
    const std::string_view key = next_word(line, i);
    if (key.empty()) break;
    Field* field = nullptr;
    for (Field& f : fields)
      if (key.size() == 1 && key[0] == f.key) field = &f;
    if (!field) {
      r.reason = "unknown field " + quoted_field(key) + " (expected P, T or H)";
      return r;
    }
    if (field->seen) {
      r.reason = std::string(1, field->key) + " given twice";
      return r;
    }
    field->seen = true;
    const std::string_view value = next_word(line, i);
    if (value.empty()) {
      r.reason = std::string(1, field->key) + " has no value";
      return r;
    }
    if (!parse_decimal(value, *field->value)) {
      r.reason = std::string(field->what) + " " + quoted_field(value) + " is not a number";
      return r;
    }
  }
  if (!fields[0].seen) {
    r.reason = "no pressure (P)";
    return r;
  }
  if (!fields[1].seen) {
    r.reason = "no temperature (T)";
    return r;
  }
  r.reason = reading_problem(reading);
  if (r.reason.empty()) r.kind = BaroLineResult::Kind::kSample;
  return r;
}

}  // namespace ips::baro
