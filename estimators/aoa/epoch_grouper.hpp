#pragma once
// Groups AoA events into epochs: the angles the anchors measured on one advertisement of a tag.
// The anchors report an advertisement at slightly different times (source 000 section 7.2.1:
// skewed by up to 25 ms; multipath copies come later still), and the tag advertises every
// 100 ms, so an epoch is every event of a tag within `window` of the epoch's first event. An
// epoch closes when a later event of any tag shows that its window has passed (the log's own
// time, so replay is exact), or at flush(now) when the bus goes quiet.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "core/time.hpp"

namespace ips::aoa {

struct AoaEvent {
  utime_t utime = 0;
  size_t anchor = 0;        // index into the site's anchors
  double azimuth_deg = 0;   // corrected (calibration applied)
  double elevation_deg = 0;
  double rssi_dbm = 0;
  int64_t order = 0;        // arrival order, the tie-break
};

struct Epoch {
  std::string tag_id;
  utime_t utime = 0;  // the earliest event's time: the closest to the advertisement itself
  std::vector<AoaEvent> events;  // in arrival order
};

class EpochGrouper {
 public:
  using Sink = std::function<void(Epoch&)>;
  EpochGrouper(double window_s, Sink sink);

  void add(const std::string& tag_id, const AoaEvent& e);
  // Closes every epoch whose window ended before `now`.
  void flush(utime_t now);
  void flush_all();
  size_t open_epochs() const { return open_.size(); }
  void clear() { open_.clear(); }

 private:
  void close(std::map<std::string, Epoch>::iterator it);
  void close_until(utime_t now, bool all);

  utime_t window_us_;
  Sink sink_;
  std::map<std::string, Epoch> open_;
};

}  // namespace ips::aoa
