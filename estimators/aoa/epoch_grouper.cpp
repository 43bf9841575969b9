#include "estimators/aoa/epoch_grouper.hpp"

#include <algorithm>
#include <cstddef>

namespace ips::aoa {

EpochGrouper::EpochGrouper(double window_s, Sink sink)
    : window_us_(s_to_utime(window_s)), sink_(std::move(sink)) {}

void EpochGrouper::close(std::map<std::string, Epoch>::iterator it) {
  Epoch epoch = std::move(it->second);
  open_.erase(it);
  sink_(epoch);
}

utime_t EpochGrouper::advertising_interval_us(const std::string& tag_id) const {
  const auto it = rate_.find(tag_id);
  return it == rate_.end() ? 0 : it->second.median;
}

utime_t EpochGrouper::window_us(const std::string& tag_id) const {
  const auto it = rate_.find(tag_id);
  return it == rate_.end() || it->second.window == 0 ? window_us_ : it->second.window;
}

void EpochGrouper::add(const std::string& tag_id, const AoaEvent& e) {
  Rate& rate = rate_[tag_id];
  auto last = rate.last.find(e.anchor);
  if (last != rate.last.end()) {
    const utime_t dt = e.utime - last->second;
    if (dt > 0 && dt < 2'000'000) {  // a gap beyond 2 s is an outage, not the rate
      if (rate.intervals.size() < kIntervals) rate.intervals.push_back(dt);
      else rate.intervals[rate.next] = dt;
      rate.next = (rate.next + 1) % kIntervals;
      if (rate.intervals.size() >= kMinIntervals) {
        std::vector<utime_t> v = rate.intervals;
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        rate.median = v[v.size() / 2];
        rate.window = std::min(
            window_us_, static_cast<utime_t>(kAdvertisingFraction * static_cast<double>(rate.median)));
      }
    }
  }
  rate.last[e.anchor] = e.utime;
  flush(e.utime);
  auto it = open_.find(tag_id);
  if (it != open_.end() && e.utime - it->second.utime > window_us(tag_id)) {
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
      if ((all || it->second.utime < now - window_us(it->first)) &&
          (oldest == open_.end() || it->second.utime < oldest->second.utime))
        oldest = it;
    if (oldest == open_.end()) return;
    close(oldest);
  }
}

}  // namespace ips::aoa
