#pragma once
// The anchor -> server reception report of a SEWIO-style UWB TDoA system (source 004 §1, Fig. 3.2;
// docs/hardware/uwb.md): one pipe-separated ASCII record per reception,
//
//   |AAAA|E|SSSS|KK|GGG|QQQ|b0|b1|b2|b3|b4|T|                      (12 fields: 'E', a transmit)
//   |AAAA|A|SSSS|KK|GGG|QQQ|b0|b1|b2|b3|b4|T|d1|d2|d3|d4|d5|d6|d7|d8|    (20 fields: a reception)
//
//   AAAA  reporting anchor, 4 hex digits (leading 0: an anchor)
//   F     'E': the sync master's own record of its sync transmission; 'A': any reception
//   SSSS  sender, 4 hex digits (leading 0: an anchor, i.e. the sync master; leading 1: a tag)
//   KK    'aa': sync message (sent by an anchor); 'bb': tag blink
//   GGG   group sequence number, QQQ sequence number within the group (1 to 3 decimal digits)
//   b0-b4 the anchor's 40-bit counter at reception (at transmission for 'E'), 2 hex digits each,
//         most significant first; 63.8976 GHz (499.2 MHz x 128, the DW1000 clock)
//   T     MCU temperature, degrees C (004's field list puts it last, but in every example it is
//         the first value after the counter, and the only one in the 'E' example)
//   d1-d8 eight values that "determine RSSI" (004 §1); their order and meaning are not known.
//         Every 'A' record has them, no 'E' record does (a transmission has no received signal),
//         as in 004's examples; so a reception cut short after T is refused, not misread.
//
// Mapping to uwb_rx_t: the ids as sent (text, e.g. "0006"); is_sync = (KK == aa); the 'E' record
// becomes anchor_id == sender_id (the simulator's convention for the master's own record, so an
// 'E' record must name the same id twice and an 'A' record must not); seq = group * 1000 + seq;
// rx_counter from b0..b4; counter_hz 63.8976e9; quality NaN; rx_power_dbm and fp_power_dbm NaN
// unless the caller asks for the DW1000 reading of the diagnostics (PowerModel below). Pure: no
// I/O, never throws on input.
#include <array>
#include <cstdint>
#include <ips/uwb_rx_t.hpp>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace ips::uwb_tdoa_anchors {

inline constexpr double kCounterHz = 63.8976e9;
inline constexpr int64_t kCounterModulus = int64_t{1} << 40;
// The wire carries seq as group (0..999) and seq within the group (0..999).
inline constexpr int32_t kSeqModulus = 1000 * 1000;
inline constexpr size_t kDiagnosticCount = 8;
// Longest record we accept: the 20-field example is 89 bytes.
inline constexpr size_t kMaxRecordBytes = 256;

struct AnchorReport {
  std::string anchor_id;  // as sent, 4 hex digits
  std::string sender_id;  // as sent, 4 hex digits
  bool transmit = false;  // 'E': the master's own record of its sync transmission
  bool is_sync = false;   // 'aa'
  int32_t group = 0;      // 0..999
  int32_t seq_in_group = 0;
  int64_t rx_counter = 0;  // 0 .. 2^40-1
  double temperature_c = 0;
  size_t diagnostic_count = 0;  // 0 ('E') or kDiagnosticCount ('A')
  std::array<double, kDiagnosticCount> diagnostics{};

  int32_t seq() const { return group * 1000 + seq_in_group; }
};

struct AnchorReportParse {
  bool ok = false;
  AnchorReport report;
  std::string reason;  // when !ok: printable, names the field
};

// One record, without its line end; spaces and tabs around it are ignored.
AnchorReportParse parse_anchor_report(std::string_view record);

// How to read d1..d8 as receive power. They line up with the Decawave driver's dwt_rxdiag_t
// (maxNoise, firstPathAmp1, stdNoise, firstPathAmp2, firstPathAmp3, maxGrowthCIR = CIR_PWR,
// rxPreamCount, firstPath): the last is FP_INDEX in 10.6 fixed point printed as a number (744.3593
// = 47639/64), the seventh a preamble count just under a 256-symbol preamble, the amplitudes in
// the thousands. That is our inference, not documented by SEWIO, and the pulse repetition
// frequency, which sets the constant A, is not in the record; so it is opt-in.
enum class PowerModel {
  kNone,         // NaN (default)
  kDw1000Prf16,  // DW1000 user manual §4.7: A = 113.77 dB
  kDw1000Prf64,  // A = 121.74 dB
};

struct ReceivePower {
  float rx_power_dbm;
  float fp_power_dbm;
};
// DW1000 user manual §4.7.2: RX level = 10 log10(C 2^17 / N^2) - A, first path level =
// 10 log10((F1^2 + F2^2 + F3^2) / N^2) - A, with C = CIR_PWR (d6), N = preamble count (d7),
// F1..F3 = first path amplitudes (d2, d4, d5). NaN for kNone, a report without diagnostics, or
// values that give no finite level (N = 0, C = 0).
ReceivePower receive_power(const AnchorReport& r, PowerModel model);

// The message for a report received at `utime`, with ids as published (the caller may have
// renamed them, see WireIds).
uwb_rx_t to_uwb_rx(const AnchorReport& r, utime_t utime, const std::string& source,
                   const std::string& anchor_name, const std::string& sender_name,
                   PowerModel power = PowerModel::kNone);

struct AnchorReportEncode {
  bool ok = false;
  std::string record;  // without a line end
  std::string reason;
};

// The record for a message whose ids are already the 4-hex wire ids: 'E' for a sync whose anchor
// is its sender, 'A' otherwise; seq modulo kSeqModulus (the wire's wrap); the temperature given,
// and for an 'A' record eight diagnostics written as 0 (uwb_rx_t has none). Refused: ids that are
// not 4 hex digits, a blink from the anchor itself, a negative seq, a counter outside 0..2^40-1, a
// counter_hz other than 63.8976e9, a temperature outside -100..200 C.
AnchorReportEncode encode_anchor_report(const uwb_rx_t& m, double temperature_c = 25.0);

bool is_wire_id(std::string_view text);

}  // namespace ips::uwb_tdoa_anchors
