#pragma once
// Default channel names (docs/channels.md). Every program can rename any of them with
// --channel KIND=NAME.

#include <string>

namespace ips::channel {

inline constexpr const char* kUwbRange = "UWB_RANGE";
inline constexpr const char* kUwbRx = "UWB_RX";
inline constexpr const char* kBleAoa = "BLE_AOA";
inline constexpr const char* kImu = "IMU";
inline constexpr const char* kBaro = "BARO";
inline constexpr const char* kInsModule = "INS_MODULE";
inline constexpr const char* kSite = "SITE";
// A process waiting for its site asks for it here (an empty site_t); whoever holds the bus's
// site answers on SITE (core/site_source.cpp): a restarted estimator need not wait for the next
// periodic SITE.
inline constexpr const char* kSiteRequest = "SITE_REQUEST";
inline constexpr const char* kHealth = "HEALTH";
inline constexpr const char* kTruth = "TRUTH";
inline constexpr const char* kPoseUwb = "POSE_UWB";
// The position a UWB module computes on board (DWM1001 PANS `lec` POS), published by its driver.
inline constexpr const char* kPoseUwbModule = "POSE_UWB_MODULE";
// One difference of distances between two anchors, as Loco-style TDoA systems report it
// (uwb_tdoa_t).
inline constexpr const char* kUwbTdoa = "UWB_TDOA";
// The raw exchange timestamps of a two-way range, beside its UWB_RANGE (uwb_twr_timestamps_t).
inline constexpr const char* kUwbTwrRaw = "UWB_TWR_RAW";
// ips-uwb-twr's plain per-epoch least-squares fixes (estimators.uwb_twr.epoch_fixes): the naive
// solution the tracker is checked against.
inline constexpr const char* kPoseUwbEpoch = "POSE_UWB_EPOCH";
inline constexpr const char* kPoseTdoa = "POSE_TDOA";
inline constexpr const char* kPoseAoa = "POSE_AOA";
inline constexpr const char* kPosePdr = "POSE_PDR";
inline constexpr const char* kPoseIns = "POSE_INS";
inline constexpr const char* kStep = "STEP";
inline constexpr const char* kAltitude = "ALTITUDE";
inline constexpr const char* kClock = "CLOCK";
inline constexpr const char* kPoseFused = "POSE_FUSED";
inline constexpr const char* kZoneEvent = "ZONE_EVENT";  // zone_event_t, from ips-zones
inline constexpr const char* kAlert = "ALERT";           // alert_t, from ips-zones

// A channel name we accept: 1 to 63 of [A-Za-z0-9_]. LCM subscribes by regular expression and
// limits names to 63 characters, so anything else would be matched wrongly or not sent at all.
inline bool valid_channel_name(const std::string& name) {
  if (name.empty() || name.size() > 63) return false;
  for (char c : name)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_'))
      return false;
  return true;
}

// Every kind, for checking --channel KIND=NAME.
inline constexpr const char* kAllKinds[] = {
    kUwbRange, kUwbRx,    kBleAoa,   kImu,     kBaro,    kInsModule, kSite,  kHealth,    kTruth,
    kPoseUwb,  kPoseTdoa, kPoseAoa,  kPosePdr, kPoseIns, kStep,      kAltitude, kClock, kPoseFused,
    kPoseUwbModule, kSiteRequest, kUwbTdoa, kUwbTwrRaw, kPoseUwbEpoch, kZoneEvent, kAlert};

}  // namespace ips::channel
