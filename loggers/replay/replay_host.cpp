#include "loggers/replay/replay_host.hpp"

#include <algorithm>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/site_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>

#include "core/channels.hpp"
#include "core/node.hpp"

namespace ips::replay {

namespace {
constexpr const char* kUwbTwr = "uwb_twr";
constexpr const char* kUwbTdoa = "uwb_tdoa";
constexpr const char* kAoa = "aoa";
constexpr const char* kPdr = "pdr";
constexpr const char* kIns = "ins";
constexpr const char* kAltitude = "altitude";
}

std::vector<std::string> ReplayHost::available() { return {kUwbTwr, kUwbTdoa, kAoa, kPdr, kIns, kAltitude};
}

ReplayHost::ReplayHost(const ReplayOptions& opts, const CommonOptions& channels, Sink sink)
    : channels_(channels), sink_(std::move(sink)), opts_(opts) {
  for (const auto& name : opts_.only) {
    const auto all = available();
    if (std::find(all.begin(), all.end(), name) == all.end()) {
      std::string names;
      for (const auto& n : all) names += (names.empty() ? "" : ", ") + n;
      throw ConfigError("--only: unknown estimator '" + name + "' (" + names + ")");
    }
  }
  auto wanted = [&](const char* name) { return opts_.only.empty() || opts_.only.count(name); };
  if (wanted(kUwbTwr)) {
    const std::string out = channels_.channel(channel::kPoseUwb);
    twr_ = std::make_unique<uwb_twr::TwrEstimator>([this, out](const pose_t& p) { emit(out, p); });
    produced_channels_.insert(out);
  }
  if (wanted(kUwbTdoa)) {
    const std::string pose_out = channels_.channel(channel::kPoseTdoa);
    const std::string clock_out = channels_.channel(channel::kClock);
    tdoa_ = std::make_unique<uwb_tdoa::TdoaEstimator>(
        [this, pose_out](const pose_t& p) { emit(pose_out, p); },
        [this, clock_out](const clock_t& c) { emit(clock_out, c); });
    produced_channels_.insert(pose_out);
    produced_channels_.insert(clock_out);
  }
  if (wanted(kAoa)) {
    const std::string out = channels_.channel(channel::kPoseAoa);
    aoa_ = std::make_unique<aoa::AoaEstimator>([this, out](const pose_t& p) { emit(out, p); });
    produced_channels_.insert(out);
  }
  if (wanted(kPdr)) {
    const std::string steps = channels_.channel(channel::kStep);
    const std::string poses = channels_.channel(channel::kPosePdr);
    pdr_ = std::make_unique<pdr::PdrEstimator>([this, steps](const step_t& s) { emit(steps, s); },
                                               [this, poses](const pose_t& p) { emit(poses, p); });
    produced_channels_.insert(steps);
    produced_channels_.insert(poses);
  }
  if (wanted(kIns)) {
    const std::string out = channels_.channel(channel::kPoseIns);
    ins_ = std::make_unique<ins::InsEstimator>([this, out](const pose_t& p) { emit(out, p); });
    produced_channels_.insert(out);
  }
  if (wanted(kAltitude)) {
    const std::string out = channels_.channel(channel::kAltitude);
    altitude_ = std::make_unique<altitude::AltitudeEstimator>(
        [this, out](const altitude_t& a) { emit(out, a); });
    produced_channels_.insert(out);
  }
  if (!opts_.site_path.empty()) apply_site(load_site_file(opts_.site_path));
}

std::vector<std::string> ReplayHost::hosted() const {
  std::vector<std::string> names;
  if (twr_) names.push_back(kUwbTwr);
  if (tdoa_) names.push_back(kUwbTdoa);
  if (aoa_) names.push_back(kAoa);
  if (pdr_) names.push_back(kPdr);
  if (ins_) names.push_back(kIns);
  if (altitude_) names.push_back(kAltitude);
  return names;
}

template <class Msg>
void ReplayHost::emit(const std::string& channel, const Msg& msg) {
  buffer_.resize(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  ++stats_.estimates_out;
  sink_(channel, now_timestamp_, buffer_.data(), buffer_.size());
}

void ReplayHost::apply_site(const Site& site) {
  if (twr_) twr_->set_site(site);
  if (tdoa_) tdoa_->set_site(site);
  if (aoa_) aoa_->set_site(site);
  if (pdr_) pdr_->set_site(site);
  if (ins_) ins_->set_site(site);
  if (altitude_) altitude_->set_site(site);
}

void ReplayHost::finish() {
  if (tdoa_) tdoa_->flush();
  if (aoa_) aoa_->finish();
  if (altitude_) altitude_->finish();
}

void ReplayHost::process(const std::string& channel, int64_t timestamp, const uint8_t* data,
                         size_t size) {
  ++stats_.events_in;
  now_timestamp_ = timestamp;
  // Inputs pass through first, so each estimate follows the input that caused it.
  if (produced_channels_.count(channel) && !opts_.keep_regenerated) {
    ++stats_.dropped_regenerated;
  } else {
    ++stats_.passed_through;
    sink_(channel, timestamp, data, size);
  }
  if (channel == channels_.channel(channel::kSite) && opts_.site_path.empty()) {
    site_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    if (m.site_yaml == last_site_yaml_) return;
    try {
      apply_site(site_from_msg(m));
      last_site_yaml_ = m.site_yaml;
    } catch (const ConfigError&) {
      ++stats_.bad_sites;
    }
  } else if (twr_ && channel == channels_.channel(channel::kUwbRange)) {
    uwb_range_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    twr_->on_range(m);
  } else if (tdoa_ && channel == channels_.channel(channel::kUwbRx)) {
    uwb_rx_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    tdoa_->on_rx(m);
  } else if (aoa_ && channel == channels_.channel(channel::kBleAoa)) {
    ble_aoa_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    aoa_->on_event(m);
  } else if ((pdr_ || ins_) && channel == channels_.channel(channel::kImu)) {
    imu_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    if (pdr_) pdr_->on_imu(m);
    if (ins_) ins_->on_imu(m);
  } else if (altitude_ && channel == channels_.channel(channel::kBaro)) {
    baro_t m;
    if (!decode_message(m, data, size)) {
      ++stats_.undecodable;
      return;
    }
    altitude_->on_baro(m);
  }
}

}  // namespace ips::replay
