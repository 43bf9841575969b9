#pragma once
// ips-export's pure part: decodes one LCM message of any ips type (by its fingerprint) into CSV
// rows and a JSON object. No file I/O here; main.cpp reads the log and writes the files.
//
// CSV (docs/programs.md#ips-export): one header row of field names with units, arrays flattened
// (position_x_m, position_cov_xy_m2, ...), strings quoted per RFC 4180 when they hold a comma, a
// quote, CR or LF, booleans as 0/1, NaN as "NaN" and infinities as "Inf"/"-Inf" (read by pandas
// read_csv and MATLAB readtable as numbers). site_t has one row per site element (anchor,
// baro_station, tag); its YAML text is in the JSON lines only.
// JSON lines: one object per message with "channel", "log_time_us", "type" and every field under
// the CSV column names (site_t nested: anchors, baro_stations, tags, site_yaml); NaN and
// infinities are null. Numbers are printed shortest-round-trip (std::to_chars).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>
#include "core/text_escape.hpp"

namespace ips::log_export {

// One CSV cell. float is kept apart from double so that it prints with float's shortest digits.
using Cell = std::variant<int64_t, double, float, bool, std::string>;

struct Decoded {
  std::string type;                         // LCM type name without package, e.g. "pose_t"
  const std::vector<std::string>* columns;  // CSV header: the same for every message of a type
  std::vector<std::vector<Cell>> rows;      // CSV rows (one, except site_t: one per element)
  std::string json;                         // "{...}" with every field, without channel/log time
};

// Tries every ips type (the generated decode checks the 8-byte fingerprint first). nullopt when
// no type matches or the bytes are corrupt. Never throws.
std::optional<Decoded> decode_any(const void* data, size_t size);

// Names of every type decode_any knows, e.g. for --help and the docs.
std::vector<std::string> known_types();

// Shortest text that reads back to the same value; "NaN", "Inf", "-Inf" when not finite.
std::string format_number(double v);
std::string format_number(float v);

// RFC 4180: quoted (with quotes doubled) when the text holds a comma, a quote, CR or LF; the bytes
// are not otherwise altered.
std::string csv_quote(std::string_view s);
// JSON string literals: ips::json_quote (core/text_escape.hpp).
using ips::json_quote;

std::string csv_line(const std::vector<std::string>& columns);  // header, "\n"-terminated
std::string csv_line(const std::vector<Cell>& row);
// {"channel": ..., "log_time_us": ..., "type": ..., <fields>}, "\n"-terminated.
std::string json_line(std::string_view channel, int64_t log_time_us, const Decoded& msg);

// A file name for a channel: bytes outside [A-Za-z0-9_.-] become '_', and a name that is empty or
// starts with '.' gets a leading '_' (a channel name came off the wire and must not escape --out).
std::string file_stem(std::string_view channel);

}  // namespace ips::log_export
