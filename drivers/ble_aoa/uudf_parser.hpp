#pragma once
// Parser for what a u-blox XPLR-AOA anchor (C211 board, NINA-B411 with u-connectLocate) prints on
// its serial port: +UUDF angle-of-arrival events, and the lines of the AT conversation around
// them (docs/hardware/ble-aoa.md):
//
//   +UUDF:<tag>,<rssi>,<azimuth>,<elevation>,<reserved>,<channel>,"<anchor>","<user>",<uptime_ms>[,<counter>]
//   +UUDF:6C1DEBA5F60C,-68,-30,42,0,37,"6C1DEBA09862","",1606101,25
//
// <tag>: the tag's id (its Eddystone instance id, 12 hex digits), <rssi>: dBm of the first
// polarisation, <azimuth>/<elevation>: degrees as the firmware gives them (-90..90; older
// firmware 0..180, converted by the decoder, not here), <reserved>: RFU (older firmware: the
// second polarisation's RSSI), <channel>: the BLE channel (37..39 for advertisements),
// <anchor>: the anchor id (+UDFCFG tag 4, by default the anchor's MAC), <user>: the user string
// (+UDFCFG tag 2), <uptime_ms>: ms since the anchor booted, <counter>: the event counter, only in
// the newest firmware (nine fields before that).
//
// Pure: no I/O, never throws. Reasons are printable ASCII (quoted_field).
#include <cstdint>
#include <string>
#include <string_view>

namespace ips::ble_aoa {

inline constexpr size_t kMaxIdLength = 32;
// +UDFCFG tag 2 allows 30 characters; we accept a little more rather than lose an event.
inline constexpr size_t kMaxUserStringLength = 64;
inline constexpr double kMinRssiDbm = -128.0;
inline constexpr double kMaxRssiDbm = 20.0;
// Raw angles: the union of the two firmware ranges (-90..90 and 0..180).
inline constexpr double kMinRawAngleDeg = -90.0;
inline constexpr double kMaxRawAngleDeg = 180.0;
inline constexpr int kMaxBleChannel = 39;

struct UudfEvent {
  std::string_view tag_id;  // views into the parsed line
  double rssi_dbm = 0;
  double azimuth_raw_deg = 0;
  double elevation_raw_deg = 0;
  double reserved = 0;
  int channel = 0;
  std::string_view anchor_id;    // without its quotes
  std::string_view user_string;  // without its quotes, raw bytes
  int64_t uptime_ms = 0;
  bool has_counter = false;  // ten fields (newest firmware)
  int32_t counter = -1;
};

// The lines of the AT conversation that are not +UUDF events.
enum class AtLine {
  kOk,        // "OK": the command was accepted
  kError,     // "ERROR" (or "+CME ERROR..."): it was not
  kStartup,   // "+STARTUP": the anchor (re)booted
  kEcho,      // the anchor echoing a command we sent ("AT..." while echo is on)
  kResponse,  // an information response, e.g. "+UMLA:6C1DEBA09862p", "+UDFCFG:1,50"
};

struct UudfParseResult {
  enum class Kind { kEvent, kAtLine, kError };
  Kind kind = Kind::kError;
  UudfEvent event;          // kEvent
  AtLine at = AtLine::kOk;  // kAtLine
  std::string reason;       // kError
};

UudfParseResult parse_uudf_line(std::string_view line);

// True for an id we accept (tag, anchor, --anchor-name target): 1 to 32 of [A-Za-z0-9_.:-].
bool valid_id(std::string_view id);

}  // namespace ips::ble_aoa
