#include "drivers/uwb_serial/line_decoder.hpp"

#include <cmath>
#include <limits>

#include "drivers/uwb_serial/pans_parser.hpp"
#include "drivers/uwb_serial/range_line_parser.hpp"

namespace ips::uwb_serial {

std::optional<LineFormat> line_format_from_name(std::string_view name) {
  if (name == "pans") return LineFormat::kPans;
  if (name == "line") return LineFormat::kRangeLine;
  if (name == "auto") return LineFormat::kAuto;
  return std::nullopt;
}

LineDecoder::LineDecoder(LineDecoderConfig config, RangeSink on_range, PoseSink on_pose)
    : config_(std::move(config)), on_range_(std::move(on_range)), on_pose_(std::move(on_pose)) {
  range_msg_.source = config_.source;
  range_msg_.fp_power_dbm = std::numeric_limits<float>::quiet_NaN();
  range_msg_.quality = std::numeric_limits<float>::quiet_NaN();
}

LineOutcome LineDecoder::decode(std::string_view line, int64_t utime_us) {
  ++stats_.lines;
  LineOutcome out;
  switch (config_.format) {
    case LineFormat::kPans:
      out = decode_pans(line, utime_us);
      break;
    case LineFormat::kRangeLine:
      out = decode_range_line(line, utime_us);
      break;
    case LineFormat::kAuto:
      if (looks_like_range_line(line)) {
        out = decode_range_line(line, utime_us);
      } else if (looks_like_pans_line(line)) {
        out = decode_pans(line, utime_us);
      } else {
        out.kind = LineOutcome::Kind::kError;
        out.reason = "neither a PANS lec line (DIST,/POS,) nor a RANGE line";
      }
      break;
  }
  switch (out.kind) {
    case LineOutcome::Kind::kMeasurement:
      ++stats_.measurement_lines;
      break;
    case LineOutcome::Kind::kIgnored:
      ++stats_.ignored_lines;
      break;
    case LineOutcome::Kind::kError:
      ++stats_.error_lines;
      break;
  }
  return out;
}

LineOutcome LineDecoder::decode_pans(std::string_view line, int64_t utime_us) {
  LineOutcome out;
  PansParseResult parsed = parse_pans_line(line);
  if (parsed.kind == PansParseResult::Kind::kShellText) {
    out.kind = LineOutcome::Kind::kIgnored;
    return out;
  }
  if (parsed.kind == PansParseResult::Kind::kError) {
    out.kind = LineOutcome::Kind::kError;
    out.reason = std::move(parsed.reason);
    return out;
  }
  if (config_.tag_id.empty()) {
    out.kind = LineOutcome::Kind::kError;
    out.reason = "PANS line but no tag id given (--tag): lec lines do not carry it";
    return out;
  }
  out.kind = LineOutcome::Kind::kMeasurement;
  const PansLine& p = parsed.line;
  for (size_t i = 0; i < p.num_ranges; ++i) {
    emit_range(config_.tag_id, p.ranges[i].id(), p.ranges[i].range_m,
               std::numeric_limits<double>::quiet_NaN(), utime_us);
    ++out.ranges;
  }
  if (p.position) {
    if (p.position->quality_percent == 0) {
      // qf 0: the location engine has no solution; its coordinates mean nothing.
      out.position_without_fix = true;
      ++stats_.positions_without_fix;
    } else {
      pose_t pose;
      pose.utime = utime_us;
      pose.source = config_.source;
      pose.tag_id = config_.tag_id;
      const double nan = std::numeric_limits<double>::quiet_NaN();
      for (int k = 0; k < 3; ++k) {
        pose.position[k] = p.position->position_m[k];
        pose.velocity[k] = nan;
      }
      for (double& c : pose.position_cov) c = nan;
      pose.heading_rad = nan;
      pose.num_used = static_cast<int32_t>(p.num_ranges);
      pose.residual_m = nan;
      pose.status = pose_t::STATUS_OK;
      if (on_pose_) on_pose_(pose);
      out.position = true;
      ++stats_.positions;
    }
  }
  return out;
}

LineOutcome LineDecoder::decode_range_line(std::string_view line, int64_t utime_us) {
  LineOutcome out;
  RangeLineParseResult parsed = parse_range_line(line);
  if (parsed.kind == RangeLineParseResult::Kind::kComment) {
    out.kind = LineOutcome::Kind::kIgnored;
    return out;
  }
  if (parsed.kind == RangeLineParseResult::Kind::kError) {
    out.kind = LineOutcome::Kind::kError;
    out.reason = std::move(parsed.reason);
    return out;
  }
  out.kind = LineOutcome::Kind::kMeasurement;
  emit_range(parsed.range.tag_id, parsed.range.anchor_id, parsed.range.range_m,
             parsed.range.rssi_dbm, utime_us);
  out.ranges = 1;
  return out;
}

int32_t LineDecoder::next_seq(std::string_view tag_id, std::string_view anchor_id) {
  seq_key_.assign(tag_id);
  seq_key_ += '\0';
  seq_key_ += anchor_id;
  auto it = seq_.find(seq_key_);
  if (it == seq_.end()) {
    if (seq_.size() >= kMaxSequencedPairs) return -1;
    seq_.emplace(seq_key_, 0);
    return 0;
  }
  // Wraps to 0 after INT32_MAX (-1 means "unknown").
  it->second = it->second == std::numeric_limits<int32_t>::max() ? 0 : it->second + 1;
  return it->second;
}

void LineDecoder::emit_range(std::string_view tag_id, std::string_view anchor_id, double range_m,
                             double rssi_dbm, int64_t utime_us) {
  range_msg_.utime = utime_us;
  range_msg_.tag_id.assign(tag_id);
  range_msg_.anchor_id.assign(anchor_id);
  range_msg_.range_m = range_m;
  range_msg_.rx_power_dbm = static_cast<float>(rssi_dbm);
  range_msg_.seq = next_seq(tag_id, anchor_id);
  ++stats_.ranges;
  if (on_range_) on_range_(range_msg_);
}

}  // namespace ips::uwb_serial
