#pragma once
// Groups AoA events into epochs: the angles the anchors measured on one advertisement of a tag.
// The anchors report an advertisement at slightly different times (source 000 section 7.2.1:
// skewed by up to 25 ms; multipath copies come later still), and the tag advertises every
// 100 ms, so an epoch is every event of a tag within `window` of the epoch's first event. The
// window follows the tag's measured advertising interval (the median interval between an
// anchor's consecutive events of the tag, over the last 31): at most advertising_fraction of it,
// so that a tag advertising faster than the configured window (20 Hz: 50 ms) does not have two
// advertisements merged into one epoch; never more than the configured window. An
// epoch closes when a later event of any tag shows that its window has passed (the log's own
// time, so replay is exact), or at flush(now) when the bus goes quiet.
//
// Per event it does no string work beyond one hash lookup of the tag (none with tag_index()),
// and allocates nothing once a tag's buffers have grown.
#include <array>
#include <cstddef>
#include <deque>
#include <functional>
#include <string>
#include <unordered_map>
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
  // Gets each closed epoch; it may take the events (the grouper reuses the buffer otherwise).
  using Sink = std::function<void(Epoch&)>;
  EpochGrouper(double window_s, Sink sink);
  static constexpr double kAdvertisingFraction = 0.8;
  static constexpr size_t kIntervals = 31;  // intervals kept per tag
  static constexpr size_t kMinIntervals = 8;  // fewer: the configured window

  // The tag's index for add(size_t, ...): the same for the grouper's lifetime (until clear()).
  size_t tag_index(const std::string& tag_id);
  void add(const std::string& tag_id, const AoaEvent& e) { add(tag_index(tag_id), e); }
  void add(size_t tag, const AoaEvent& e);
  // Closes every epoch whose window ended before `now`.
  void flush(utime_t now);
  void flush_all();
  size_t open_epochs() const { return open_.size(); }
  void clear() {
    tags_.clear();
    index_.clear();
    open_.clear();
  }
  // The tag's measured advertising interval (0 until kMinIntervals) and its window now.
  utime_t advertising_interval_us(const std::string& tag_id) const;
  utime_t window_us(const std::string& tag_id) const;

 private:
  struct Rate {
    struct Last {
      bool seen = false;
      utime_t utime = 0;
    };
    std::vector<Last> last;  // per anchor index
    std::array<utime_t, kIntervals> intervals{};  // ring of the newest kIntervals
    std::array<utime_t, kIntervals> sorted{};     // the same, in order: the median is read
    size_t count = 0;
    size_t next = 0;
    utime_t median = 0;
    utime_t window = 0;
  };
  struct Tag {
    Epoch epoch;  // its tag_id set once
    bool open = false;
    Rate rate;
  };
  utime_t window_of(const Tag& t) const { return t.rate.window == 0 ? window_us_ : t.rate.window; }
  void close(size_t open_slot);
  void close_until(utime_t now, bool all);

  utime_t window_us_;
  Sink sink_;
  std::deque<Tag> tags_;  // by tag index (a deque: references stay valid as tags are added)
  std::unordered_map<std::string, size_t> index_;
  std::vector<size_t> open_;  // the tags with an open epoch, in no particular order
};

}  // namespace ips::aoa
