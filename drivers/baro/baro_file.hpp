#pragma once
// ips-baro --file: recorded barometer logs -> samples with times that come from the file only
// (never from when it is read). Two formats (docs/hardware/barometer.md, "Recorded logs"):
//
//   - the serial line format, one sample a line: "P <Pa> T <degC> [H <%>]" (baro_line_parser),
//     no time on the line: times from --rate, or from the terminal logger's banner dates;
//   - delimited text with a column list (--columns, read through core/table_text.hpp):
//       p, t, h         pressure, temperature, humidity of the file's sensor (--device)
//       NAME.p, .t, .h  those of another sensor NAME in the same file
//       NAME            NAME's pressure (e.g. "mpl" for a second barometer's column)
//       time            the row's time (s, ms, us, ns or ISO-8601; --time-unit)
//       -               a column that is not read
//     with --units, one unit per column in the same order ("0.001hPa,0.001hPa,0.001degC";
//     "-" or empty keeps the default: Pa, degC, %, and a guessed time unit).
//
// A terminal logger's lines ("Date: 2016-06-13 - 09:37:43", "Date: 13-06-2016 - 16:41:18" before
// and after the data, "-----" rules, "End log file") are not data: the dates give the start and
// end of the recording; without a time column and without --rate the rows are spread evenly
// between them (the rate is printed).
//
// Each sensor's value of each row passes reading_problem(): a 0 or non-physical pressure is
// rejected and counted for that sensor; a row is rejected (ImportTally) only when no sensor of
// it gave a sample. Pure: no I/O, never throws.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/baro/baro_reading.hpp"

namespace ips::baro {

struct FileColumn {
  enum class Role { kSkip, kTime, kPressure, kTemperature, kHumidity };
  Role role = Role::kSkip;
  int sensor = -1;  // index into FileLayout::sensors (not for kSkip, kTime)
  table::UnitScale unit;
};

struct FileLayout {
  std::vector<FileColumn> columns;  // empty: the "P <Pa> T <degC>" line format
  std::vector<std::string> sensors;  // ids; [0] is the file's own sensor (--device)
  std::optional<table::TimeUnit> time_unit;  // the time column's unit, when given
  bool has_time() const;
  int needed() const { return static_cast<int>(columns.size()); }
  std::string describe() const;  // the --columns text
};

// --columns and --units -> a layout; false with the reason (a usage error). `columns` empty: the
// line format, the file's one sensor being `device`.
bool parse_file_layout(std::string_view columns, std::string_view units, const std::string& device,
                       FileLayout& out, std::string& reason);

// "Date: 2016-06-13 - 09:37:43" or "Date: 13-06-2016 - 16:41:18" (a terminal logger's banner;
// local time read as UTC) -> us since the epoch. False when `line` is not such a line.
bool parse_banner_date(std::string_view line, int64_t& us);

struct FileOptions {
  std::string name;  // the file's name, for messages
  FileLayout layout;
  table::ReadOptions read;
  std::optional<int64_t> start_utime;  // --file-start
  std::optional<int64_t> end_utime;    // --file-end
  double rate_hz = 0;                  // --rate; 0: not given
};

struct FileSample {
  int sensor = 0;  // index into FileLayout::sensors
  int64_t utime = 0;
  BaroReading reading;
};

struct SensorTally {
  int64_t samples = 0;
  int64_t rejected = 0;
  int64_t first_rejected_line = 0;
  std::string first_reason;
  // Of the samples' pressures and temperatures, for the summary (raw per-sample noise).
  double sum_p = 0, sum_p2 = 0, sum_t = 0;
  int64_t n_t = 0;
  double mean_p() const;
  double std_p() const;  // population standard deviation, Pa
};

struct FileResult {
  // Non-empty: the file cannot be used at all (one line, e.g. no way to give the rows times).
  std::string error;
  table::ImportTally tally;
  std::vector<FileSample> samples;
  std::vector<SensorTally> sensors;  // as FileLayout::sensors
  int64_t data_rows = 0;             // rows read as data (accepted or rejected)
  std::optional<int64_t> banner_start, banner_end;
  double rate_hz = 0;     // the rate the times were made with (0: a time column)
  double derived_hz = 0;  // from the start and end dates and the row count (0: unknown)
  std::string time_note;  // how the times were made, for stderr
};

// Reads the whole text of one file.
FileResult read_baro_file(std::string_view text, const FileOptions& options);

}  // namespace ips::baro
