#pragma once
// The names of the enumerations of zone_event_t and alert_t, as the JSON of ips-view and ips-mqtt
// write them: "enter", "tag_silent", "warning", "raised"; nullptr for a value the message
// definition does not have (the caller says how: "unknown", "unknown(7)").
#include <ips/alert_t.hpp>
#include <ips/zone_event_t.hpp>

namespace ips {

inline const char* zone_event_name(int8_t event) {
  switch (event) {
    case zone_event_t::EVENT_ENTER: return "enter";
    case zone_event_t::EVENT_LEAVE: return "leave";
    case zone_event_t::EVENT_DWELL: return "dwell";
    default: return nullptr;
  }
}

inline const char* alert_kind_name(int8_t kind) {
  switch (kind) {
    case alert_t::KIND_TAG_SILENT: return "tag_silent";
    case alert_t::KIND_PROCESS_DEGRADED: return "process_degraded";
    case alert_t::KIND_PROCESS_GONE: return "process_gone";
    case alert_t::KIND_ZONE: return "zone";
    default: return nullptr;
  }
}

inline const char* alert_severity_name(int8_t severity) {
  switch (severity) {
    case alert_t::SEVERITY_INFO: return "info";
    case alert_t::SEVERITY_WARNING: return "warning";
    case alert_t::SEVERITY_CRITICAL: return "critical";
    default: return nullptr;
  }
}

inline const char* alert_state_name(int8_t state) {
  switch (state) {
    case alert_t::STATE_RAISED: return "raised";
    case alert_t::STATE_CLEARED: return "cleared";
    default: return nullptr;
  }
}

}  // namespace ips
