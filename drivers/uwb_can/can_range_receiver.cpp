#include "drivers/uwb_can/can_range_receiver.hpp"

namespace ips::uwb_can {

CanRangeReceiver::CanRangeReceiver(RangeFrameLayout layout, RangeIds ids, Sink sink)
    : layout_(layout), ids_(std::move(ids)), sink_(std::move(sink)) {}

void CanRangeReceiver::bad(const std::string& reason) {
  ++stats_.bad_input;
  if (sink_.bad_input) sink_.bad_input(reason);
}

void CanRangeReceiver::on_frame(const CanFrame& frame, utime_t utime,
                                const std::string& interface) {
  ++stats_.frames;
  if (frame.error) {
    ++stats_.error_frames;
    const std::string what = "CAN error frame on " + interface + ": " + describe_error_frame(frame);
    if (sink_.error_frame) sink_.error_frame(what);
    if (error_frame_lost_frames(frame)) {
      ++stats_.lost_frames;  // the controller says at least one frame was lost
      if (sink_.lost) sink_.lost(1, "controller receive overflow on " + interface);
    }
    return;
  }
  const RangeFrameDecode d = decode_range_frame(frame, layout_);
  switch (d.what) {
    case FrameClass::kNotRange:
      ++stats_.other_frames;
      if (!frame.extended && (stats_.other_ids.size() < 16 || stats_.other_ids.count(frame.id)))
        ++stats_.other_ids[frame.id];
      return;
    case FrameClass::kBad:
      bad(d.reason);
      return;
    case FrameClass::kRange:
      break;
  }
  if (interface != source_interface_) {
    source_interface_ = interface;
    source_ = "ips-uwb-can:" + interface;
  }
  ++stats_.ranges;
  if (sink_.range) sink_.range(range_message(d.record, ids_, utime, source_));
}

void CanRangeReceiver::on_candump_line(const CandumpLine& line, TimeFrom time_from, utime_t now) {
  switch (line.kind) {
    case CandumpLineKind::kEmpty:
    case CandumpLineKind::kNote:
      return;
    case CandumpLineKind::kDropCount:
      stats_.lost_frames += static_cast<int64_t>(line.dropped);
      if (sink_.lost)
        sink_.lost(static_cast<int64_t>(line.dropped),
                   "candump reports dropped frames (DROPCOUNT)");
      return;
    case CandumpLineKind::kBad:
      bad(line.reason);
      return;
    case CandumpLineKind::kFrame:
      break;
  }
  if (time_from == TimeFrom::kLine && !line.has_time) {
    ++stats_.frames;
    bad("no absolute timestamp on the line (candump -L writes one; or use --time-from host)");
    return;
  }
  on_frame(line.frame, time_from == TimeFrom::kLine ? line.utime : now, line.interface);
}

}  // namespace ips::uwb_can
