#include "viewer-headless/bus_feed.hpp"

#include <ips/health_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>

#include "core/node.hpp"

namespace ips::view {

const char* BusFeed::feed(const std::string& channel, const void* data, size_t size,
                          utime_t host_utime) {
  ++stats_.messages;
  model_.on_bytes(channel, size, host_utime);
  // Each typed channel: decoded into the model, or counted and its type named.
  const auto typed = [&](auto msg, const char* type, auto on) -> const char* {
    if (!decode_message(msg, data, size)) {
      ++stats_.undecodable;
      return type;
    }
    (model_.*on)(msg, host_utime);
    return nullptr;
  };
  if (channel == channels_.site) return typed(site_t{}, "site_t", &ViewModel::on_site);
  if (channel == channels_.health) return typed(health_t{}, "health_t", &ViewModel::on_health);
  if (channel == channels_.altitude) return typed(altitude_t{}, "altitude_t", &ViewModel::on_altitude);
  if (channel == channels_.zone_event)
    return typed(zone_event_t{}, "zone_event_t", &ViewModel::on_zone_event);
  if (channel == channels_.alert) return typed(alert_t{}, "alert_t", &ViewModel::on_alert);
  pose_t pose;
  if (decode_message(pose, data, size)) {
    ++stats_.poses;
    model_.on_pose(channel, pose, host_utime);
  } else {
    ++stats_.other;
  }
  return nullptr;
}

}  // namespace ips::view
