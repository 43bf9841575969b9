#include "loggers/replay/replay_host.hpp"

#include <algorithm>
#include <ips/altitude_t.hpp>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/step_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <ips/uwb_tdoa_t.hpp>
#include <type_traits>
#include <utility>

#include "core/channels.hpp"
#include "core/node.hpp"
#include "core/tag_filter.hpp"

namespace ips::replay {

namespace {
// Steps per batch handed to the second thread, and batches queued at most.
constexpr size_t kBatchSteps = 4096;
constexpr size_t kMaxQueuedBatches = 8;
constexpr const char* kUwbTwr = "uwb_twr";
constexpr const char* kUwbTdoa = "uwb_tdoa";
constexpr const char* kAoa = "aoa";
constexpr const char* kPdr = "pdr";
constexpr const char* kIns = "ins";
constexpr const char* kAltitude = "altitude";
constexpr const char* kFuse = "fuse";
constexpr const char* kZones = "zones";
}  // namespace

std::vector<std::string> ReplayHost::available() {
  return {kUwbTwr, kUwbTdoa, kAoa, kPdr, kIns, kAltitude, kFuse, kZones};
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
  std::string tags_error;
  auto selector = TagSelector::parse(opts_.tags, opts_.shard, tags_error);
  if (!selector) throw ConfigError(tags_error);
  tags_ = *selector;
  stage_tags_ = std::move(*selector);
  auto wanted = [&](const char* name) {
    return (opts_.only.empty() || opts_.only.count(name)) && !opts_.except.count(name);
  };
  if (wanted(kUwbTwr)) {
    const std::string out = channels_.channel(channel::kPoseUwb);
    twr_ = std::make_unique<uwb_twr::TwrEstimator>([this, out](const pose_t& p) {
      ++counts_[kTwrIndex].out;
      emit(out, p);
    });
    produce(kUwbTwr, out);
    // The per-epoch fixes, when the site asks for them (estimators.uwb_twr.epoch_fixes): not
    // counted as the tracker's estimates.
    const std::string epoch_out = channels_.channel(channel::kPoseUwbEpoch);
    twr_->set_epoch_sink([this, epoch_out](const pose_t& p) { emit(epoch_out, p); });
    produce(kUwbTwr, epoch_out);
  }
  if (wanted(kUwbTdoa)) {
    const std::string pose_out = channels_.channel(channel::kPoseTdoa);
    const std::string clock_out = channels_.channel(channel::kClock);
    tdoa_ = std::make_unique<uwb_tdoa::TdoaEstimator>(
        [this, pose_out](const pose_t& p) {
          ++counts_[kTdoaIndex].out;
          emit(pose_out, p);
        },
        [this, clock_out](const clock_t& c) {
          ++counts_[kTdoaIndex].out;
          emit(clock_out, c);
        });
    produce(kUwbTdoa, pose_out);
    produce(kUwbTdoa, clock_out);
  }
  if (wanted(kAoa)) {
    const std::string out = channels_.channel(channel::kPoseAoa);
    aoa_ = std::make_unique<aoa::AoaEstimator>([this, out](const pose_t& p) {
      ++counts_[kAoaIndex].out;
      emit(out, p);
    });
    produce(kAoa, out);
  }
  if (wanted(kPdr)) {
    const std::string steps = channels_.channel(channel::kStep);
    const std::string poses = channels_.channel(channel::kPosePdr);
    pdr_ = std::make_unique<pdr::PdrEstimator>(
        [this, steps](const step_t& s) {
          ++counts_[kPdrIndex].out;
          emit(steps, s);
        },
        [this, poses](const pose_t& p) {
          ++counts_[kPdrIndex].out;
          emit(poses, p);
        });
    produce(kPdr, steps);
    produce(kPdr, poses);
  }
  if (wanted(kIns)) {
    const std::string out = channels_.channel(channel::kPoseIns);
    ins_ = std::make_unique<ins::InsEstimator>([this, out](const pose_t& p) {
      ++counts_[kInsIndex].out;
      emit(out, p);
    });
    produce(kIns, out);
  }
  if (wanted(kAltitude)) {
    const std::string out = channels_.channel(channel::kAltitude);
    altitude_ = std::make_unique<altitude::AltitudeEstimator>(
        [this, out](const altitude_t& a) {
          ++counts_[kAltitudeIndex].out;
          emit(out, a);
        });
    produce(kAltitude, out);
  }
  if (wanted(kFuse)) {
    const std::string out = channels_.channel(channel::kPoseFused);
    // Written, never fed back: the fusion does not read its own output.
    fuse_ = std::make_unique<fusion::FuseEstimator>([this, out](const pose_t& p) {
      ++counts_[kFuseIndex].out;
      write(out, p);
    });
    produce(kFuse, out);
  }
  if (wanted(kZones)) {
    // After the estimators: it watches what they produce (ips-zones on the bus).
    const std::string events = channels_.channel(channel::kZoneEvent);
    const std::string alerts = channels_.channel(channel::kAlert);
    zones::ZoneMonitorOptions zo;
    zo.pose_channel = opts_.zones_pose_channel;
    zones_ = std::make_unique<zones::ZoneMonitor>(
        zo,
        [this, events](const zone_event_t& e) {
          ++counts_[kZonesIndex].out;
          write(events, e);
        },
        [this, alerts](const alert_t& a) {
          ++counts_[kZonesIndex].out;
          write(alerts, a);
        });
    produce(kZones, events);
    produce(kZones, alerts);
  }
  produced_channels_.insert(opts_.produced_elsewhere.begin(), opts_.produced_elsewhere.end());
  for (const char* kind : {channel::kInsModule, channel::kPoseIns, channel::kPoseTdoa,
                           channel::kPoseAoa, channel::kStep, channel::kAltitude})
    fuse_log_channels_.insert(channels_.channel(kind));
  if (opts_.site) {
    apply_site(*opts_.site);
  } else if (!opts_.site_path.empty()) {
    apply_site(load_site_file(opts_.site_path));
  }
  if (opts_.threads >= 2 && (fuse_ || zones_)) {
    threaded_ = true;
    thread_ = std::thread(&ReplayHost::worker, this);
  }
}

ReplayHost::~ReplayHost() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> l(mutex_);
    stop_ = true;
    queue_.clear();
  }
  cv_.notify_all();
  thread_.join();
}

uint32_t ReplayHost::intern(const std::string& channel) {
  const auto it = channel_index_.find(channel);
  if (it != channel_index_.end()) return it->second;
  const auto index = static_cast<uint32_t>(channel_names_.size());
  channel_names_.push_back(channel);
  channel_index_.emplace(channel, index);
  return index;
}

ReplayHost::Input ReplayHost::input_of(const std::string& channel) const {
  const auto is = [&](const char* kind) { return channel == channels_.channel(kind); };
  const auto read_if = [](bool read, Input input) { return read ? input : Input::kOther; };
  if (is(channel::kSite)) return read_if(opts_.site_path.empty() && !opts_.site, Input::kSite);
  if (is(channel::kUwbRange)) return read_if(twr_ || fuse_, Input::kUwbRange);
  if (is(channel::kUwbRx)) return read_if(tdoa_ || fuse_, Input::kUwbRx);
  if (is(channel::kUwbTdoa)) return read_if(tdoa_ || fuse_, Input::kUwbTdoa);  // pairwise
  if (is(channel::kBleAoa)) return read_if(aoa_ || fuse_, Input::kBleAoa);
  if (is(channel::kImu)) return read_if(pdr_ || ins_ || fuse_, Input::kImu);
  if (is(channel::kBaro)) return read_if(altitude_ != nullptr, Input::kBaro);
  // What a hosted estimator regenerates reaches ips-fuse as it is written, not from the log.
  if (!fuse_ || produced_channels_.count(channel) || !fuse_log_channels_.count(channel))
    return Input::kOther;
  if (is(channel::kStep)) return Input::kFuseStep;
  if (is(channel::kAltitude)) return Input::kFuseAltitude;
  return Input::kFusePose;
}

const ReplayHost::ChannelInfo& ReplayHost::classify(const std::string& channel) {
  const auto it = channel_info_.find(channel);
  if (it != channel_info_.end()) return it->second;
  ChannelInfo c;
  c.id = intern(channel);
  c.produced = produced_channels_.count(channel) > 0;
  c.input = input_of(channel);
  const auto is = [&](const char* kind) { return channel == channels_.channel(kind); };
  // What a hosted estimator regenerates reaches ips-zones as it is written.
  c.to_zones =
      zones_ && !c.produced &&
      (channel == opts_.zones_pose_channel || is(channel::kAltitude) || is(channel::kHealth));
  return channel_info_.emplace(channel, c).first->second;
}

void ReplayHost::post(Op op, uint32_t ch, const uint8_t* data, size_t size, bool stable) {
  // An estimate is this host's own, even when a shared input caused it (a sync master's broadcast
  // closes a blink of this lane's tag): the fusion counts it as an input of this host alone.
  const bool estimate =
      op == Op::kEstimate || op == Op::kEmitPose || op == Op::kEmitStep || op == Op::kEmitAltitude;
  const bool shared = shared_input_ && !estimate;
  if (!threaded_) {
    run(Step{op, ch, now_timestamp_, data, 0, size, shared}, data);
    return;
  }
  Step s{op, ch, now_timestamp_, stable ? data : nullptr, batch_.bytes.size(), size, shared};
  if (!stable && size > 0) batch_.bytes.insert(batch_.bytes.end(), data, data + size);
  batch_.steps.push_back(s);
  if (batch_.steps.size() >= kBatchSteps) submit();
}

void ReplayHost::submit() {
  rethrow_worker_error();
  {
    std::unique_lock<std::mutex> l(mutex_);
    cv_.wait(l, [this] { return queue_.size() < kMaxQueuedBatches || worker_failed_; });
    queue_.push_back(std::move(batch_));
    if (!spare_.empty()) {
      batch_ = std::move(spare_.back());
      spare_.pop_back();
    } else {
      batch_ = Batch{};
    }
  }
  batch_.steps.clear();
  batch_.bytes.clear();
  cv_.notify_all();
  rethrow_worker_error();
}

void ReplayHost::worker() {
  for (;;) {
    Batch b;
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait(l, [this] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;
      b = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
    }
    if (!worker_failed_) {
      try {
        run_batch(b);
      } catch (...) {
        worker_error_ = std::current_exception();
        worker_failed_ = true;
      }
    }
    {
      std::lock_guard<std::mutex> l(mutex_);
      busy_ = false;
      spare_.push_back(std::move(b));
    }
    cv_.notify_all();
  }
}

void ReplayHost::rethrow_worker_error() {
  if (!worker_failed_) return;
  std::lock_guard<std::mutex> l(mutex_);
  if (worker_error_) std::rethrow_exception(std::exchange(worker_error_, nullptr));
}

void ReplayHost::run_batch(const Batch& b) {
  for (const Step& s : b.steps) run(s, s.data ? s.data : b.bytes.data() + s.offset);
}

void ReplayHost::run(const Step& s, const uint8_t* data) {
  stage_timestamp_ = s.timestamp;
  stage_shared_ = s.shared;
  if (s.shared) ++stage_shared_inputs_;
  const std::string& channel = channel_names_[s.channel];
  // Decodes a message this process encoded or already decoded once: it cannot fail.
  const auto decoded = [&](auto msg) {
    decode_message(msg, data, s.size);
    return msg;
  };
  const auto to_fuse = [&](auto msg, auto&& use) {
    count_in(kFuseIndex, stage_shared_);
    const auto m = decoded(std::move(msg));
    take_shared(stage_shared_, stage_shared_inputs_, kFuse, *fuse_, [&] { use(m); });
  };
  // A first-stage estimator's estimate: written, heard by ips-zones, handed to the fusion.
  const auto emitted = [&](auto msg) {
    const auto m = decoded(std::move(msg));
    ++stats_.estimates_out;
    sink_(channel, s.timestamp, data, s.size);
    zones_hear(channel, m);
    if (fuse_) feed_fuse(channel, m);
  };
  switch (s.op) {
    case Op::kWrite:
      sink_(channel, s.timestamp, data, s.size);
      break;
    case Op::kEstimate:
      ++stats_.estimates_out;
      sink_(channel, s.timestamp, data, s.size);
      break;
    case Op::kEmitPose:
      emitted(pose_t{});
      break;
    case Op::kEmitStep:
      emitted(step_t{});
      break;
    case Op::kEmitAltitude:
      emitted(altitude_t{});
      break;
    case Op::kFuseRange:
      to_fuse(uwb_range_t{}, [this](const uwb_range_t& m) { fuse_->on_range(m); });
      break;
    case Op::kFuseRx:
      to_fuse(uwb_rx_t{}, [this](const uwb_rx_t& m) { fuse_->on_rx(m); });
      break;
    case Op::kFusePair:
      to_fuse(uwb_tdoa_t{}, [this](const uwb_tdoa_t& m) { fuse_->on_pair(m); });
      break;
    case Op::kFuseAoa:
      to_fuse(ble_aoa_t{}, [this](const ble_aoa_t& m) { fuse_->on_aoa(m); });
      break;
    case Op::kFuseImu:
      to_fuse(imu_t{}, [this](const imu_t& m) { fuse_->on_imu(m); });
      break;
    case Op::kFuseFromLog:
      feed_fuse_from_log(channel, data, s.size);
      break;
    case Op::kZonesFromLog:
      feed_zones_from_log(channel, data, s.size);
      break;
    case Op::kSite:
      stage_tags_.set_always_selected(site_non_tag_ids(*sites_[s.offset]));
      if (fuse_) fuse_->set_site(*sites_[s.offset]);
      if (zones_) zones_->set_site(*sites_[s.offset]);
      break;
    case Op::kFinish:
      if (fuse_) fuse_->flush();
      break;
  }
}

std::vector<std::string> ReplayHost::hosted() const {
  std::vector<std::string> names;
  if (twr_) names.push_back(kUwbTwr);
  if (tdoa_) names.push_back(kUwbTdoa);
  if (aoa_) names.push_back(kAoa);
  if (pdr_) names.push_back(kPdr);
  if (ins_) names.push_back(kIns);
  if (altitude_) names.push_back(kAltitude);
  if (fuse_) names.push_back(kFuse);
  if (zones_) names.push_back(kZones);
  return names;
}

// The second stage's own estimates (ips-fuse's, ips-zones'): to the sink, and to ips-zones.
template <class Msg>
void ReplayHost::write(const std::string& channel, const Msg& msg) {
  stage_buffer_.resize(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(stage_buffer_.data(), 0, static_cast<int>(stage_buffer_.size()));
  ++stats_.estimates_out;
  sink_(channel, stage_timestamp_, stage_buffer_.data(), stage_buffer_.size());
  zones_hear(channel, msg);
}

// ips-zones hears the estimates as they are written (POSE_FUSED too: fuse's poses are written,
// not emitted).
template <class Msg>
void ReplayHost::zones_hear(const std::string& channel, const Msg& msg) {
  if constexpr (std::is_same_v<Msg, pose_t>) {
    if (zones_ && channel == opts_.zones_pose_channel) {
      count_in(kZonesIndex, stage_shared_);
      zones_->on_pose(msg);
    }
  } else if constexpr (std::is_same_v<Msg, altitude_t>) {
    if (zones_ && channel == channels_.channel(channel::kAltitude)) {
      count_in(kZonesIndex, stage_shared_);
      zones_->on_altitude(msg);
    }
  }
}

// A first-stage estimator's estimate: encoded here, written and handed to the fusion by the
// second stage.
template <class Msg>
void ReplayHost::emit(const std::string& channel, const Msg& msg) {
  buffer_.resize(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
  if (!threaded_) {  // what run() does with the step, without decoding what is at hand
    stage_timestamp_ = now_timestamp_;
    stage_shared_ = false;  // as post() marks an estimate
    ++stats_.estimates_out;
    sink_(channel, now_timestamp_, buffer_.data(), buffer_.size());
    zones_hear(channel, msg);
    if (fuse_) feed_fuse(channel, msg);
    return;
  }
  Op op = Op::kEstimate;
  if constexpr (std::is_same_v<Msg, pose_t>) op = Op::kEmitPose;
  if constexpr (std::is_same_v<Msg, step_t>) op = Op::kEmitStep;
  if constexpr (std::is_same_v<Msg, altitude_t>) op = Op::kEmitAltitude;
  post(op, channel, buffer_.data(), buffer_.size(), false);
}

void ReplayHost::feed_fuse(const std::string& channel, const pose_t& m) {
  if (channel == channels_.channel(channel::kPoseIns)) {
    count_in(kFuseIndex, stage_shared_);
    fuse_->on_pose_ins(m);
  } else if (channel == channels_.channel(channel::kPoseTdoa)) {
    count_in(kFuseIndex, stage_shared_);
    fuse_->on_pose(m, "tdoa");
  } else if (channel == channels_.channel(channel::kPoseAoa)) {
    count_in(kFuseIndex, stage_shared_);
    fuse_->on_pose(m, "aoa");
  }
}

void ReplayHost::feed_fuse(const std::string& channel, const step_t& m) {
  if (channel != channels_.channel(channel::kStep)) return;
  count_in(kFuseIndex, stage_shared_);
  fuse_->on_step(m);
}

void ReplayHost::feed_fuse(const std::string& channel, const altitude_t& m) {
  if (channel != channels_.channel(channel::kAltitude)) return;
  count_in(kFuseIndex, stage_shared_);
  fuse_->on_altitude(m);
}

void ReplayHost::feed_fuse_from_log(const std::string& channel, const uint8_t* data, size_t size) {
  // The channels are the live ips-fuse's. An input a hosted estimator regenerates reaches the
  // fusion through emit(), never from here: input_of() does not make its log events kFuse*.
  const bool ins_module = channel == channels_.channel(channel::kInsModule);
  if (ins_module || channel == channels_.channel(channel::kPoseIns) ||
      channel == channels_.channel(channel::kPoseTdoa) ||
      channel == channels_.channel(channel::kPoseAoa)) {
    pose_t m;
    if (!decode_message(m, data, size)) {
      ++stage_undecodable_;
      return;
    }
    if (!stage_take(m.tag_id)) return;
    if (ins_module) {
      count_in(kFuseIndex, stage_shared_);
      fuse_->on_ins_module(m);
    } else {
      feed_fuse(channel, m);
    }
  } else if (channel == channels_.channel(channel::kStep)) {
    step_t m;
    if (!decode_message(m, data, size)) {
      ++stage_undecodable_;
      return;
    }
    if (!stage_take(m.tag_id)) return;
    count_in(kFuseIndex, stage_shared_);
    fuse_->on_step(m);
  } else if (channel == channels_.channel(channel::kAltitude)) {
    altitude_t m;
    if (!decode_message(m, data, size)) {
      ++stage_undecodable_;
      return;
    }
    if (!stage_take(m.tag_id)) return;
    count_in(kFuseIndex, stage_shared_);
    fuse_->on_altitude(m);
  }
}

void ReplayHost::apply_site(const Site& site) {
  site_applied_ = true;
  tags_.set_always_selected(site_non_tag_ids(site));
  if (twr_) twr_->set_site(site);
  if (tdoa_) tdoa_->set_site(site);
  if (aoa_) aoa_->set_site(site);
  if (pdr_) pdr_->set_site(site);
  if (ins_) ins_->set_site(site);
  if (altitude_) altitude_->set_site(site);
  if (fuse_ || zones_) {
    sites_.push_back(std::make_unique<Site>(site));
    const uint32_t ch = intern(channels_.channel(channel::kSite));
    const Step step{Op::kSite, ch, now_timestamp_, nullptr, sites_.size() - 1, 0};
    if (!threaded_) {
      run(step, nullptr);
    } else {
      batch_.steps.push_back(step);
    }
  }
}

void ReplayHost::feed_zones_from_log(const std::string& channel, const uint8_t* data,
                                     size_t size) {
  // What a hosted estimator regenerates reaches ips-zones through write().
  if (produced_channels_.count(channel)) return;
  auto feed = [&](auto msg, auto&& use) {
    if (!decode_message(msg, data, size)) {
      ++stage_undecodable_;
      return;
    }
    if constexpr (requires { msg.tag_id; })
      if (!stage_take(msg.tag_id)) return;
    count_in(kZonesIndex, stage_shared_);
    use(msg);
  };
  if (channel == opts_.zones_pose_channel) {
    feed(pose_t{}, [this](const pose_t& m) { zones_->on_pose(m); });
  } else if (channel == channels_.channel(channel::kAltitude)) {
    feed(altitude_t{}, [this](const altitude_t& m) { zones_->on_altitude(m); });
  } else if (channel == channels_.channel(channel::kHealth)) {
    feed(health_t{}, [this](const health_t& m) { zones_->on_health(m); });
  }
}

void ReplayHost::finish(std::optional<int64_t> end_timestamp) {
  if (end_timestamp) now_timestamp_ = *end_timestamp;
  if (tdoa_) tdoa_->flush();
  if (aoa_) aoa_->finish();
  if (altitude_) altitude_->finish();
  post(Op::kFinish, channels_.channel(channel::kSite), nullptr, 0, false);
  if (threaded_) {
    submit();
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait(l, [this] { return (queue_.empty() && !busy_) || worker_failed_; });
      stop_ = true;
      queue_.clear();
    }
    cv_.notify_all();
    thread_.join();
    threaded_ = false;
    rethrow_worker_error();
  }
  stats_.undecodable += std::exchange(stage_undecodable_, 0);
  stats_.skipped_other_tags += std::exchange(stage_skipped_, 0);
}

void ReplayHost::process(const std::string& channel, int64_t timestamp, const uint8_t* data,
                         size_t size, bool stable) {
  if (worker_failed_) rethrow_worker_error();
  ++stats_.events_in;
  now_timestamp_ = timestamp;
  if (shared_input_) ++shared_inputs_;
  const ChannelInfo& c = classify(channel);
  // Inputs pass through first, so each estimate follows the input that caused it.
  if (c.produced && !opts_.keep_regenerated) {
    ++stats_.dropped_regenerated;
  } else {
    ++stats_.passed_through;
    if (opts_.pass_through) post(Op::kWrite, c.id, data, size, stable);
  }
  if (c.to_zones) post(Op::kZonesFromLog, c.id, data, size, stable);
  // Decodes the event as Msg: false, counted, when it is not one.
  const auto decode = [&](auto& m) {
    if (decode_message(m, data, size)) return true;
    ++stats_.undecodable;
    return false;
  };
  switch (c.input) {
    case Input::kSite: {
      site_t m;
      if (!decode(m) || m.site_yaml == last_site_yaml_) break;
      try {
        apply_site(site_from_msg(m));
        last_site_yaml_ = m.site_yaml;
      } catch (const ConfigError&) {
        ++stats_.bad_sites;
      }
      break;
    }
    case Input::kUwbRange: {
      uwb_range_t m;
      if (!decode(m) || !take(m.tag_id)) break;
      if (twr_) {
        count_in(kTwrIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kUwbTwr, *twr_, [&] { twr_->on_range(m); });
      }
      if (fuse_) post(Op::kFuseRange, c.id, data, size, stable);
      break;
    }
    case Input::kUwbRx: {
      uwb_rx_t m;
      // A sync master's broadcast serves every tag.
      if (!decode(m) || (!m.is_sync && !take(m.sender_id))) break;
      // ips-fuse hears a blink before the POSE_TDOA made of it, as on the bus.
      if (fuse_) post(Op::kFuseRx, c.id, data, size, stable);
      if (tdoa_) {
        count_in(kTdoaIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kUwbTdoa, *tdoa_, [&] { tdoa_->on_rx(m); });
      }
      break;
    }
    case Input::kUwbTdoa: {
      uwb_tdoa_t m;
      if (!decode(m) || !take(m.tag_id)) break;
      if (fuse_) post(Op::kFusePair, c.id, data, size, stable);
      if (tdoa_) {
        count_in(kTdoaIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kUwbTdoa, *tdoa_, [&] { tdoa_->on_pair(m); });
      }
      break;
    }
    case Input::kBleAoa: {
      ble_aoa_t m;
      if (!decode(m) || !take(m.tag_id)) break;
      if (fuse_) post(Op::kFuseAoa, c.id, data, size, stable);
      if (aoa_) {
        count_in(kAoaIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kAoa, *aoa_, [&] { aoa_->on_event(m); });
      }
      break;
    }
    case Input::kImu: {
      imu_t m;
      if (!decode(m) || !take(m.device_id)) break;
      if (fuse_) post(Op::kFuseImu, c.id, data, size, stable);
      if (pdr_) {
        count_in(kPdrIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kPdr, *pdr_, [&] { pdr_->on_imu(m); });
      }
      if (ins_) {
        count_in(kInsIndex, shared_input_);
        take_shared(shared_input_, shared_inputs_, kIns, *ins_, [&] { ins_->on_imu(m); });
      }
      break;
    }
    case Input::kBaro: {
      baro_t m;
      if (!decode(m) || (!m.is_reference && !take(m.sensor_id))) break;
      count_in(kAltitudeIndex, shared_input_);
      take_shared(shared_input_, shared_inputs_, kAltitude, *altitude_,
                  [&] { altitude_->on_baro(m); });
      break;
    }
    case Input::kFusePose:
    case Input::kFuseStep:
    case Input::kFuseAltitude:
      post(Op::kFuseFromLog, c.id, data, size, stable);
      break;
    case Input::kOther:
      break;
  }
}

void ReplayHost::estimate(const std::string& channel, int64_t timestamp, const uint8_t* data,
                          size_t size) {
  if (worker_failed_) rethrow_worker_error();
  now_timestamp_ = timestamp;
  Op op = Op::kEstimate;
  if (channel == opts_.zones_pose_channel) {
    op = Op::kEmitPose;
  } else if (channel == channels_.channel(channel::kAltitude)) {
    op = Op::kEmitAltitude;
  }
  post(op, channel, data, size, false);
}

void describe_account(EstimatorAccount& a, bool only_given, bool site_applied) {
  a.silent = a.messages_in > 0 && a.estimates_out == 0;
  a.warn = a.silent && (a.drops.faults() > 0 || only_given);
  a.line = a.name + ": " + std::to_string(a.messages_in) + " " + a.inputs + " in, " +
           std::to_string(a.estimates_out) + " estimates out";
  if (a.silent) {
    // The dominant reasons say why; without any, the input was taken and gave nothing yet.
    a.line += ": ";
    a.line += a.drops.total() > 0 ? a.drops.summary(3) : "none dropped, none gave an estimate yet";
  } else if (a.drops.total() > 0) {
    a.line += "; " + a.drops.text();
  }
  if (a.drops.count(DropReason::kNoSite) > 0 && !site_applied)
    a.line += " (the log has no SITE: give --site FILE)";
}

std::vector<EstimatorAccount> ReplayHost::accounts() const {
  const auto ch = [this](const char* kind) { return channels_.channel(kind); };
  std::vector<EstimatorAccount> out;
  auto account = [&](Hosted index, const char* name, std::string inputs, const auto& est) {
    const DropReasons drops = est.drop_reasons();
    EstimatorAccount a;
    if constexpr (requires { est.consistency().run_summary(); }) {
      a.consistency = est.consistency().run_summary();
      a.consistency_problems = est.consistency().problems();
    }
    if constexpr (requires { est.problems(); }) a.problems = est.problems();
    if constexpr (requires { est.run_notes(); }) a.notes = est.run_notes();
    a.name = name;
    a.inputs = std::move(inputs);
    a.messages_in = counts_[index].in;
    a.shared_in = counts_[index].shared_in;
    a.estimates_out = counts_[index].out;
    a.drops = drops;
    describe_account(a, !opts_.only.empty(), site_applied_);
    out.push_back(std::move(a));
  };
  if (twr_) account(kTwrIndex, kUwbTwr, ch(channel::kUwbRange), *twr_);
  // Raw receptions, or pairwise differences (UWB_TDOA) when the log had only those.
  if (tdoa_)
    account(kTdoaIndex, kUwbTdoa,
            tdoa_->pair_stats().pairs_in > 0 && tdoa_->stats().rx_in == 0 ? ch(channel::kUwbTdoa)
                                                                          : ch(channel::kUwbRx),
            *tdoa_);
  if (aoa_) account(kAoaIndex, kAoa, ch(channel::kBleAoa), *aoa_);
  if (pdr_) account(kPdrIndex, kPdr, ch(channel::kImu), *pdr_);
  if (ins_) account(kInsIndex, kIns, ch(channel::kImu), *ins_);
  if (altitude_) account(kAltitudeIndex, kAltitude, ch(channel::kBaro), *altitude_);
  if (fuse_) account(kFuseIndex, kFuse, "messages", *fuse_);
  if (zones_) account(kZonesIndex, kZones, opts_.zones_pose_channel, *zones_);
  return out;
}

std::string ReplayHost::nothing_estimated() const {
  // ips-zones consumes estimates and is not one: its events count only when it is alone.
  return replay::nothing_estimated(accounts(), zones_ && hosted().size() == 1);
}

std::string nothing_estimated(const std::vector<EstimatorAccount>& accounts, bool zones_alone) {
  int64_t in = 0, out = 0;
  std::string inputs, why, fuse_why;
  for (const auto& a : accounts) {
    if (a.name == kZones && !zones_alone) continue;
    in += a.messages_in;
    out += a.estimates_out;
    if (a.name == kFuse) {
      if (a.silent) fuse_why = a.line;
      continue;
    }
    inputs += (inputs.empty() ? "" : ", ") + a.name + ": " + a.inputs;
    if (a.silent) why += (why.empty() ? "" : "; ") + a.line;
  }
  if (out > 0) return "";
  if (in == 0)
    return "the log holds no input for the hosted estimators (" +
           (inputs.empty() ? std::string("fuse: its inputs") : inputs) + "): nothing estimated";
  // The fusion's account repeats its sources' unless it was alone.
  return "no hosted estimator gave an estimate: " + (why.empty() ? fuse_why : why);
}

}  // namespace ips::replay
