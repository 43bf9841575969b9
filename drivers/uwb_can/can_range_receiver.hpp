#pragma once
// What ips-uwb-can does with each CAN frame, whichever medium it came from (a CAN_RAW socket, a
// candump log, a candump stream): a range frame becomes a uwb_range_t; a frame on an anchor's id
// that does not fit the layout is bad input, with a reason; error frames are bus trouble to
// report; frames the capture or the controller lost are counted; other devices' frames, remote
// requests and extended ids are counted and otherwise ignored. Pure: no I/O, no clock.
#include <cstdint>
#include <functional>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <string>

#include "core/time.hpp"
#include "drivers/uwb_can/can_frame.hpp"
#include "drivers/uwb_can/can_range_frame.hpp"
#include "drivers/uwb_can/candump_parser.hpp"
#include "drivers/uwb_can/range_naming.hpp"

namespace ips::uwb_can {

struct CanRangeStats {
  int64_t frames = 0;        // frames seen (including error frames)
  int64_t ranges = 0;        // range messages produced
  int64_t bad_input = 0;     // bad frames and unreadable candump lines
  int64_t error_frames = 0;  // error frames from the CAN controller driver
  int64_t lost_frames = 0;   // lost before they reached us (controller rx overflow, DROPCOUNT)
  int64_t other_frames = 0;  // other ids, extended ids, remote requests: not ours
  std::map<uint32_t, int64_t> other_ids;  // standard ids of other frames, first 16 kept
};

// Where a candump line's utime comes from.
enum class TimeFrom {
  kLine,  // the line's absolute timestamp (a replayed log keeps its times)
  kHost,  // the host clock when the line was read
};

class CanRangeReceiver {
 public:
  struct Sink {
    std::function<void(const uwb_range_t&)> range;
    std::function<void(const std::string& reason)> bad_input;
    std::function<void(const std::string& what)> error_frame;
    std::function<void(int64_t frames, const std::string& why)> lost;
  };

  CanRangeReceiver(RangeFrameLayout layout, RangeIds ids, Sink sink);

  // A frame received at `utime` on `interface` (the message's source is "ips-uwb-can:<if>").
  void on_frame(const CanFrame& frame, utime_t utime, const std::string& interface);
  // A parsed candump line; `now` is the host time it was read.
  void on_candump_line(const CandumpLine& line, TimeFrom time_from, utime_t now);

  const CanRangeStats& stats() const { return stats_; }

 private:
  void bad(const std::string& reason);

  RangeFrameLayout layout_;
  RangeIds ids_;
  Sink sink_;
  CanRangeStats stats_;
  std::string source_interface_, source_;  // cached: the interface rarely changes
};

}  // namespace ips::uwb_can
