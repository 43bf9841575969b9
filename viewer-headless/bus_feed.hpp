#pragma once
// Bus messages (live off LCM, or events of a log) into a ViewModel: every message counts in the
// channel table; SITE is decoded as site_t, HEALTH as health_t, ALTITUDE as altitude_t,
// ZONE_EVENT as zone_event_t, ALERT as alert_t, and any other channel's message
// that decodes as pose_t (LCM checks the type's fingerprint first, so UWB_RANGE and the like are
// refused cheaply) becomes a track. A message on SITE or HEALTH that does not decode is counted.
// Pure: bytes in, model updated; the same bytes give the same model.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/time.hpp"
#include "viewer-headless/view_model.hpp"

namespace ips::view {

struct FeedChannels {
  std::string site = "SITE";
  std::string health = "HEALTH";
  std::string altitude = "ALTITUDE";
  std::string zone_event = "ZONE_EVENT";
  std::string alert = "ALERT";
};

struct FeedStats {
  int64_t messages = 0;
  int64_t undecodable = 0;  // on a typed channel (SITE, HEALTH, ...), not of its type
  int64_t poses = 0;
  int64_t other = 0;  // neither: counted in the channel table only
};

class BusFeed {
 public:
  BusFeed(ViewModel& model, FeedChannels channels) : model_(model), channels_(std::move(channels)) {}
  // nullptr, or the type ("site_t", "health_t", ...) a message on one of the typed channels did
  // not decode as (also counted in stats().undecodable).
  const char* feed(const std::string& channel, const void* data, size_t size,
                   utime_t host_utime);
  const FeedStats& stats() const { return stats_; }

 private:
  ViewModel& model_;
  FeedChannels channels_;
  FeedStats stats_;
};

}  // namespace ips::view
