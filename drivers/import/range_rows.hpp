#pragma once
// Recorded two-way ranges as text rows -> uwb_range_t, for `ips-import ranges`. One row a range:
// time, tag, anchor, range, and optionally receive power, first-path power, a sequence number and
// the anchor's position (x, y[, z]) as ROS topic dumps carry it. Columns are mapped by the
// header's names (KnownColumn aliases below), by --columns, or tagged lines (libRSF's
// "range2 t range var anchorX anchorY anchorID snr" with row_tag "range2"). A file without a tag
// or anchor column takes --tag / --anchor (one file per anchor). Rows that carry the exchange's
// raw device timestamps (DW1000 logs: poll_tx, poll_rx, resp_tx, resp_rx, and final_tx,
// final_rx for DS-TWR; rtd_init, rtd_resp checked against them) also give one
// uwb_twr_timestamps_t each, with the range computed from them (core/twr_timestamps.hpp); that
// range can replace the file's in uwb_range_t (RangeFrom::kTimestamps). Pure: text in, messages
// out.
#include <cstdint>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_twr_timestamps_t.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "core/twr_timestamps.hpp"
#include "drivers/import/row_time.hpp"

namespace ips::import {

// The columns a range file may have, in --columns names: t, tag, anchor, range, rx, fp, seq,
// quality, ax, ay, az, and the exchange's timestamps poll_tx, poll_rx, resp_tx, resp_rx,
// final_tx, final_rx, rtd_init, rtd_resp (uwb-cucudasluv's poll_tx_ts ... rtd_resp by name).
const std::vector<table::KnownColumn>& range_columns();

// Where uwb_range_t.range_m comes from when the rows carry timestamps (--range-from).
enum class RangeFrom : uint8_t {
  kFile,        // the file's range column (default)
  kTimestamps,  // the range computed from the timestamps; rows without one are rejected
};

struct RangeOptions {
  // Declared (not an aggregate): GCC 12 otherwise warns, wrongly, that a temporary RangeOptions{}
  // passed by reference may be used uninitialized (-Wmaybe-uninitialized).
  RangeOptions() {}
  std::string columns;  // --columns; empty: by header names, else "t,tag,anchor,range"
  table::ReadOptions read;
  TimeOptions time;
  table::UnitScale unit;  // ranges and anchor positions to metres (--unit)
  std::string tag;        // --tag: for files without a tag column (overrides none)
  std::string anchor;     // --anchor: for files without an anchor column
  std::string source = "ips-import";
  RangeFrom range_from = RangeFrom::kFile;
  int counter_bits = 32;                   // the stamps' counter width (--counter-bits)
  double tick_s = twr::kDw1000TickS;       // one counter tick, s
  twr::ClockOffsetOptions clock;           // SS-TWR's clock offset across exchanges
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

// What the timestamp columns gave.
struct TwrTally {
  int64_t exchanges = 0;     // uwb_twr_timestamps_t made
  int64_t ss = 0, ds = 0;    // of them, SS-TWR (4 stamps) and DS-TWR (6)
  int64_t no_offset = 0;     // SS-TWR exchanges without a clock offset yet (range uncorrected)
  int64_t no_range = 0;      // exchanges whose stamps gave no plausible range (range_m NaN)
  int64_t bad = 0;           // rows whose stamps were rejected (not numbers, beyond the counter,
                             // disagreeing with rtd_init/rtd_resp): no exchange made
  int64_t first_bad_line = 0;
  std::string first_bad_reason;
  twr::ClockOffsetTally clock;
};

struct RangeFile {
  std::vector<uwb_range_t> ranges;
  std::vector<uwb_twr_timestamps_t> exchanges;  // when the rows carry timestamps
  TwrTally twr;
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
// A range computed from timestamps is kept (uwb_twr_timestamps_t.range_m) within
// [kMinStampRangeM, kMaxRangeM]: noise and antenna delays can make a short one slightly negative.
inline constexpr double kMinStampRangeM = -10.0;

}  // namespace ips::import
