#pragma once
// Replays a capture file of the source experiments (capture_line.hpp) as ble_aoa_t: each line's
// PC time, read in the zone the caller resolves, becomes utime; each port gets its own
// EventDecoder (as if it had been a --device), with source "ips-ble-aoa:<port>", so duplicates
// and the angle range are judged per port exactly as live.
//
// Pure: lines in, messages out through the callback; the zone arrives as a function.
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "drivers/ble_aoa/capture_line.hpp"
#include "drivers/ble_aoa/event_decoder.hpp"

namespace ips::ble_aoa {

class CaptureDecoder {
 public:
  // The capture's wall-clock reading -> us since the epoch; nullopt when it has none (e.g. a
  // time skipped by a daylight-saving change, or outside 1970..2095).
  using ZoneConversion = std::function<std::optional<int64_t>(const CivilTime&)>;
  // Ports with a decoder of their own; lines of further ports are errors.
  static constexpr size_t kMaxPorts = 256;

  // `base.source` is ignored: each port's decoder publishes as "<program>:<port>".
  CaptureDecoder(std::string program, EventDecoderConfig base, ZoneConversion zone,
                 EventDecoder::Sink sink);

  // kPublished, kAtLine (the anchor's AT conversation, captured too), kDuplicate, kRangeUnknown,
  // or kError with the reason (a bad capture line or a bad +UUDF line).
  LineOutcome decode(std::string_view line);
  int64_t lines() const { return lines_; }

 private:
  std::string program_;
  EventDecoderConfig base_;
  ZoneConversion zone_;
  EventDecoder::Sink sink_;
  std::map<std::string, std::unique_ptr<EventDecoder>, std::less<>> ports_;
  int64_t lines_ = 0;
};

}  // namespace ips::ble_aoa
