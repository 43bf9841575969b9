#pragma once
// Per-tag tracks keyed by ids that come off an unauthenticated bus: an estimator bounds how many
// it keeps, so that made-up ids cannot exhaust its memory.
#include <cstddef>
#include <iterator>

#include "core/time.hpp"

namespace ips {

// Whether `tracks` (a map of id to a track with `newest_utime`) may take one more track at
// `now`: when it holds max_tracks, tracks silent for longer than `stale` make room first.
template <class Map>
bool room_for_track(Map& tracks, utime_t now, int max_tracks, utime_t stale) {
  const auto limit = static_cast<size_t>(max_tracks);
  if (tracks.size() >= limit)
    for (auto old = tracks.begin(); old != tracks.end();)
      old = now - old->second.newest_utime > stale ? tracks.erase(old) : std::next(old);
  return tracks.size() < limit;
}

}  // namespace ips
