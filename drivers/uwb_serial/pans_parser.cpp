#include "drivers/uwb_serial/pans_parser.hpp"

#include <cmath>

#include "core/device_text.hpp"

namespace ips::uwb_serial {

namespace {

// DIST, n, 16 anchors of 6 fields, POS and its 4: anything longer is not a lec line.
constexpr size_t kMaxFields = 2 + 6 * kMaxPansAnchors + 5;

struct Fields {
  std::array<std::string_view, kMaxFields> at;
  size_t count = 0;
  bool too_many = false;
};

void split_commas(std::string_view line, Fields& f) {
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    const std::string_view field = line.substr(
        start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    if (f.count == kMaxFields) {
      f.too_many = true;
      return;
    }
    f.at[f.count++] = field;
    if (comma == std::string_view::npos) return;
    start = comma + 1;
  }
}

bool is_hex(char c) {
  return (c >= '0' && c <= '9') || (c >= 'A' && c <= 'F') || (c >= 'a' && c <= 'f');
}

bool parse_coordinate(std::string_view field, double& v) {
  return parse_decimal(field, v) && std::fabs(v) <= kMaxCoordinateM;
}

PansParseResult error(std::string reason) {
  PansParseResult r;
  r.kind = PansParseResult::Kind::kError;
  r.reason = std::move(reason);
  return r;
}

// "POS,x,y,z,qf" from fields[i] (the word POS) on; the fields must end with it.
bool parse_position(const Fields& f, size_t i, PansPosition& pos, std::string& reason) {
  const size_t after = f.count - i - 1;
  if (after != 4) {
    reason = "POS: expected x,y,z,qf (4 fields), got " + std::to_string(after);
    return false;
  }
  static const char* const kAxis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    const std::string_view field = f.at[i + 1 + static_cast<size_t>(k)];
    if (!parse_coordinate(field, pos.position_m[k])) {
      reason =
          std::string("POS: ") + kAxis[k] + " " + quoted_field(field) + " is not a coordinate in m";
      return false;
    }
  }
  int64_t qf = 0;
  if (!parse_integer(f.at[i + 4], qf) || qf < 0 || qf > 100) {
    reason = "POS: quality factor " + quoted_field(f.at[i + 4]) + " is not 0..100";
    return false;
  }
  pos.quality_percent = static_cast<int>(qf);
  return true;
}

}  // namespace

bool looks_like_pans_line(std::string_view line) {
  return line.starts_with("DIST,") || line.starts_with("POS,") || line.starts_with("dwm>");
}

PansParseResult parse_pans_line(std::string_view line) {
  while (!line.empty() && (line.back() == ' ' || line.back() == '\t')) line.remove_suffix(1);
  if (line.starts_with("dwm>")) {
    PansParseResult r;
    r.kind = PansParseResult::Kind::kShellText;
    return r;
  }
  Fields f;
  split_commas(line, f);
  if (f.too_many) return error("more than " + std::to_string(kMaxFields) + " fields");

  PansParseResult r;
  r.kind = PansParseResult::Kind::kMeasurement;
  std::string reason;
  if (f.at[0] == "POS") {
    PansPosition pos;
    if (!parse_position(f, 0, pos, reason)) return error(std::move(reason));
    r.line.position = pos;
    return r;
  }
  if (f.at[0] != "DIST") {
    return error("not a PANS lec line (expected DIST, POS or the dwm> prompt, got " +
                 quoted_field(f.at[0]) + ")");
  }
  if (f.count < 2) return error("DIST: no anchor count");
  int64_t n = 0;
  if (!parse_integer(f.at[1], n) || n < 0 || n > static_cast<int64_t>(kMaxPansAnchors)) {
    return error("DIST: anchor count " + quoted_field(f.at[1]) + " is not 0.." +
                 std::to_string(kMaxPansAnchors));
  }
  const auto anchors = static_cast<size_t>(n);
  size_t i = 2;
  for (size_t a = 0; a < anchors; ++a, i += 6) {
    if (i + 6 > f.count || (i < f.count && f.at[i] == "POS")) {
      return error("DIST: says " + std::to_string(anchors) + " anchors, line has " +
                   std::to_string(a) + (i < f.count && f.at[i] != "POS" ? " and a cut one" : ""));
    }
    const std::string label = "AN" + std::to_string(a);
    if (f.at[i] != label) {
      return error("DIST: expected " + label + " at field " + std::to_string(i + 1) + ", got " +
                   quoted_field(f.at[i]));
    }
    PansAnchorRange& range = r.line.ranges[a];
    const std::string_view id = f.at[i + 1];
    if (id.size() != 4 || !is_hex(id[0]) || !is_hex(id[1]) || !is_hex(id[2]) || !is_hex(id[3])) {
      return error(label + ": id " + quoted_field(id) + " is not 4 hex digits");
    }
    for (size_t k = 0; k < 4; ++k) {
      const char c = id[k];
      range.anchor_id[k] = (c >= 'a' && c <= 'f') ? static_cast<char>(c - 'a' + 'A') : c;
    }
    range.anchor_id[4] = '\0';
    static const char* const kAxis[3] = {"x", "y", "z"};
    for (size_t k = 0; k < 3; ++k) {
      if (!parse_coordinate(f.at[i + 2 + k], range.anchor_position_m[k])) {
        return error(label + ": " + kAxis[k] + " " + quoted_field(f.at[i + 2 + k]) +
                     " is not a coordinate in m");
      }
    }
    const std::string_view dist = f.at[i + 5];
    if (!parse_decimal(dist, range.range_m)) {
      return error(label + ": distance " + quoted_field(dist) + " is not a number");
    }
    if (range.range_m < 0 || range.range_m > kMaxRangeM) {
      return error(label + ": distance " + quoted_field(dist) + " m is outside 0.." +
                   std::to_string(static_cast<int>(kMaxRangeM)) + " m");
    }
  }
  r.line.num_ranges = anchors;
  if (i == f.count) return r;
  if (f.at[i] == "POS") {
    PansPosition pos;
    if (!parse_position(f, i, pos, reason)) return error(std::move(reason));
    r.line.position = pos;
    return r;
  }
  if (f.at[i].starts_with("AN")) {
    return error("DIST: says " + std::to_string(anchors) + " anchors, more follow");
  }
  return error("DIST: unexpected field " + quoted_field(f.at[i]) + " at field " +
               std::to_string(i + 1));
}

}  // namespace ips::uwb_serial
