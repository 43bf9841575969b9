#pragma once
// Turns the text lines of a UWB tag or listener into messages: uwb_range_t for every range,
// pose_t for the position a PANS tag computes on board. Picks the parser by --format (PANS lec,
// our RANGE protocol, or either by the line's first word), stamps the host reception time,
// and numbers the ranges per tag/anchor pair (the devices give no sequence number).
// Pure: the caller supplies lines and times; messages leave through callbacks.
#include <cstdint>
#include <functional>
#include <ips/pose_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>

namespace ips::uwb_serial {

enum class LineFormat { kPans, kRangeLine, kAuto };
// "pans", "line", "auto" -> the format; nullopt for anything else.
std::optional<LineFormat> line_format_from_name(std::string_view name);

struct LineDecoderConfig {
  LineFormat format = LineFormat::kPans;
  std::string tag_id;  // the tag's id for PANS lines (they do not carry it); empty: none given
  std::string source;  // uwb_range_t/pose_t source, e.g. "ips-uwb-serial:/dev/ttyACM0"
};

struct LineOutcome {
  enum class Kind {
    kMeasurement,  // published ranges and/or a position
    kIgnored,      // not data and not an error: the PANS shell prompt, a RANGE-protocol comment
    kError,        // garbled or not in the format: `reason`
  };
  Kind kind = Kind::kError;
  std::string reason;
  int ranges = 0;                     // uwb_range_t published from this line
  bool position = false;              // pose_t published from this line
  bool position_without_fix = false;  // a PANS POS with qf 0, not published
};

struct LineDecoderStats {
  int64_t lines = 0;
  int64_t measurement_lines = 0;
  int64_t ignored_lines = 0;
  int64_t error_lines = 0;
  int64_t ranges = 0;
  int64_t positions = 0;
  int64_t positions_without_fix = 0;
};

class LineDecoder {
 public:
  using RangeSink = std::function<void(const uwb_range_t&)>;
  using PoseSink = std::function<void(const pose_t&)>;
  // Tag/anchor pairs that get their own sequence counter; beyond it seq is -1 (a device spewing
  // made-up ids must not grow memory without bound).
  static constexpr size_t kMaxSequencedPairs = 4096;

  LineDecoder(LineDecoderConfig config, RangeSink on_range, PoseSink on_pose);

  // Decodes one line read at host time `utime_us`.
  LineOutcome decode(std::string_view line, int64_t utime_us);
  const LineDecoderStats& stats() const { return stats_; }

 private:
  LineOutcome decode_pans(std::string_view line, int64_t utime_us);
  LineOutcome decode_range_line(std::string_view line, int64_t utime_us);
  int32_t next_seq(std::string_view tag_id, std::string_view anchor_id);
  void emit_range(std::string_view tag_id, std::string_view anchor_id, double range_m,
                  double rssi_dbm, int64_t utime_us);

  LineDecoderConfig config_;
  RangeSink on_range_;
  PoseSink on_pose_;
  std::map<std::string, int32_t, std::less<>> seq_;  // key: tag id, NUL, anchor id
  std::string seq_key_;
  uwb_range_t range_msg_;
  LineDecoderStats stats_;
};

}  // namespace ips::uwb_serial
