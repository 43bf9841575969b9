#pragma once
// Recorded pairwise TDoA as text rows -> uwb_tdoa_t, for `ips-import tdoa`. One row a difference:
// time, anchor_a, anchor_b, diff (= distance to anchor_b - distance to anchor_a, Crazyflie's sign)
// and optionally sigma, quality, a sequence number and the tag. Columns are mapped by the
// header's names (tdoa_columns() aliases below; the UTIL dataset's flight CSVs name theirs
// t_tdoa, idA, idB, tdoa_meas), by --columns, else "t,a,b,diff". A file without a tag column
// takes --tag. A wide file that holds other sensors' rows too (UTIL's: a row per IMU, flow or
// pose sample, its TDoA fields empty) has those rows skipped, not rejected. Pure.
#include <ips/uwb_tdoa_t.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/import/row_time.hpp"

namespace ips::import {

// The columns a TDoA file may have, in --columns names: t, tag, a, b, diff, sigma, quality, seq.
const std::vector<table::KnownColumn>& tdoa_columns();

struct TdoaOptions {
  std::string columns;  // --columns; empty: by header names, else "t,a,b,diff"
  table::ReadOptions read;
  TimeOptions time;
  table::UnitScale unit;  // differences and sigmas to metres (--unit)
  std::string tag;        // --tag: for files without a tag column
  std::string source = "ips-import";
};

struct TdoaFile {
  std::vector<uwb_tdoa_t> pairs;
  std::vector<std::string> anchors;  // anchor ids seen, in order of first appearance
  table::ImportTally tally;
  int64_t other_rows = 0;  // rows with no difference (another sensor's row of a wide file)
  std::string columns;
  std::string time_unit;
  bool relative_times = false;
  std::string error;  // empty when usable
};

TdoaFile read_tdoa(std::string_view text, const std::string& name, const TdoaOptions& options);

// A difference beyond this is not one (UWB rooms are tens of metres).
inline constexpr double kMaxTdoaM = 1000.0;

}  // namespace ips::import
