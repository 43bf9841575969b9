#pragma once
// Delimited text as real recordings come: a phone app's CSV, a ROS topic dump, a u-blox capture
// of decoded +UUDF fields, a microcontroller's serial log, motion-capture truth. One reader for
// every file input of the project (drivers' --file/--capture modes, ips-import, ips-eval --dwell):
//
//   - the separator (',' ';' tab, or runs of blanks) is given or detected from the first data line;
//   - lines before the first data line are a preamble (a terminal program's banner, a date line)
//     and the last of them with as many fields as the data is the column header, so columns can
//     be mapped by name ("%time", "field.distanceFromTag", "Timestamp(ms)" all normalise);
//   - a column mapping is a list of known names ("t,ax,ay,az", '-' skips a column), a header
//     matched against each known name's aliases, or the caller's default;
//   - times are numbers in s, ms, us or ns, or ISO-8601 date-times; epoch or since-boot, placed
//     with a start time, or made from a row rate when the file has no time column;
//   - units are SI after a factor ("0.001hPa", "cm", "deg/s", "g").
// Pure: no I/O, never throws; every string it returns is printable ASCII.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ips::table {

// --- fields ----------------------------------------------------------------------------------

// ',' ';' '\t', or ' ' for runs of spaces and tabs.
inline constexpr char kBlanks = ' ';
// "," ";" "tab" "\t" "space" "whitespace" " " (and "comma", "semicolon").
std::optional<char> separator_from_name(std::string_view name);
// "comma", "semicolon", "tab", "whitespace".
const char* separator_name(char separator);
// The flag value that selects it: ",", ";", "tab", "space".
const char* separator_flag(char separator);
// The separator that splits `line` into the most fields (outside double quotes): tab, ';', ','
// in that order on a tie; blanks when none of them occurs.
char detect_separator(std::string_view line);

inline constexpr size_t kMaxFields = 512;
// Splits on `separator` (runs of blanks for ' '); fields are trimmed of blanks and of one pair of
// surrounding double quotes. False when the line has more than kMaxFields fields.
bool split_fields(std::string_view line, char separator, std::vector<std::string_view>& out);

// A finite decimal number: optional sign, digits, fraction, exponent ("1.7345e+18", "-.5").
bool parse_number(std::string_view field, double& value);
bool is_number(std::string_view field);

// --- units -----------------------------------------------------------------------------------

enum class Quantity : uint8_t {
  kLength,        // m, cm, mm, km, ft, in
  kPressure,      // Pa, hPa, kPa, mbar, bar, mmHg, inHg
  kTemperature,   // degC (C), K, degF
  kAcceleration,  // m/s2 (m/s^2), g
  kAngularRate,   // rad/s, deg/s (dps)
  kMagnetic,      // uT, mG, G, nT, T
  kAngle,         // rad, deg
  kRatio,         // 1, % (humidity)
};
// value_si = value * factor + offset.
struct UnitScale {
  double factor = 1.0;
  double offset = 0.0;
  double to_si(double v) const { return v * factor + offset; }
};
// A unit, optionally preceded by a positive number ("0.001hPa", "1e-3 m", "cm"): nullopt when it
// is not a unit of `q`.
std::optional<UnitScale> parse_unit(std::string_view spec, Quantity q);
// The unit names `q` takes, for an error message ("m, cm, mm, km, ft, in").
const char* unit_names(Quantity q);

// --- time ------------------------------------------------------------------------------------

enum class TimeUnit : uint8_t { kS, kMs, kUs, kNs };
// "s" | "ms" | "us" | "ns".
std::optional<TimeUnit> time_unit_from_name(std::string_view name);
const char* time_unit_name(TimeUnit unit);
// The unit an epoch time of this magnitude is most likely in (about 1e9 s, 1e12 ms, 1e15 us,
// 1e18 ns, for times from 2001 to 2286); nullopt when it is not an epoch time in any of them.
std::optional<TimeUnit> guess_epoch_unit(double value);

// An ISO-8601 date-time, "2024-12-18T05:58:05.123Z", "2024-12-18 05:58:05", "...+09:00" (UTC
// when no offset is given) -> us since the Unix epoch.
bool parse_iso8601_us(std::string_view field, int64_t& us);
// A time field: an ISO-8601 date-time, or a number in `unit` (integers exactly, integer ns
// truncated to the us, fractions rounded to the us) -> us. False when neither, or beyond +-4e18 us.
bool parse_time_us(std::string_view field, TimeUnit unit, int64_t& us);

// Where the rows of a file are in time. Built from --time-unit, --file-start, --rate:
//   - a time column, no start: the times are Unix epoch (since_boot() tells when they look not);
//   - a time column and a start: the first row is at `start`, the others keep their spacing;
//   - no time column (rate_hz > 0): row k is at start + k / rate_hz (start 0 when not given).
class RowClock {
 public:
  RowClock() = default;
  RowClock(std::optional<int64_t> start_utime, double rate_hz)
      : start_(start_utime), rate_hz_(rate_hz) {}

  // The utime of the next row: from its time column (t_us) or, with a rate, from its index.
  // nullopt when the row has no time and there is no rate.
  std::optional<int64_t> next(std::optional<int64_t> t_us);
  bool uses_rate() const { return rate_hz_ > 0; }
  // True when the first time read from a column, with no start given, is before 2001: a clock
  // since boot or since the recording's start rather than Unix epoch.
  bool since_boot() const { return since_boot_; }

 private:
  std::optional<int64_t> start_;
  double rate_hz_ = 0;
  int64_t rows_ = 0;
  bool have_first_ = false, since_boot_ = false;
  int64_t first_t_ = 0;
};

// --- column mappings -------------------------------------------------------------------------

// A column a reader knows: its name in --columns, and the header names that mean it (separated
// by '|', compared normalised: lower case, without a leading '%' or "field.", without a unit in
// brackets, '_' ' ' '-' '.' ignored). Aliases are tried in order over the whole header, so the
// first alias that occurs wins.
struct KnownColumn {
  std::string_view name;
  std::string_view aliases;
};

std::string normalise_header_name(std::string_view name);

class Columns {
 public:
  // Positional, from "t,ax,ay,az" ('-' skips a column, a trailing column may be left out): the
  // reason when a name is not known or given twice.
  std::string set_from_list(std::string_view list, const std::vector<KnownColumn>& known);
  // By name, from a header's fields; a known column no alias of which occurs stays unmapped.
  // Returns the number of known columns mapped.
  int set_from_header(const std::vector<std::string_view>& header,
                      const std::vector<KnownColumn>& known);

  // The column of `name`, or -1.
  int index(std::string_view name) const;
  bool has(std::string_view name) const { return index(name) >= 0; }
  // Fields a row must have: the largest mapped index + 1.
  int needed() const { return needed_; }
  // The mapping as a --columns value ("t,-,ax,ay,az"), for messages.
  std::string describe() const;
  bool empty() const { return names_.empty(); }

 private:
  std::vector<std::pair<std::string, int>> names_;
  int needed_ = 0;
};

// --- reading lines ---------------------------------------------------------------------------

enum class HeaderMode : uint8_t { kAuto, kNone, kPresent };

struct ReadOptions {
  std::optional<char> separator;  // nullopt: detected from the first data line
  HeaderMode header = HeaderMode::kAuto;
  // Only rows whose first field is this (tagged lines, e.g. libRSF's "range2 ..."); the tag is
  // then column 0. Other rows are counted as other_rows.
  std::string row_tag;
  size_t max_preamble_lines = 64;
};

class TableReader {
 public:
  enum class Kind : uint8_t {
    kEmpty,     // blank line
    kComment,   // starts with '#' (after blanks), or "//"
    kPreamble,  // before the first data line and not data (banner, header)
    kData,      // fields() holds the row
    kOtherRow,  // a row of another tag (ReadOptions::row_tag)
    kTooWide,   // more than kMaxFields fields
  };

  explicit TableReader(ReadOptions options = {}) : options_(std::move(options)) {}

  // One line without its newline; fields() views point into it.
  Kind feed(std::string_view line);
  const std::vector<std::string_view>& fields() const { return fields_; }
  int64_t line_number() const { return line_number_; }

  // Known once the first data line was read.
  char separator() const { return separator_; }
  bool separator_known() const { return separator_ != 0; }
  // The column header (the last preamble line with as many fields as the first data line), empty
  // when there was none. Set when the first data line is read.
  const std::vector<std::string>& header() const { return header_; }
  std::vector<std::string_view> header_views() const;
  // True while feed() returns the first data line.
  bool first_data() const { return data_rows_ == 1 && just_first_; }
  int64_t data_rows() const { return data_rows_; }
  int64_t preamble_lines() const { return preamble_; }
  const std::string& first_preamble() const { return first_preamble_; }

 private:
  bool looks_like_data(std::string_view line, char separator);

  ReadOptions options_;
  std::vector<std::string_view> fields_;
  std::vector<std::string> header_;
  std::string candidate_header_, first_preamble_;
  char separator_ = 0;
  int64_t line_number_ = 0, data_rows_ = 0, preamble_ = 0;
  bool just_first_ = false;
};

// --- nothing silent --------------------------------------------------------------------------

// What an import read and rejected, and the one line that says what went wrong when it failed.
struct ImportTally {
  int64_t lines = 0;         // lines read
  int64_t preamble = 0;      // header and banner lines before the data
  int64_t skipped = 0;       // comments, blank lines, rows of other tags: not errors
  int64_t rows = 0;          // data rows accepted
  int64_t bad = 0;           // data rows rejected
  int64_t messages = 0;      // messages made
  int64_t first_bad_line = 0;
  std::string first_bad_text;    // the line, cut and made printable
  std::string first_bad_reason;  // why
  std::string first_preamble;    // the first line that was not data

  // Counts a line by what the reader made of it: every kind but kData is counted here (a data
  // row is then counted by the caller as ++rows or reject()).
  void note(const TableReader& reader, TableReader::Kind kind, std::string_view line);
  // Counts a rejected row; the first one is kept for the verdict.
  void reject(int64_t line_number, std::string_view line, std::string_view reason);
};

// What the import expected, for the verdict's hint.
struct ImportExpectation {
  std::string input;              // the file's name
  std::string columns;            // the mapping in use, e.g. "t,ax,ay,az"
  std::optional<char> separator;  // the separator in use when known
  bool separator_given = false;   // from --separator (else detected)
  bool time_needed = true;        // rows need a time (no --rate)
};

// Empty when the import is acceptable. Otherwise one line (for "<program>: error: <line>"),
// when the input was not empty and 0 messages came of it, or more than half of its data rows were
// rejected:
//   "F: 0 messages from 19405 lines; line 2 '1.0,2.0,3.0': 1 fields, expected at least 4
//    (t,ax,ay,az); looks comma-separated: try --separator ,"
std::string import_verdict(const ImportTally& tally, const ImportExpectation& expected);
// A hint for a rejected line: another separator that splits it into more fields ("looks
// comma-separated: try --separator ,"), else empty.
std::string separator_hint(std::string_view line, std::optional<char> used);

// `text` cut to at most `max` characters with non-printable bytes shown as '?', for messages.
std::string excerpt(std::string_view text, size_t max = 60);

}  // namespace ips::table
