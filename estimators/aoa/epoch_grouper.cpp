#include "estimators/aoa/epoch_grouper.hpp"

#include <algorithm>
#include <cstddef>
#include <utility>

namespace ips::aoa {

EpochGrouper::EpochGrouper(double window_s, Sink sink)
    : window_us_(s_to_utime(window_s)), sink_(std::move(sink)) {}

size_t EpochGrouper::tag_index(const std::string& tag_id) {
  const auto [it, added] = index_.try_emplace(tag_id, tags_.size());
  if (added) tags_.emplace_back().epoch.tag_id = tag_id;
  return it->second;
}

void EpochGrouper::close(size_t open_slot) {
  Tag& tag = tags_[open_[open_slot]];
  open_[open_slot] = open_.back();
  open_.pop_back();
  tag.open = false;
  // Handed over on its own, so that the sink may even add to this grouper again.
  Epoch epoch = std::move(tag.epoch);
  tag.epoch.tag_id = epoch.tag_id;
  sink_(epoch);
  if (!tag.open && tag.epoch.events.empty()) {  // its buffer back for the next epoch
    tag.epoch.events = std::move(epoch.events);
    tag.epoch.events.clear();
  }
}

utime_t EpochGrouper::advertising_interval_us(const std::string& tag_id) const {
  const auto it = index_.find(tag_id);
  return it == index_.end() ? 0 : tags_[it->second].rate.median;
}

utime_t EpochGrouper::window_us(const std::string& tag_id) const {
  const auto it = index_.find(tag_id);
  return it == index_.end() ? window_us_ : window_of(tags_[it->second]);
}

void EpochGrouper::add(size_t tag_index, const AoaEvent& e) {
  Tag& tag = tags_[tag_index];
  Rate& rate = tag.rate;
  if (rate.last.size() <= e.anchor) rate.last.resize(e.anchor + 1);
  Rate::Last& last = rate.last[e.anchor];
  if (last.seen) {
    const utime_t dt = e.utime - last.utime;
    if (dt > 0 && dt < 2'000'000) {  // a gap beyond 2 s is an outage, not the rate
      const auto sorted = rate.sorted.begin();
      auto end = sorted + static_cast<std::ptrdiff_t>(rate.count);
      if (rate.count == kIntervals) {  // the oldest leaves
        const auto old = std::lower_bound(sorted, end, rate.intervals[rate.next]);
        std::move(old + 1, end, old);
        --end;
      } else {
        ++rate.count;
      }
      const auto at = std::upper_bound(sorted, end, dt);
      std::move_backward(at, end, end + 1);
      *at = dt;
      rate.intervals[rate.next] = dt;
      rate.next = (rate.next + 1) % kIntervals;
      if (rate.count >= kMinIntervals) {
        rate.median = rate.sorted[rate.count / 2];
        rate.window = std::min(
            window_us_, static_cast<utime_t>(kAdvertisingFraction * static_cast<double>(rate.median)));
      }
    }
  }
  last.seen = true;
  last.utime = e.utime;
  flush(e.utime);
  if (tag.open && e.utime - tag.epoch.utime > window_of(tag))
    close(static_cast<size_t>(std::find(open_.begin(), open_.end(), tag_index) - open_.begin()));
  if (!tag.open) {
    tag.open = true;
    open_.push_back(tag_index);
    tag.epoch.utime = e.utime;
    tag.epoch.events.clear();
    tag.epoch.events.reserve(8);
  }
  tag.epoch.utime = std::min(tag.epoch.utime, e.utime);
  tag.epoch.events.push_back(e);
}

void EpochGrouper::flush(utime_t now) { close_until(now, false); }

void EpochGrouper::flush_all() { close_until(0, true); }

void EpochGrouper::close_until(utime_t now, bool all) {
  // Oldest first, so the poses of different tags come out in time order; of two as old, the
  // tag first in id order.
  for (;;) {
    size_t oldest = open_.size();
    for (size_t k = 0; k < open_.size(); ++k) {
      const Tag& t = tags_[open_[k]];
      if (!all && !(t.epoch.utime < now - window_of(t))) continue;
      if (oldest == open_.size()) {
        oldest = k;
        continue;
      }
      const Epoch& o = tags_[open_[oldest]].epoch;
      if (t.epoch.utime < o.utime || (t.epoch.utime == o.utime && t.epoch.tag_id < o.tag_id))
        oldest = k;
    }
    if (oldest == open_.size()) return;
    close(oldest);
  }
}

}  // namespace ips::aoa
