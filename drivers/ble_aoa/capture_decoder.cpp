#include "drivers/ble_aoa/capture_decoder.hpp"

#include "core/device_text.hpp"

namespace ips::ble_aoa {

CaptureDecoder::CaptureDecoder(std::string program, EventDecoderConfig base, ZoneConversion zone,
                               EventDecoder::Sink sink)
    : program_(std::move(program)),
      base_(std::move(base)),
      zone_(std::move(zone)),
      sink_(std::move(sink)) {}

LineOutcome CaptureDecoder::decode(std::string_view line) {
  ++lines_;
  LineOutcome out;
  const CaptureParseResult parsed = parse_capture_line(line);
  if (!parsed.ok) {
    out.reason = parsed.reason;
    return out;
  }
  const std::optional<int64_t> utime = zone_ ? zone_(parsed.line.pc_time) : std::nullopt;
  if (!utime) {
    out.reason = "capture: time " + quoted_field(line.substr(0, line.find(','))) +
                 " does not exist in the time zone (or is before 1970)";
    return out;
  }
  auto it = ports_.find(parsed.line.port);
  if (it == ports_.end()) {
    if (ports_.size() >= kMaxPorts) {
      out.reason = "capture: more than 256 ports";
      return out;
    }
    EventDecoderConfig config = base_;
    config.source = program_ + ":" + std::string(parsed.line.port);
    it = ports_
             .emplace(std::string(parsed.line.port),
                      std::make_unique<EventDecoder>(std::move(config), sink_))
             .first;
  }
  return it->second->decode(parsed.line.payload, *utime);
}

}  // namespace ips::ble_aoa
