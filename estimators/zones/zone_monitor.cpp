#include "estimators/zones/zone_monitor.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "core/text_escape.hpp"
#include "core/time.hpp"

namespace ips::zones {

namespace {

std::string seconds_text(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f s", s);
  return buf;
}

bool is_self(const ZoneMonitorOptions& o, const health_t& h) {
  return o.self_pid >= 0 && h.source == o.source && h.host == o.self_host && h.pid == o.self_pid;
}

}  // namespace

double last_boundary_crossing(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p0,
                              const Eigen::Vector2d& p1) {
  // Segment-segment intersection: p0 + s d = a + u e, s and u in [0, 1].
  const Eigen::Vector2d d = p1 - p0;
  double best = -1;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d a = poly[j];
    const Eigen::Vector2d e = poly[i] - a;
    const double den = d.x() * e.y() - d.y() * e.x();
    if (std::abs(den) < 1e-15) continue;  // parallel
    const Eigen::Vector2d w = a - p0;
    const double s = (w.x() * e.y() - w.y() * e.x()) / den;
    const double u = (w.x() * d.y() - w.y() * d.x()) / den;
    if (s >= 0 && s <= 1 && u >= 0 && u <= 1) best = std::max(best, s);
  }
  return best < 0 ? 1.0 : best;
}

ZoneMonitor::ZoneMonitor(ZoneMonitorOptions opts, EventSink on_event, AlertSink on_alert)
    : opts_(std::move(opts)), on_event_(std::move(on_event)), on_alert_(std::move(on_alert)) {}

void ZoneMonitor::set_site(const Site& site) {
  site_ = site;
  for (auto& [id, tag] : tags_) {
    for (auto it = tag.zones.begin(); it != tag.zones.end();) {
      if (site.layout.find_zone(it->first)) {
        ++it;
      } else {
        it = tag.zones.erase(it);
      }
    }
  }
  // A tag of the site never heard is silent from now (or from the first pose of any tag).
  for (const Tag& t : site.tags) {
    auto [it, added] = tags_.try_emplace(t.id);
    if (added) it->second.last_utime = tags_clock_;
  }
  check_tags();
  check_processes();
}

void ZoneMonitor::advance_clocks(int64_t tags_utime, int64_t processes_utime) {
  if (tags_clock_ > 0) advance_tags_clock(tags_utime);
  if (processes_clock_ > 0) advance_processes_clock(processes_utime);
}

void ZoneMonitor::advance_tags_clock(int64_t utime) {
  if (utime <= tags_clock_) return;
  tags_clock_ = utime;
  check_tags();
}

void ZoneMonitor::advance_processes_clock(int64_t utime) {
  if (utime <= processes_clock_) return;
  processes_clock_ = utime;
  check_processes();
}

void ZoneMonitor::on_altitude(const altitude_t& a) {
  ++stats_.altitudes_in;
  if (a.tag_id.empty() || !plausible_utime(a.utime)) {
    drops_.add(DropReason::kInvalid);
    return;
  }
  advance_tags_clock(a.utime);
  TagState& tag = tags_[a.tag_id];
  if (a.utime < tag.altitude_utime) return;
  tag.altitude_utime = a.utime;
  tag.altitude_floor = a.floor;
  tag.altitude_floor_valid = a.floor_valid && !a.relative;
}

void ZoneMonitor::on_pose(const pose_t& pose) {
  ++stats_.poses_in;
  const Eigen::Vector3d p(pose.position[0], pose.position[1], pose.position[2]);
  if (pose.tag_id.empty() || !plausible_utime(pose.utime) || !p.head<2>().allFinite() ||
      p.head<2>().cwiseAbs().maxCoeff() > 1e6) {
    drops_.add(DropReason::kInvalid);
    return;
  }
  advance_tags_clock(pose.utime);
  TagState& tag = tags_[pose.tag_id];
  if (tag.heard && pose.utime <= tag.last_utime) {
    drops_.add(pose.utime == tag.last_utime ? DropReason::kDuplicate : DropReason::kLate);
    return;
  }
  if (tag.silent_alert) {
    const std::string subject = pose.tag_id;
    const std::string text =
        printable(pose.tag_id) + ": poses on " + opts_.pose_channel + " again" +
        (tag.heard ? " after " + seconds_text(1e-6 * double(pose.utime - tag.last_utime)) : "");
    clear(tag.silent_alert, alert_t::KIND_TAG_SILENT, alert_t::SEVERITY_WARNING, pose.utime,
          subject, text);
    tag.silent_alert = 0;
  }
  if (!site_) {
    drops_.add(DropReason::kNoSite);
  } else {
    const SiteLayout& layout = site_->layout;
    // The tag's floor: its barometric floor when fresh, else the floor of its pose's height;
    // unknown without floors or a height (a zone with a floor then keeps its state).
    bool floor_known = false;
    int floor = kNoFloor;
    if (tag.altitude_floor_valid &&
        std::abs(double(pose.utime - tag.altitude_utime)) <= kAltitudeFreshS * 1e6) {
      floor_known = true;
      floor = tag.altitude_floor;
    } else if (!layout.floors.empty() && std::isfinite(p.z())) {
      floor_known = true;
      floor = layout.floor_of_height(p.z());
    } else if (layout.floors.size() == 1) {
      floor_known = true;
      floor = layout.floors.front().index;
    }
    for (const Zone& zone : layout.zones)
      update_zone(zone, tag, tag.zones[zone.id], pose, p, floor_known, floor);
    tag.last_floor = floor;
    tag.last_floor_known = floor_known;
  }
  tag.heard = true;
  tag.last_utime = pose.utime;
  tag.last_position = p;
}

void ZoneMonitor::update_zone(const Zone& zone, TagState& tag, ZoneTrack& track, const pose_t& pose,
                              const Eigen::Vector3d& p, bool floor_known, int floor) {
  if (zone.floor && !floor_known) return;
  const bool on_floor = !zone.floor || floor == *zone.floor;
  const bool raw_in = on_floor && polygon_contains(zone.polygon, p.head<2>());
  if (!track.known) {
    track.known = true;
    track.raw_inside = raw_in;
    if (raw_in) {
      track.inside = true;
      track.enter_utime = pose.utime;
      track.dwell_sent = false;
      emit_event(zone, pose.tag_id, zone_event_t::EVENT_ENTER, pose.utime, p, 0.0);
    }
    return;
  }
  if (raw_in != track.raw_inside) {
    // The boundary was crossed between the previous pose and this one: where, by linear
    // interpolation along the segment (a change of floor happens at this pose).
    int64_t t = pose.utime;
    Eigen::Vector3d c = p;
    const bool was_on_floor =
        !zone.floor || (tag.last_floor_known && tag.last_floor == *zone.floor);
    if (on_floor && was_on_floor && tag.heard) {
      const double s =
          last_boundary_crossing(zone.polygon, tag.last_position.head<2>(), p.head<2>());
      t = tag.last_utime + s_to_utime(s * 1e-6 * double(pose.utime - tag.last_utime));
      c = tag.last_position + s * (p - tag.last_position);
    }
    track.pending = raw_in != track.inside;
    track.cross_utime = t;
    track.cross_position = c;
    track.raw_inside = raw_in;
  }
  const double depth = on_floor ? polygon_boundary_distance(zone.polygon, p.head<2>())
                                : std::numeric_limits<double>::infinity();
  // DWELL once inside dwell_s, at the moment it was reached (enter + dwell_s), unless the tag
  // had crossed out before.
  auto check_dwell = [&] {
    if (!track.inside || track.dwell_sent || !(zone.dwell_s > 0)) return;
    const int64_t due = track.enter_utime + s_to_utime(zone.dwell_s);
    const int64_t until = track.pending ? track.cross_utime : pose.utime;
    if (until < due) return;
    track.dwell_sent = true;
    Eigen::Vector3d at = p;
    if (tag.heard && due > tag.last_utime) {
      const double s = double(due - tag.last_utime) / double(pose.utime - tag.last_utime);
      at = tag.last_position + s * (p - tag.last_position);
    } else if (tag.heard) {
      at = tag.last_position;
    }
    emit_event(zone, pose.tag_id, zone_event_t::EVENT_DWELL, due, at, zone.dwell_s);
  };
  if (!track.inside && raw_in && depth >= zone.hysteresis_m) {
    track.inside = true;
    track.pending = false;
    track.dwell_sent = false;
    track.enter_utime = track.cross_utime;
    emit_event(zone, pose.tag_id, zone_event_t::EVENT_ENTER, track.cross_utime,
               track.cross_position, 0.0);
    check_dwell();
  } else if (track.inside && !raw_in && depth >= zone.hysteresis_m) {
    check_dwell();
    track.inside = false;
    track.pending = false;
    emit_event(zone, pose.tag_id, zone_event_t::EVENT_LEAVE, track.cross_utime,
               track.cross_position, 1e-6 * double(track.cross_utime - track.enter_utime));
  } else {
    check_dwell();
  }
}

void ZoneMonitor::emit_event(const Zone& zone, const std::string& tag_id, int8_t kind,
                             int64_t utime, const Eigen::Vector3d& position, double dwell_s) {
  zone_event_t e;
  e.utime = utime;
  e.source = opts_.source;
  e.seq = event_seq_++;
  e.tag_id = tag_id;
  e.zone_id = zone.id;
  e.zone_name = zone.name;
  e.floor = zone.floor ? *zone.floor : zone_event_t::FLOOR_ANY;
  e.event = kind;
  e.dwell_s = dwell_s;
  for (int k = 0; k < 3; ++k) e.position[k] = position[k];
  e.pose_channel = opts_.pose_channel;
  e.alert = (kind == zone_event_t::EVENT_ENTER && zone.alert.enter) ||
            (kind == zone_event_t::EVENT_LEAVE && zone.alert.leave) ||
            (kind == zone_event_t::EVENT_DWELL && zone.alert.dwell);
  ++stats_.events_out;
  ++events_by_kind_[kind];
  on_event_(e);
  if (!e.alert) return;
  const std::string who = printable(tag_id);
  const std::string where = printable(zone.name);
  std::string text;
  if (kind == zone_event_t::EVENT_ENTER) {
    text = who + " entered " + where;
  } else if (kind == zone_event_t::EVENT_LEAVE) {
    text = who + " left " + where + " after " + seconds_text(dwell_s);
  } else {
    text = who + " in " + where + " for " + seconds_text(dwell_s);
  }
  raise(alert_t::KIND_ZONE, alert_t::SEVERITY_WARNING, utime, tag_id + "/" + zone.id, text);
}

void ZoneMonitor::publish_alert(int64_t id, int8_t kind, int8_t severity, int8_t state,
                                int64_t utime, const std::string& subject,
                                const std::string& text) {
  alert_t a;
  a.utime = utime;
  a.source = opts_.source;
  a.seq = alert_seq_++;
  a.id = id;
  a.kind = kind;
  a.severity = severity;
  a.state = state;
  a.subject = subject;
  a.text = text;
  ++stats_.alerts_out;
  on_alert_(a);
}

int64_t ZoneMonitor::raise(int8_t kind, int8_t severity, int64_t utime, const std::string& subject,
                           const std::string& text) {
  const int64_t id = next_alert_id_++;
  ++alerts_raised_;
  // A zone event's alert is raised only: nothing clears it.
  if (kind != alert_t::KIND_ZONE) open_[id] = text;
  publish_alert(id, kind, severity, alert_t::STATE_RAISED, utime, subject, text);
  return id;
}

void ZoneMonitor::clear(int64_t id, int8_t kind, int8_t severity, int64_t utime,
                        const std::string& subject, const std::string& text) {
  open_.erase(id);
  publish_alert(id, kind, severity, alert_t::STATE_CLEARED, utime, subject, text);
}

void ZoneMonitor::check_tags() {
  const double silent_s = site_ ? site_->layout.alerts.tag_silent_s : AlertRules{}.tag_silent_s;
  if (!(silent_s > 0) || tags_clock_ == 0) return;
  const int64_t limit = s_to_utime(silent_s);
  for (auto& [id, tag] : tags_) {
    if (tag.last_utime == 0) tag.last_utime = tags_clock_;  // a site tag: from the first pose
    if (tag.silent_alert || tags_clock_ - tag.last_utime < limit) continue;
    const std::string text = printable(id) + ": no pose on " + opts_.pose_channel + " for " +
                             seconds_text(silent_s) +
                             (tag.heard ? "" : " (none since ips-zones started)");
    tag.silent_alert = raise(alert_t::KIND_TAG_SILENT, alert_t::SEVERITY_WARNING,
                             tag.last_utime + limit, id, text);
  }
}

void ZoneMonitor::on_health(const health_t& h) {
  if (is_self(opts_, h)) return;
  ++stats_.health_in;
  if (h.source.empty() || !plausible_utime(h.utime)) {
    drops_.add(DropReason::kInvalid);
    return;
  }
  advance_processes_clock(h.utime);
  const std::string key = h.source + "@" + h.host;
  const std::string who = printable(h.source) + " on " + printable(h.host);
  ProcessState& ps = processes_[key];
  if (h.utime < ps.last_utime) return;  // an older report
  if (ps.gone_alert) {
    clear(ps.gone_alert, alert_t::KIND_PROCESS_GONE, alert_t::SEVERITY_CRITICAL, h.utime, key,
          who + ": HEALTH again after " + seconds_text(1e-6 * double(h.utime - ps.last_utime)));
    ps.gone_alert = 0;
  }
  ps.last_utime = h.utime;
  ps.state = h.state;
  if (h.uptime_us >= s_to_utime(kWatchedUptimeS)) ps.watched = true;
  const bool process_degraded =
      site_ ? site_->layout.alerts.process_degraded : AlertRules{}.process_degraded;
  const bool bad =
      process_degraded && (h.state == health_t::STATE_DEGRADED || h.state == health_t::STATE_ERROR);
  auto severity_of = [](int8_t state) {
    return state == health_t::STATE_ERROR ? alert_t::SEVERITY_CRITICAL : alert_t::SEVERITY_WARNING;
  };
  if (ps.degraded_alert && (!bad || h.state != ps.degraded_state)) {
    clear(ps.degraded_alert, alert_t::KIND_PROCESS_DEGRADED, severity_of(ps.degraded_state),
          h.utime, key,
          who + (bad ? ": no longer " : ": OK again, no longer ") +
              (ps.degraded_state == health_t::STATE_ERROR ? "in error" : "degraded"));
    ps.degraded_alert = 0;
  }
  if (bad && !ps.degraded_alert) {
    std::string text = who + (h.state == health_t::STATE_ERROR ? ": in error" : ": degraded");
    if (!h.last_error.empty()) text += ": " + printable(h.last_error);
    ps.degraded_alert =
        raise(alert_t::KIND_PROCESS_DEGRADED, severity_of(h.state), h.utime, key, text);
    ps.degraded_state = h.state;
  }
}

void ZoneMonitor::check_processes() {
  const double silent_s =
      site_ ? site_->layout.alerts.process_silent_s : AlertRules{}.process_silent_s;
  if (!(silent_s > 0)) return;
  const int64_t limit = s_to_utime(silent_s);
  for (auto& [key, ps] : processes_) {
    if (!ps.watched || ps.gone_alert || processes_clock_ - ps.last_utime < limit) continue;
    const auto at = key.rfind('@');
    const std::string who = printable(key.substr(0, at)) + " on " + printable(key.substr(at + 1));
    ps.gone_alert =
        raise(alert_t::KIND_PROCESS_GONE, alert_t::SEVERITY_CRITICAL, ps.last_utime + limit, key,
              who + ": no HEALTH for " + seconds_text(silent_s));
  }
}

std::string ZoneMonitor::run_notes() const {
  size_t heard = 0;
  for (const auto& [id, t] : tags_) heard += t.heard ? 1 : 0;
  const size_t zones = site_ ? site_->layout.zones.size() : 0;
  return std::to_string(heard) + " tags, " + std::to_string(zones) +
         " zones: " + std::to_string(events_by_kind_[zone_event_t::EVENT_ENTER]) + " ENTER, " +
         std::to_string(events_by_kind_[zone_event_t::EVENT_LEAVE]) + " LEAVE, " +
         std::to_string(events_by_kind_[zone_event_t::EVENT_DWELL]) + " DWELL; " +
         std::to_string(alerts_raised_) + " alerts raised, " + std::to_string(open_.size()) +
         " open";
}

std::vector<std::string> ZoneMonitor::open_alerts() const {
  std::vector<std::string> out;
  for (const auto& [id, text] : open_) out.push_back(text);
  return out;
}

}  // namespace ips::zones
