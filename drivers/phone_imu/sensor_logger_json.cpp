#include "drivers/phone_imu/sensor_logger_json.hpp"

#include "core/device_text.hpp"
#include "core/text_escape.hpp"
#include "drivers/phone_imu/csv_row.hpp"

namespace ips::phone_imu {

namespace {

constexpr int kMaxDepth = 32;
constexpr size_t kMaxCaptured = 256;

// A cursor over the body; every method returns false with `error` set on malformed JSON.
class Json {
 public:
  explicit Json(std::string_view s) : s_(s) {}
  std::string error;

  void ws() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
      ++i_;
  }
  bool at_end() {
    ws();
    return i_ == s_.size();
  }
  char peek() {
    ws();
    return i_ < s_.size() ? s_[i_] : '\0';
  }
  bool eat(char c) {
    if (peek() != c) return fail(std::string("expected '") + c + "'");
    ++i_;
    return true;
  }
  bool fail(const std::string& what) {
    if (error.empty()) error = what + " at byte " + std::to_string(i_);
    return false;
  }

  // A string; its content (escapes decoded, non-ASCII \u as '?') into *out when given.
  bool string(std::string* out) {
    if (!eat('"')) return false;
    if (out) out->clear();
    while (i_ < s_.size()) {
      const char c = s_[i_++];
      if (c == '"') return true;
      if (static_cast<unsigned char>(c) < 0x20) return fail("control character in a string");
      char decoded = c;
      if (c == '\\') {
        if (i_ >= s_.size()) break;
        const char e = s_[i_++];
        switch (e) {
          case '"': case '\\': case '/': decoded = e; break;
          case 'b': decoded = '\b'; break;
          case 'f': decoded = '\f'; break;
          case 'n': decoded = '\n'; break;
          case 'r': decoded = '\r'; break;
          case 't': decoded = '\t'; break;
          case 'u': {
            if (i_ + 4 > s_.size()) return fail("cut \\u escape");
            unsigned v = 0;
            for (int k = 0; k < 4; ++k) {
              const char h = s_[i_++];
              v <<= 4;
              if (h >= '0' && h <= '9') v |= static_cast<unsigned>(h - '0');
              else if (h >= 'a' && h <= 'f') v |= static_cast<unsigned>(h - 'a' + 10);
              else if (h >= 'A' && h <= 'F') v |= static_cast<unsigned>(h - 'A' + 10);
              else return fail("bad \\u escape");
            }
            decoded = v < 0x80 ? static_cast<char>(v) : '?';
            break;
          }
          default:
            return fail("bad escape in a string");
        }
      }
      if (out) {
        if (out->size() >= kMaxCaptured) return fail("string longer than 256 bytes");
        *out += decoded;
      }
    }
    return fail("unterminated string");
  }

  // A number (RFC 8259 grammar); its text into `text`.
  bool number(std::string_view& text) {
    ws();
    const size_t start = i_;
    if (i_ < s_.size() && s_[i_] == '-') ++i_;
    const size_t int_start = i_;
    while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9') ++i_;
    if (i_ == int_start) return fail("expected a value");
    if (s_[int_start] == '0' && i_ - int_start > 1) return fail("leading zero in a number");
    if (i_ < s_.size() && s_[i_] == '.') {
      const size_t f = ++i_;
      while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9') ++i_;
      if (i_ == f) return fail("bad fraction in a number");
    }
    if (i_ < s_.size() && (s_[i_] == 'e' || s_[i_] == 'E')) {
      ++i_;
      if (i_ < s_.size() && (s_[i_] == '+' || s_[i_] == '-')) ++i_;
      const size_t e = i_;
      while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9') ++i_;
      if (i_ == e) return fail("bad exponent in a number");
    }
    text = s_.substr(start, i_ - start);
    return true;
  }

  bool literal(std::string_view word) {
    ws();
    if (s_.substr(i_, word.size()) != word) return fail("expected a value");
    i_ += word.size();
    return true;
  }

  bool skip(int depth) {
    if (depth > kMaxDepth) return fail("nesting deeper than 32");
    const char c = peek();
    if (c == '"') return string(nullptr);
    if (c == 't') return literal("true");
    if (c == 'f') return literal("false");
    if (c == 'n') return literal("null");
    if (c == '[') {
      ++i_;
      if (peek() == ']') return ++i_, true;
      for (;;) {
        if (!skip(depth + 1)) return false;
        if (peek() == ',') { ++i_; continue; }
        return eat(']');
      }
    }
    if (c == '{') {
      ++i_;
      if (peek() == '}') return ++i_, true;
      for (;;) {
        if (!string(nullptr) || !eat(':') || !skip(depth + 1)) return false;
        if (peek() == ',') { ++i_; continue; }
        return eat('}');
      }
    }
    std::string_view text;
    return number(text);
  }

  // Walks an object's members: on_member(key) reads the value (or skips it) and returns false
  // on a JSON error.
  template <class OnMember>
  bool object(OnMember&& on_member) {
    if (!eat('{')) return false;
    if (peek() == '}') return ++i_, true;
    std::string key;
    for (;;) {
      if (!string(&key) || !eat(':') || !on_member(key)) return false;
      if (peek() == ',') { ++i_; continue; }
      return eat('}');
    }
  }

 private:
  std::string_view s_;
  size_t i_ = 0;
};

// One payload entry; false on a JSON error (the body is refused), else `kind`/`sample` filled or
// `bad` set.
struct Entry {
  std::string name;
  bool has_time = false, time_ok = false, has_values = false;
  bool values_ok = true;
  int got_axes = 0;
  int64_t device_us = 0;
  std::array<double, 3> xyz{};
  std::string problem;
};

bool read_entry(Json& j, Entry& e) {
  return j.object([&](const std::string& key) {
    if (key == "name") {
      if (j.peek() != '"') return j.skip(2);
      return j.string(&e.name);
    }
    if (key == "time") {
      e.has_time = true;
      if (j.peek() == '"') {
        std::string text;
        if (!j.string(&text)) return false;
        e.time_ok = parse_time_us(text, TimeUnit::kNs, e.device_us) && !text.empty() &&
                    text.find_first_not_of("0123456789") == std::string::npos;
        if (!e.time_ok) e.problem = "time " + quoted_field(text) + " is not epoch nanoseconds";
        return true;
      }
      if (j.peek() == '-' || (j.peek() >= '0' && j.peek() <= '9')) {
        std::string_view text;
        if (!j.number(text)) return false;
        e.time_ok = parse_time_us(text, TimeUnit::kNs, e.device_us);
        if (!e.time_ok) e.problem = "time " + quoted_field(text) + " is not epoch nanoseconds";
        return true;
      }
      e.problem = "time is not a number";
      return j.skip(2);
    }
    if (key == "values") {
      e.has_values = true;
      if (j.peek() != '{') {
        e.values_ok = false;
        e.problem = "values is not an object";
        return j.skip(2);
      }
      return j.object([&](const std::string& axis) {
        const int a = axis == "x" ? 0 : axis == "y" ? 1 : axis == "z" ? 2 : -1;
        if (a < 0) return j.skip(3);
        double v = 0;
        bool ok = false;
        if (j.peek() == '"') {
          std::string text;
          if (!j.string(&text)) return false;
          ok = parse_number(text, v);
        } else if (j.peek() == '-' || (j.peek() >= '0' && j.peek() <= '9')) {
          std::string_view text;
          if (!j.number(text)) return false;
          ok = parse_number(text, v);
        } else if (!j.skip(3)) {
          return false;
        }
        if (!ok) {
          e.values_ok = false;
          if (e.problem.empty()) e.problem = "values." + axis + " is not a finite number";
        } else {
          e.xyz[static_cast<size_t>(a)] = v;
          e.got_axes |= 1 << a;
        }
        return true;
      });
    }
    return j.skip(2);
  });
}

}  // namespace

JsonBatch parse_sensor_logger_batch(std::string_view body, const JsonSensorNames& names) {
  JsonBatch b;
  Json j(body);
  bool has_payload = false;
  auto refuse = [&](const std::string& why) {
    b.ok = false;
    b.reason = ips::printable(why);
    b.samples.clear();
    return b;
  };
  if (j.peek() != '{') return refuse("body is not a JSON object");
  const bool parsed = j.object([&](const std::string& key) {
    if (key == "deviceId") {
      if (j.peek() != '"') return j.skip(1);
      return j.string(&b.device_id);
    }
    if (key != "payload") return j.skip(1);
    if (j.peek() != '[') {
      j.error = "payload is not an array";
      return false;
    }
    has_payload = true;
    if (!j.eat('[')) return false;
    if (j.peek() == ']') return j.eat(']');
    for (;;) {
      if (j.peek() != '{') {
        j.error = "a payload entry is not an object";
        return false;
      }
      Entry e;
      if (!read_entry(j, e)) return false;
      int kind = -1;
      if (e.name == names.accel) kind = 0;
      else if (e.name == names.gyro) kind = 1;
      else if (e.name == names.mag) kind = 2;
      if (kind < 0) {
        ++b.other_entries;
      } else {
        std::string why = e.problem;
        if (why.empty() && !e.has_time) why = "no time";
        if (why.empty() && !e.has_values) why = "no values";
        if (why.empty() && e.got_axes != 7) why = "values lack x, y or z";
        if (!why.empty()) {
          if (b.bad_entries++ == 0) b.first_bad = ips::printable(e.name + ": " + why);
        } else {
          SensorSample s;
          s.kind = static_cast<SensorKind>(kind);
          s.device_us = e.device_us;
          const double scale = kind == 0 ? names.units.accel
                               : kind == 1 ? names.units.gyro
                                           : names.units.mag;
          for (size_t a = 0; a < 3; ++a) s.xyz[a] = e.xyz[a] * scale;
          b.samples.push_back(s);
        }
      }
      if (j.peek() == ',') {
        j.eat(',');
        continue;
      }
      return j.eat(']');
    }
  });
  if (!parsed) return refuse("not JSON: " + j.error);
  if (!j.at_end()) return refuse("bytes after the JSON object");
  if (!has_payload) return refuse("no payload array");
  b.ok = true;
  return b;
}

}  // namespace ips::phone_imu
