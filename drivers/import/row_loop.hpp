#pragma once
// The pass over a file's rows that every ips-import row reader shares (read_ranges, read_poses):
// lines -> TableReader -> tally; on the first data row the columns (--columns, else the header's
// names, else a default layout) and the reader's own checks; on each data row the field count, the
// row's own parsing, and its time; at the end the verdict. Pure.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "core/time.hpp"
#include "drivers/import/row_time.hpp"

namespace ips::import {

// What a reader tells the row loop about its file.
struct RowLoopSpec {
  const std::string& name;  // the file's name, for messages
  const table::ReadOptions& read;
  const TimeOptions& time;
  const std::string& columns;  // --columns; empty: by the header, else default
  const std::vector<table::KnownColumn>& known;
  const char* key;       // a header mapping counts only when it finds this column
  const char* fallback;  // the layout the verdict names when no row mapped the columns
  const char* nothing;   // the error when no message came of the file: "no range"
};

// One data row, as a reader's row function sees it.
class Row {
 public:
  Row(const table::TableReader& reader, const table::Columns& columns, std::string_view line,
      RowTimes& times, table::ImportTally& tally)
      : reader_(reader), columns_(columns), line_(line), times_(times), tally_(tally) {}

  bool has(const char* col) const { return columns_.has(col); }
  // The field of a mapped column; empty when the column is not mapped.
  std::string_view field(const char* col) const {
    const int i = columns_.index(col);
    return i < 0 ? std::string_view() : reader_.fields()[static_cast<size_t>(i)];
  }
  // Counts the row rejected for `reason`.
  void reject(const std::string& reason) const {
    tally_.reject(reader_.line_number(), line_, reason);
  }
  // The row's utime (its t field, or the --rate clock); nullopt when the row was rejected for it.
  std::optional<int64_t> time() const {
    std::string reason;
    const auto t = times_.next(field("t"), reason);
    if (!t) {
      reject(reason);
      return std::nullopt;
    }
    if (!plausible_utime(*t)) {
      reject("time not after 1970 or beyond 2096");
      return std::nullopt;
    }
    return t;
  }

 private:
  const table::TableReader& reader_;
  const table::Columns& columns_;
  std::string_view line_;
  RowTimes& times_;
  table::ImportTally& tally_;
};

// Reads `text` into `out` (a RangeFile or PoseFile: its tally, columns, time_unit,
// relative_times and error).
// - default_list(reader): the column list when neither --columns nor the header name the columns.
// - check(reader, columns): on the first data row, once the columns are mapped: "" when the file
//   can be read, else why not (the error becomes "NAME: <why>" and reading stops).
// - on_row(row): parses a data row that has the fields the columns need; true when it was used
//   (counted in tally.rows), false after row.reject().
template <class File, class DefaultList, class Check, class OnRow>
void read_rows(std::string_view text, const RowLoopSpec& spec, File& out,
               DefaultList&& default_list, Check&& check, OnRow&& on_row) {
  table::TableReader reader(spec.read);
  table::Columns columns;
  RowTimes times(spec.time);
  bool failed = false;

  for_each_line(text, [&](std::string_view line) {
    if (failed) return;
    const auto kind = reader.feed(line);
    out.tally.note(reader, kind, line);
    if (kind != table::TableReader::Kind::kData) return;

    if (reader.first_data()) {
      std::string why;
      if (!spec.columns.empty()) {
        why = columns.set_from_list(spec.columns, spec.known);
        if (!why.empty()) why = "--columns: " + why;
      } else if (reader.header().empty() ||
                 columns.set_from_header(reader.header_views(), spec.known) == 0 ||
                 !columns.has(spec.key)) {
        columns.set_from_list(default_list(reader), spec.known);
      }
      if (why.empty()) why = check(reader, columns);
      if (!why.empty()) {
        out.error = spec.name + ": " + why;
        failed = true;
        return;
      }
      out.columns = columns.describe();
    }

    const auto& f = reader.fields();
    if (static_cast<int>(f.size()) < columns.needed()) {
      out.tally.reject(reader.line_number(), line,
                       std::to_string(f.size()) + " fields, expected at least " +
                           std::to_string(columns.needed()) + " (" + columns.describe() + ")");
      return;
    }
    if (on_row(Row(reader, columns, line, times, out.tally))) ++out.tally.rows;
  });

  out.time_unit = times.describe();
  out.relative_times = times.relative();
  if (failed) return;
  table::ImportExpectation expected;
  expected.input = spec.name;
  expected.columns = out.columns.empty() ? spec.fallback : out.columns;
  expected.separator =
      reader.separator_known() ? std::optional<char>(reader.separator()) : spec.read.separator;
  expected.separator_given = spec.read.separator.has_value();
  expected.time_needed = spec.time.rate_hz <= 0;
  out.error = table::import_verdict(out.tally, expected);
  if (out.error.empty() && out.tally.messages == 0)
    out.error = spec.name + ": " + spec.nothing + (out.tally.lines == 0 ? " (an empty file)" : "");
}

}  // namespace ips::import
