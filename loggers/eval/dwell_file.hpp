#pragma once
// The dwell-interval file of `ips-eval --dwell FILE`: known points a tag stood at, each for a
// time range, one per row: start, end, x, y[, z][, tag]. Read with the project's delimited-text
// reader (core/table_text.hpp): the separator is detected, a header maps columns by name
// (StartTimestamp|Start|StartTime|Begin, EndTimestamp|End|EndTime|Stop, X, Y, Z|Height,
// Tag|TagId|Id), times are epoch numbers (unit guessed from the first start time, or given) or
// ISO-8601, lengths are scaled to metres. The public BLE dataset's files
// (ble-byongho96 .../gt/*.csv: "StartTimestamp,EndTimestamp,X,Y" in epoch ms and cm) read with
// --dwell-unit cm. Pure: text in, intervals and a tally out.
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "loggers/eval/evaluation.hpp"

namespace ips::eval {

struct DwellFileOptions {
  // "start,end,x,y[,z][,tag]" by position ('-' skips a column); empty: from the header, or
  // start,end,x,y when there is none.
  std::string columns;
  // Numeric times: nullopt guesses the epoch unit from the first start time (s, ms, us, ns), or
  // takes it from a unit in the start column's header ("Start(ms)").
  std::optional<table::TimeUnit> time_unit;
  // Lengths: nullopt takes a unit in the x column's header ("X(cm)"), else metres.
  std::optional<table::UnitScale> unit;
  std::optional<char> separator;  // nullopt: detected
};

struct DwellFile {
  std::vector<DwellInterval> intervals;
  table::ImportTally tally;  // lines, rows accepted and rejected (the first with its reason)
  std::string columns;       // the column mapping used, e.g. "start,end,x,y"
  std::string time_unit;     // "ms", or "ISO-8601"
  double unit_factor = 1.0;  // metres per file unit
  // Empty when usable; else one line for "ips-eval: error: <error>" (no interval, or most
  // rows rejected).
  std::string error;
};

// `name` is the file's name for messages.
DwellFile read_dwell_file(std::string_view text, const std::string& name,
                          const DwellFileOptions& options);

}  // namespace ips::eval
