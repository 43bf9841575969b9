#pragma once
// Recorded two-way ranges as text rows -> uwb_range_t, for `ips-import ranges`. One row a range:
// time, tag, anchor, range, and optionally receive power, first-path power, a sequence number and
// the anchor's position (x, y[, z]) as ROS topic dumps carry it. Columns are mapped by the
// header's names (KnownColumn aliases below), by --columns, or tagged lines (libRSF's
// "range2 t range var anchorX anchorY anchorID snr" with row_tag "range2"). A file without a tag
// or anchor column takes --tag / --anchor (one file per anchor). Pure: text in, messages out.
#include <cstdint>
#include <ips/uwb_range_t.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/import/row_time.hpp"

namespace ips::import {

// The columns a range file may have, in --columns names: t, tag, anchor, range, rx, fp, seq,
// ax, ay, az, quality.
const std::vector<table::KnownColumn>& range_columns();

struct RangeOptions {
  std::string columns;  // --columns; empty: by header names, else "t,tag,anchor,range"
  table::ReadOptions read;
  TimeOptions time;
  table::UnitScale unit;  // ranges and anchor positions to metres (--unit)
  std::string tag;        // --tag: for files without a tag column (overrides none)
  std::string anchor;     // --anchor: for files without an anchor column
  std::string source = "ips-import";
};

// An anchor's position as the rows carry it: the mean, and how far it moved.
struct AnchorSeen {
  std::string id;
  int64_t rows = 0;
  double sum[3] = {0, 0, 0};
  double min[3] = {0, 0, 0};
  double max[3] = {0, 0, 0};
  bool has_z = false;
  double mean(int k) const { return rows > 0 ? sum[k] / static_cast<double>(rows) : 0.0; }
  // The largest extent of the positions seen along x, y or z, m.
  double spread() const;
};

struct RangeFile {
  std::vector<uwb_range_t> ranges;
  std::vector<AnchorSeen> anchors;  // when the rows carry anchor positions (ax, ay)
  std::vector<std::string> tags;    // tag ids seen, in order of first appearance
  table::ImportTally tally;
  std::string columns;    // the mapping used, e.g. "t,-,anchor,ax,ay,az,range,rx,fp"
  std::string time_unit;  // RowTimes::describe()
  bool relative_times = false;
  // Empty when usable; else one line for "ips-import: error: <error>".
  std::string error;
};

// `name` is the file's name for messages.
RangeFile read_ranges(std::string_view text, const std::string& name, const RangeOptions& options);

// Valid ranges: 0 <= range <= kMaxRangeM; powers -200..+50 dBm.
inline constexpr double kMaxRangeM = 1000.0;

}  // namespace ips::import
