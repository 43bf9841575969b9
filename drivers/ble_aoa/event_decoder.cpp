#include "drivers/ble_aoa/event_decoder.hpp"

#include <cmath>

#include "core/device_text.hpp"

namespace ips::ble_aoa {

std::optional<AngleRange> angle_range_from_name(std::string_view name) {
  if (name == "pm90") return AngleRange::kPlusMinus90;
  if (name == "0-180") return AngleRange::kZeroTo180;
  if (name == "auto") return AngleRange::kAuto;
  return std::nullopt;
}

EventDecoder::EventDecoder(EventDecoderConfig config, Sink sink)
    : config_(std::move(config)), sink_(std::move(sink)) {
  msg_.source = config_.source;
}

LineOutcome EventDecoder::finish(LineOutcome out) {
  switch (out.kind) {
    case LineOutcome::Kind::kPublished:
      ++stats_.published;
      break;
    case LineOutcome::Kind::kAtLine:
      ++stats_.at_lines;
      break;
    case LineOutcome::Kind::kDuplicate:
      ++stats_.duplicates;
      break;
    case LineOutcome::Kind::kRangeUnknown:
      ++stats_.range_unknown;
      break;
    case LineOutcome::Kind::kError:
      ++stats_.errors;
      break;
  }
  return out;
}

std::optional<AngleRange> EventDecoder::range_for(const UudfEvent& e) {
  if (config_.angle_range != AngleRange::kAuto) return config_.angle_range;
  auto it = anchor_range_.find(e.anchor_id);
  if (it != anchor_range_.end()) return it->second;
  std::optional<AngleRange> decided;
  if (e.has_counter || e.azimuth_raw_deg < 0 || e.elevation_raw_deg < 0) {
    decided = AngleRange::kPlusMinus90;
  } else if (e.azimuth_raw_deg > 90 || e.elevation_raw_deg > 90) {
    decided = AngleRange::kZeroTo180;
  }
  if (decided && anchor_range_.size() < kMaxAnchors)
    anchor_range_.emplace(std::string(e.anchor_id), *decided);
  return decided;
}

bool EventDecoder::duplicate(const UudfEvent& e, int64_t utime_us) {
  key_.assign(e.anchor_id);
  key_ += '\0';
  key_ += e.tag_id;
  auto it = pairs_.find(key_);
  if (it == pairs_.end()) {
    if (pairs_.size() >= kMaxPairs) return false;
    it = pairs_.emplace(key_, PairMemory{}).first;
  }
  PairMemory& mem = it->second;
  const int64_t window_us = static_cast<int64_t>(config_.duplicate_window_s * 1e6);
  for (size_t k = 0; k < mem.size; ++k) {
    const Recent& r = mem.recent[k];
    if (e.has_counter) {
      if (r.has_counter && r.counter == e.counter) return true;
    } else if (!r.has_counter && utime_us - r.utime_us <= window_us &&
               utime_us - r.utime_us >= -window_us && r.rssi == e.rssi_dbm &&
               r.az == e.azimuth_raw_deg && r.el == e.elevation_raw_deg &&
               r.reserved == e.reserved && r.channel == e.channel && r.uptime_ms == e.uptime_ms &&
               r.user_string == e.user_string) {
      return true;
    }
  }
  Recent& slot = mem.recent[mem.next];
  slot.utime_us = utime_us;
  slot.has_counter = e.has_counter;
  slot.counter = e.counter;
  slot.rssi = e.rssi_dbm;
  slot.az = e.azimuth_raw_deg;
  slot.el = e.elevation_raw_deg;
  slot.reserved = e.reserved;
  slot.channel = e.channel;
  slot.uptime_ms = e.uptime_ms;
  slot.user_string.assign(e.user_string);
  mem.next = (mem.next + 1) % kRecentPerPair;
  if (mem.size < kRecentPerPair) ++mem.size;
  return false;
}

LineOutcome EventDecoder::decode(std::string_view line, int64_t utime_us) {
  ++stats_.lines;
  LineOutcome out;
  UudfParseResult parsed = parse_uudf_line(line);
  if (parsed.kind == UudfParseResult::Kind::kAtLine) {
    out.kind = LineOutcome::Kind::kAtLine;
    out.at = parsed.at;
    return finish(std::move(out));
  }
  if (parsed.kind == UudfParseResult::Kind::kError) {
    out.reason = std::move(parsed.reason);
    return finish(std::move(out));
  }
  --stats_.lines;  // decode_event counts it
  return decode_event(parsed.event, utime_us);
}

LineOutcome EventDecoder::decode_event(const UudfEvent& e, int64_t utime_us) {
  ++stats_.lines;
  LineOutcome out;
  const std::optional<AngleRange> range = range_for(e);
  if (!range) {
    out.kind = LineOutcome::Kind::kRangeUnknown;
    return finish(std::move(out));
  }
  double az = e.azimuth_raw_deg;
  double el = e.elevation_raw_deg;
  if (*range == AngleRange::kZeroTo180) {
    if (az < 0 || el < 0) {
      out.reason = "+UUDF: negative angle from an anchor giving 0..180 deg (--angle-range)";
      return finish(std::move(out));
    }
    az -= config_.legacy_offset_deg;
    el -= config_.legacy_offset_deg;
  } else if (az > 90 || el > 90) {
    out.reason = "+UUDF: angle above 90 deg from an anchor giving -90..90 deg (--angle-range)";
    return finish(std::move(out));
  }
  if (duplicate(e, utime_us)) {
    out.kind = LineOutcome::Kind::kDuplicate;
    return finish(std::move(out));
  }
  msg_.utime = utime_us;
  auto renamed = config_.anchor_names.find(e.anchor_id);
  if (renamed != config_.anchor_names.end()) {
    msg_.anchor_id = renamed->second;
  } else {
    msg_.anchor_id.assign(e.anchor_id);
  }
  auto tag_renamed = config_.tag_names.find(e.tag_id);
  if (tag_renamed != config_.tag_names.end()) {
    msg_.tag_id = tag_renamed->second;
  } else {
    msg_.tag_id.assign(e.tag_id);
  }
  msg_.azimuth_deg = static_cast<float>(az);
  msg_.elevation_deg = static_cast<float>(el);
  msg_.rssi_dbm = static_cast<float>(e.rssi_dbm);
  msg_.channel = static_cast<int16_t>(e.channel);
  msg_.anchor_uptime_ms = e.uptime_ms;
  msg_.seq = e.has_counter ? e.counter : -1;
  msg_.user_string.assign(e.user_string);
  if (sink_) sink_(msg_);
  out.kind = LineOutcome::Kind::kPublished;
  return finish(std::move(out));
}

}  // namespace ips::ble_aoa
