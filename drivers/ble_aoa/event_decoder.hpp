#pragma once
// Turns the lines one XPLR-AOA anchor port prints into ble_aoa_t: parses +UUDF events
// (uudf_parser.hpp), converts the angles of older firmware, renames anchors, drops duplicates,
// stamps the host reception time, and tells the caller about the AT conversation's lines.
//
// Angle range. Current firmware reports both angles in -90..90 deg (u-blox XPLR-AOA user guide,
// +UUDF). Older firmware reported 0..180 (source 000, section 1) and the source does not give
// the conversion: we ASSUME theta = raw - legacy_offset_deg with offset 90 (boresight at 90), for
// azimuth and elevation alike. kAuto decides per anchor id: a ten-field line (a counter: newest
// firmware) or any negative angle means -90..90; any angle above 90 means 0..180; until one of
// these is seen, a nine-field event is dropped (counted as kRangeUnknown), never guessed.
//
// Duplicates. With a counter (ten fields): an event whose anchor, tag and counter equal one of
// the last kRecentPerPair events of that anchor and tag is dropped. Without a counter (nine
// fields): an event whose fields all equal (anchor, tag, RSSI, angles, reserved, channel, user
// string, uptime) one of those received within duplicate_window_s of host time is dropped.
//
// seq: the firmware's counter, or -1 when the line has none.
//
// Pure: the caller supplies lines and times; messages leave through a callback.
#include <array>
#include <cstdint>
#include <functional>
#include <ips/ble_aoa_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "drivers/ble_aoa/uudf_parser.hpp"

namespace ips::ble_aoa {

enum class AngleRange { kPlusMinus90, kZeroTo180, kAuto };
// "pm90", "0-180", "auto" -> the range; nullopt for anything else.
std::optional<AngleRange> angle_range_from_name(std::string_view name);

struct EventDecoderConfig {
  std::string source;  // ble_aoa_t.source, e.g. "ips-ble-aoa:/dev/ttyACM0"
  AngleRange angle_range = AngleRange::kPlusMinus90;
  double legacy_offset_deg = 90.0;
  double duplicate_window_s = 0.5;
  // Hardware anchor id (as in +UUDF) -> the id to publish (the site file's, e.g. "A1").
  std::map<std::string, std::string, std::less<>> anchor_names;
  // The same for tag ids (e.g. the tag's MAC -> the site file's "T1").
  std::map<std::string, std::string, std::less<>> tag_names;
};

struct LineOutcome {
  enum class Kind {
    kPublished,     // a ble_aoa_t went out
    kAtLine,        // a line of the AT conversation: `at`
    kDuplicate,     // a repeated event, dropped
    kRangeUnknown,  // --angle-range auto, nothing seen yet from this anchor to decide: dropped
    kError,         // garbled or out of range: `reason`
  };
  Kind kind = Kind::kError;
  AtLine at = AtLine::kOk;
  std::string reason;
};

struct EventDecoderStats {
  int64_t lines = 0;
  int64_t published = 0;
  int64_t at_lines = 0;
  int64_t duplicates = 0;
  int64_t range_unknown = 0;
  int64_t errors = 0;
};

class EventDecoder {
 public:
  using Sink = std::function<void(const ble_aoa_t&)>;
  // Anchor/tag pairs with duplicate memory and anchors with a remembered angle-range decision
  // (a device spewing made-up ids must not grow memory without bound): beyond these, new pairs
  // get no duplicate check and kAuto judges each event of a new anchor on its own.
  static constexpr size_t kMaxPairs = 4096;
  static constexpr size_t kMaxAnchors = 256;
  static constexpr size_t kRecentPerPair = 8;

  EventDecoder(EventDecoderConfig config, Sink sink);

  // Decodes one line read at host time `utime_us`.
  LineOutcome decode(std::string_view line, int64_t utime_us);
  // Decodes one event whose fields were already parsed and checked (a row of decoded +UUDF
  // fields, uudf_table.hpp): kPublished, kDuplicate, kRangeUnknown or kError.
  LineOutcome decode_event(const UudfEvent& event, int64_t utime_us);
  const EventDecoderStats& stats() const { return stats_; }

 private:
  struct Recent {
    int64_t utime_us = 0;
    bool has_counter = false;
    int32_t counter = -1;
    double rssi = 0, az = 0, el = 0, reserved = 0;
    int channel = 0;
    int64_t uptime_ms = 0;
    std::string user_string;
  };
  struct PairMemory {
    std::array<Recent, kRecentPerPair> recent;
    size_t next = 0;
    size_t size = 0;
  };
  bool duplicate(const UudfEvent& e, int64_t utime_us);
  // The range to convert this anchor's event with; nullopt: not known yet.
  std::optional<AngleRange> range_for(const UudfEvent& e);
  LineOutcome finish(LineOutcome out);

  EventDecoderConfig config_;
  Sink sink_;
  std::map<std::string, PairMemory, std::less<>> pairs_;  // key: anchor id, NUL, tag id
  std::map<std::string, AngleRange, std::less<>> anchor_range_;
  std::string key_;
  ble_aoa_t msg_;
  EventDecoderStats stats_;
};

}  // namespace ips::ble_aoa
