#include "estimators/aoa/epoch_grouper.hpp"

#include <algorithm>

namespace ips::aoa {

EpochGrouper::EpochGrouper(double window_s, Sink sink)
    : window_us_(s_to_utime(window_s)), sink_(std::move(sink)) {}

void EpochGrouper::close(std::map<std::string, Epoch>::iterator it) {
  Epoch epoch = std::move(it->second);
  open_.erase(it);
  sink_(epoch);
}

void EpochGrouper::add(const std::string& tag_id, const AoaEvent& e) {
  flush(e.utime);
  auto it = open_.find(tag_id);
  if (it != open_.end() && e.utime - it->second.utime > window_us_) {
    close(it);
    it = open_.end();
  }
  if (it == open_.end()) {
    it = open_.emplace(tag_id, Epoch{tag_id, e.utime, {}}).first;
    it->second.events.reserve(8);
  }
  it->second.utime = std::min(it->second.utime, e.utime);
  it->second.events.push_back(e);
}

void EpochGrouper::flush(utime_t now) { close_until(now, false); }

void EpochGrouper::flush_all() { close_until(0, true); }

void EpochGrouper::close_until(utime_t now, bool all) {
  // Oldest first, so the poses of different tags come out in time order.
  for (;;) {
    auto oldest = open_.end();
    for (auto it = open_.begin(); it != open_.end(); ++it)
      if ((all || it->second.utime < now - window_us_) &&
          (oldest == open_.end() || it->second.utime < oldest->second.utime))
        oldest = it;
    if (oldest == open_.end()) return;
    close(oldest);
  }
}

}  // namespace ips::aoa
