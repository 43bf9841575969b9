#pragma once
// Reader for files of decoded +UUDF fields, one row per event, as the public BLE AoA datasets
// keep them (docs/hardware/ble-aoa.md, "Files of decoded fields"): a logger on the PC parsed
// each anchor's +UUDF lines into columns, usually one file per anchor:
//
//   Timestamp,Tag,RSSI,Azimuth,Elevation,Channel,Anchor,Sequence
//   1742248940709,6C1DEBA3FFAC,-57,-5,-20,20,6C1DEBA09949,37107
//
//   Timestamp,TagID,1stP,Azimuth,Elevation,2ndP,Channel,AnchorID      (older firmware)
//   1670598712042,8401,-70,-32,-12,-75,37,6502
//
//   Timestamp,Data                                                      (the line kept whole)
//   2025-04-21T21:59:30.156096,"+UUDF:6C1DEBA3FFAC,-69,16,-7,0,17,""6C1DEBA09949"","""",4336143,5778"
//
// Columns (names for --columns; header names are matched by their aliases, core/table_text.hpp):
// t (epoch s/ms/us/ns or ISO-8601, UTC unless it carries an offset), tag, rssi, azimuth,
// elevation, rssi2 (the reserved field: older firmware's second polarisation), channel, anchor,
// seq (the event counter), uptime (ms), user, or uudf (a whole +UUDF line). Ids are MACs or
// numbers (1 to 32 of [A-Za-z0-9_.:-]). Without a header and without --columns the layout is
// detected from the first row: eight fields with a negative sixth (an RSSI) are the older
// "t,tag,rssi,azimuth,elevation,rssi2,channel,anchor", else "t,tag,rssi,azimuth,elevation,
// channel,anchor,seq"; two fields "t,uudf".
//
// Each row goes through an EventDecoder (angle range, renaming, duplicates) exactly as a line
// read live. Pure: lines in, messages out through the callback; never throws.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/table_text.hpp"
#include "drivers/ble_aoa/event_decoder.hpp"

namespace ips::ble_aoa {

// The columns this reader knows, with their header aliases.
const std::vector<table::KnownColumn>& uudf_table_columns();
inline constexpr std::string_view kUudfTableDefaultColumns =
    "t,tag,rssi,azimuth,elevation,channel,anchor,seq";
inline constexpr std::string_view kUudfTableOlderColumns =
    "t,tag,rssi,azimuth,elevation,rssi2,channel,anchor";

struct UudfTableOptions {
  table::ReadOptions read;               // separator (nullopt: detected), header mode
  std::string columns;                   // --columns; empty: by header, else detected
  std::optional<table::TimeUnit> time_unit;  // nullopt: guessed from the first epoch time
};

class UudfTableDecoder {
 public:
  // `base.source` is what the messages carry (e.g. "ips-ble-aoa:anchor1.csv").
  UudfTableDecoder(UudfTableOptions options, EventDecoderConfig base, EventDecoder::Sink sink);

  // One line of the file, without its newline.
  void decode(std::string_view line);

  // Rows read, rejected (with the first reason), messages made.
  const table::ImportTally& tally() const { return tally_; }
  const EventDecoderStats& events() const { return decoder_.stats(); }
  // The mapping in use ("t,tag,rssi,..."), once the first data row was read; else the one asked.
  std::string columns() const;
  // The time unit numbers were read in, once known.
  std::optional<table::TimeUnit> time_unit() const { return unit_; }
  // For import_verdict.
  table::ImportExpectation expectation(std::string input) const;
  // A problem with the mapping itself (a --columns name not known; a header without a time,
  // azimuth or anchor column): every row is then rejected with it.
  const std::string& mapping_error() const { return mapping_error_; }
  int64_t first_utime() const { return first_utime_; }
  int64_t last_utime() const { return last_utime_; }

 private:
  void set_up_columns(const std::vector<std::string_view>& row);
  // The row's event and time, or the reason it is rejected.
  std::string decode_row(const std::vector<std::string_view>& f);

  UudfTableOptions options_;
  table::TableReader reader_;
  EventDecoder decoder_;
  table::Columns columns_;
  table::ImportTally tally_;
  std::optional<table::TimeUnit> unit_;
  std::string mapping_error_, event_line_;
  bool set_up_ = false;
  int64_t first_utime_ = 0, last_utime_ = 0;
  // Column indices, -1 when absent.
  int t_ = -1, tag_ = -1, rssi_ = -1, az_ = -1, el_ = -1, rssi2_ = -1, channel_ = -1,
      anchor_ = -1, seq_ = -1, uptime_ = -1, user_ = -1, uudf_ = -1;
};

// True when `line` looks like a line of the source experiments' capture (capture_line.hpp:
// "date time,port,+UUDF..."), not a row of decoded fields: tells the two file kinds apart.
bool looks_like_capture_line(std::string_view line);

}  // namespace ips::ble_aoa
