#include "loggers/replay/replayer.hpp"

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
#include <utility>

#include "core/channels.hpp"
#include "core/node.hpp"
#include "core/tag_filter.hpp"
#include "core/time.hpp"

namespace ips::replay {

namespace {
// Events per job, and jobs in flight at most (run, or waiting to be merged).
constexpr size_t kJobEvents = 32768;
constexpr size_t kMaxJobsInFlight = 4;
}  // namespace

Replayer::Replayer(const ReplayOptions& opts, const CommonOptions& channels, ReplayHost::Sink sink)
    : opts_(opts), channels_(channels) {
  if (opts_.lanes < 0 || opts_.lanes > kMaxShards)
    throw ConfigError("--lanes: " + std::to_string(opts_.lanes) + " is not from 1 to " +
                      std::to_string(kMaxShards));
  if (opts_.lanes == 0) {
    single_ = std::make_unique<ReplayHost>(opts_, channels_, std::move(sink));
    return;
  }
  std::string error;
  auto selector = TagSelector::parse(opts_.tags, opts_.shard, error);
  if (!selector) throw ConfigError(error);
  selector_ = std::move(*selector);
  // The site file is read once, for every host.
  if (!opts_.site && !opts_.site_path.empty())
    opts_.site = std::make_shared<const Site>(load_site_file(opts_.site_path));
  if (opts_.site) {
    const auto ids = site_non_tag_ids(*opts_.site);
    non_tags_.insert(ids.begin(), ids.end());
  }
  ReplayOptions lane = opts_;
  lane.threads = 1;
  lane.lanes = 0;
  lane.tags.clear();  // the dispatcher applies --tags and --shard, and hands a lane only its tags
  lane.shard.clear();
  lane.pass_through = false;
  lane.except.insert("zones");
  lanes_.reserve(static_cast<size_t>(opts_.lanes));  // a lane's sink keeps its address
  for (int k = 0; k < opts_.lanes; ++k) {
    Lane& l = lanes_.emplace_back();
    Lane* self = &l;
    l.host = std::make_unique<ReplayHost>(
        lane, channels_,
        [self](const std::string& ch, int64_t ts, const uint8_t* data, size_t size) {
          LaneOutput& out = *self->output;
          auto name = self->channels.find(ch);  // no node made per estimate
          if (name == self->channels.end()) name = self->channels.emplace(ch).first;
          out.estimates.push_back(Estimate{self->event, &*name, ts, out.bytes.size(), size});
          out.bytes.insert(out.bytes.end(), data, data + size);
        });
  }
  ReplayOptions merger = opts_;  // run by the merging thread
  merger.threads = 1;
  merger.lanes = 0;
  merger.only.clear();
  merger.except.clear();
  for (const auto& name : ReplayHost::available())
    if (name != "zones" || (!opts_.only.empty() && !opts_.only.count(name)))
      merger.except.insert(name);
  merger.produced_elsewhere = lanes_.front().host->produced_channels();
  merger_ = std::make_unique<ReplayHost>(merger, channels_, std::move(sink));
  job_ = take_spare_job();
  caller_cpu_start_s_ = thread_cpu_s();
  const size_t workers = static_cast<size_t>(std::clamp(opts_.threads, 1, opts_.lanes));
  try {
    for (size_t w = 0; w < workers; ++w) workers_.emplace_back(&Replayer::worker, this, w);
    merging_ = std::thread(&Replayer::merging, this);
  } catch (...) {  // no thread to be had: those started stop before the error leaves
    stop_threads();
    throw;
  }
}

Replayer::~Replayer() { stop_threads(); }

void Replayer::stop_threads() {
  {
    std::lock_guard<std::mutex> l(mutex_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : workers_) t.join();
  workers_.clear();
  if (merging_.joinable()) merging_.join();
}

int32_t Replayer::lane_of_id(const std::string& id) {
  if (non_tags_.count(id)) return kToEveryLane;
  if (!selector_.selects_all() && !selector_.selects(id)) {
    ++skipped_;
    return kToNoLane;
  }
  return lane_of_tag(id, static_cast<int>(lanes_.size()), selector_.shards());
}

int Replayer::lane_of_tag(std::string_view id, int lanes, int shards) {
  // shard_of(id, L) - 1 when the tags are not sharded, so that a lane is --shard K/L; within
  // --shard K/N, the hash over N first, so that shard K's tags still spread over the lanes.
  const uint64_t n = shards > 0 ? static_cast<uint64_t>(shards) : 1;
  return static_cast<int>(fnv1a64(id) / n % static_cast<uint64_t>(lanes));
}

int32_t Replayer::lane_of(Input input, const uint8_t* data, size_t size) {
  // Decodes the event as Msg, and its lane from the id `id_of` gives ("" for every lane). An
  // event that does not decode goes to the first lane, which counts it once.
  const auto by_id = [&](auto msg, auto&& id_of) -> int32_t {
    if (!decode_message(msg, data, size)) return 0;
    const std::string* id = id_of(msg);
    return id == nullptr ? kToEveryLane : lane_of_id(*id);
  };
  switch (input) {
    case Input::kOther:
      return kToNoLane;
    case Input::kSite: {
      // A new site, valid, reaches every lane; the others change nothing there (the merger
      // counts them as a lane would).
      site_t m;
      if (!decode_message(m, data, size) || m.site_yaml == last_site_yaml_) return kToNoLane;
      try {
        const auto ids = site_non_tag_ids(site_from_msg(m));
        non_tags_ = {ids.begin(), ids.end()};
        selector_.set_always_selected(ids);
      } catch (const ConfigError&) {
        return kToNoLane;
      }
      last_site_yaml_ = m.site_yaml;
      return kToEveryLane;
    }
    case Input::kUwbRange: {
      // A range between two anchors (a survey's) is no tag's: every lane would drop it, so the
      // first takes it and counts it once.
      const int32_t lane = by_id(uwb_range_t{}, [](const auto& m) { return &m.tag_id; });
      return lane == kToEveryLane ? 0 : lane;
    }
    case Input::kUwbRx:  // a sync master's broadcast serves every tag
      return by_id(uwb_rx_t{}, [](const auto& m) { return m.is_sync ? nullptr : &m.sender_id; });
    case Input::kUwbTdoa:
      return by_id(uwb_tdoa_t{}, [](const auto& m) { return &m.tag_id; });
    case Input::kBleAoa:
      return by_id(ble_aoa_t{}, [](const auto& m) { return &m.tag_id; });
    case Input::kImu:
      return by_id(imu_t{}, [](const auto& m) { return &m.device_id; });
    case Input::kBaro:  // as is a reference station's reading
      return by_id(baro_t{}, [](const auto& m) { return m.is_reference ? nullptr : &m.sensor_id; });
    case Input::kFusePose:
      return by_id(pose_t{}, [](const auto& m) { return &m.tag_id; });
    case Input::kFuseStep:
      return by_id(step_t{}, [](const auto& m) { return &m.tag_id; });
    case Input::kFuseAltitude:
      return by_id(altitude_t{}, [](const auto& m) { return &m.tag_id; });
  }
  return kToNoLane;
}

void Replayer::process(const std::string& channel, int64_t timestamp, const uint8_t* data,
                       size_t size, bool stable) {
  if (single_) {
    single_->process(channel, timestamp, data, size, stable);
    return;
  }
  rethrow_worker_error();
  ++events_in_;
  end_timestamp_ = timestamp;
  auto it = routes_.find(channel);
  if (it == routes_.end())
    it = routes_.emplace(channel, lanes_.front().host->input_of(channel)).first;
  Event e{&it->first,
          timestamp,
          stable ? data : nullptr,
          job_->bytes.size(),
          size,
          lane_of(it->second, data, size),
          !stable};
  if (!stable) job_->bytes.insert(job_->bytes.end(), data, data + size);
  // Each lane walks only its own events (and those of every lane), not the whole job.
  const auto index = static_cast<uint32_t>(job_->events.size());
  if (e.lane == kToEveryLane) {
    for (auto& own : job_->lane_events) own.push_back(index);
  } else if (e.lane >= 0) {
    job_->lane_events[static_cast<size_t>(e.lane)].push_back(index);
  }
  job_->events.push_back(e);
  if (job_->events.size() >= kJobEvents) submit();
}

void Replayer::submit() {
  for (Event& e : job_->events)
    if (e.data == nullptr) e.data = job_->bytes.data() + e.offset;
  job_->output.resize(lanes_.size());
  job_->pending = static_cast<int>(workers_.size());
  {
    std::unique_lock<std::mutex> l(mutex_);
    in_flight_.push_back(std::move(job_));
    ++submitted_;
    cv_.notify_all();
    cv_.wait(l, [this] { return in_flight_.size() < kMaxJobsInFlight || worker_failed_; });
    job_ = take_spare_job();
  }
  rethrow_worker_error();
}

void Replayer::record_error() {
  std::lock_guard<std::mutex> l(mutex_);
  if (!worker_error_) worker_error_ = std::current_exception();
  worker_failed_ = true;
  cv_.notify_all();
}

void Replayer::merging() {
  for (;;) {
    std::unique_ptr<Job> done;
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait(l, [this] {
        return stop_ || worker_failed_ || (!in_flight_.empty() && in_flight_.front()->pending == 0);
      });
      if (stop_ || worker_failed_) return;
      done = std::move(in_flight_.front());
      in_flight_.pop_front();
      ++retired_;
    }
    const bool last = done->finish;
    try {
      merge(*done);
      if (last) merger_->finish(end_timestamp_);
    } catch (...) {
      record_error();
      return;
    }
    if (last) merging_cpu_s_ = thread_cpu_s();
    {
      std::lock_guard<std::mutex> l(mutex_);
      spare_jobs_.push_back(std::move(done));
      merged_all_ = last;
      cv_.notify_all();
    }
    if (last) return;
  }
}

std::unique_ptr<Replayer::Job> Replayer::take_spare_job() {
  if (spare_jobs_.empty()) {
    auto job = std::make_unique<Job>();
    job->lane_events.resize(lanes_.size());
    return job;
  }
  auto job = std::move(spare_jobs_.back());
  spare_jobs_.pop_back();
  job->events.clear();
  job->bytes.clear();
  job->finish = false;
  for (auto& own : job->lane_events) own.clear();
  for (LaneOutput& out : job->output) {
    out.estimates.clear();
    out.bytes.clear();
    out.shared_drops.clear();
  }
  return job;
}

void Replayer::worker(size_t index) {
  for (uint64_t next = 0;; ++next) {
    Job* job = nullptr;
    {
      std::unique_lock<std::mutex> l(mutex_);
      cv_.wait(l, [&] { return stop_ || next < submitted_; });
      if (stop_) return;
      job = in_flight_[next - retired_].get();
    }
    if (!worker_failed_) {
      try {
        run(*job, index);
      } catch (...) {
        record_error();
      }
    }
    {
      std::lock_guard<std::mutex> l(mutex_);
      --job->pending;
    }
    cv_.notify_all();
  }
}

void Replayer::run(Job& job, size_t worker_index) {
  const auto events = static_cast<uint32_t>(job.events.size());
  for (size_t k = worker_index; k < lanes_.size(); k += workers_.size()) {
    Lane& lane = lanes_[k];
    const double t0 = thread_cpu_s();
    lane.output = &job.output[k];
    for (const uint32_t i : job.lane_events[k]) {
      const Event& e = job.events[i];
      lane.event = i;
      lane.host->set_shared_input(e.lane == kToEveryLane);
      lane.host->process(*e.channel, e.timestamp, e.data, e.size, true);
    }
    if (job.finish) {
      lane.event = events;
      lane.host->finish(end_timestamp_);
    }
    lane.host->take_shared_drops(job.output[k].shared_drops);
    lane.cpu_s += thread_cpu_s() - t0;
  }
}

void Replayer::merge(Job& job) {
  count_repeated_drops(job);
  // Every lane's estimates in the order they are written: by the event that caused them, then
  // lane, then as the lane made them (each lane's list is in event order already).
  merge_order_.clear();
  for (uint32_t k = 0; k < lanes_.size(); ++k) {
    const auto& estimates = job.output[k].estimates;
    for (uint32_t n = 0; n < estimates.size(); ++n)
      merge_order_.push_back(Placed{estimates[n].event, k, n});
  }
  std::stable_sort(merge_order_.begin(), merge_order_.end(),
                   [](const Placed& a, const Placed& b) { return a.event < b.event; });
  // An estimate that serves every tag (an anchor's CLOCK, made from the sync master's broadcasts
  // every lane hears) is made by every lane: the same bytes from a later lane for the same event
  // and channel are written once. Estimates that differ are all written.
  struct Written {
    uint32_t lane;
    const Estimate* estimate;
    const uint8_t* bytes;
  };
  std::vector<Written> written;  // this event's
  const auto repeats = [&](uint32_t lane, const Estimate& m, const uint8_t* bytes) {
    for (const Written& w : written)
      if (w.lane < lane && w.estimate->size == m.size && *w.estimate->channel == *m.channel &&
          std::equal(bytes, bytes + m.size, w.bytes))
        return true;
    return false;
  };
  size_t next = 0;
  const auto estimates_of = [&](uint32_t event) {
    written.clear();
    for (; next < merge_order_.size() && merge_order_[next].event == event; ++next) {
      const Placed& at = merge_order_[next];
      const LaneOutput& out = job.output[at.lane];
      const Estimate& m = out.estimates[at.index];
      const uint8_t* bytes = out.bytes.data() + m.offset;
      if (repeats(at.lane, m, bytes)) {
        ++repeated_;
        ++repeated_by_channel_[*m.channel];
        continue;
      }
      merger_->estimate(*m.channel, m.timestamp, bytes, m.size);
      written.push_back(Written{at.lane, &m, bytes});
    }
  };
  const auto events = static_cast<uint32_t>(job.events.size());
  for (uint32_t i = 0; i < events; ++i) {
    const Event& e = job.events[i];
    merger_->process(*e.channel, e.timestamp, e.data, e.size, !e.copied);
    if (next < merge_order_.size() && merge_order_[next].event == i) estimates_of(i);
  }
  estimates_of(events);  // the lanes' finish()
}

void Replayer::count_repeated_drops(const Job& job) {
  // Every lane takes a shared input, the same one as its ordinal-th, within the same job. What
  // each lane's estimator dropped of it, per reason the least over the lanes, is the input's own
  // drop (a broadcast that is bad for every lane alike); the rest, a lane's own tags' (a blink
  // the broadcast closed, dropped), stays in that lane's count.
  struct Alike {
    size_t lanes = 0;
    DropReasons least;
  };
  std::map<std::pair<std::string_view, uint64_t>, Alike> alike;
  for (const LaneOutput& out : job.output)
    for (const auto& d : out.shared_drops) {
      Alike& a = alike[{d.estimator, d.ordinal}];
      a.least = a.lanes++ == 0 ? d.drops : DropReasons::min(a.least, d.drops);
    }
  for (const auto& [key, a] : alike) {
    if (a.lanes != lanes_.size()) continue;
    auto it = repeated_drops_.find(key.first);
    if (it == repeated_drops_.end()) it = repeated_drops_.emplace(key.first, DropReasons{}).first;
    for (size_t k = 1; k < lanes_.size(); ++k) it->second += a.least;
  }
}

void Replayer::finish() {
  if (single_) {
    single_->finish();
    return;
  }
  if (finished_) {
    rethrow_worker_error();  // a first finish() that threw does not end well the second time
    return;
  }
  finished_ = true;
  job_->finish = true;
  submit();
  {
    std::unique_lock<std::mutex> l(mutex_);
    cv_.wait(l, [this] { return merged_all_ || worker_failed_; });
  }
  rethrow_worker_error();
  caller_cpu_s_ = thread_cpu_s() - caller_cpu_start_s_;
}

Replayer::CpuTimes Replayer::cpu_times() const {
  CpuTimes t;
  for (const Lane& l : lanes_) t.lanes_s.push_back(l.cpu_s);
  t.caller_s = caller_cpu_s_;
  t.merging_s = merging_cpu_s_;
  return t;
}

void Replayer::rethrow_worker_error() {
  if (!worker_failed_) return;
  std::lock_guard<std::mutex> l(mutex_);
  if (worker_error_) std::rethrow_exception(worker_error_);
}

int Replayer::threads() const {
  if (single_) return opts_.threads >= 2 ? 2 : 1;
  return static_cast<int>(workers_.size()) + 2;  // the lanes', the caller's, the merging one
}

ReplayStats Replayer::stats() const {
  if (single_) return single_->stats();
  ReplayStats s = merger_->stats();
  s.events_in = events_in_;
  s.skipped_other_tags += skipped_;
  for (const Lane& l : lanes_) {
    s.undecodable += l.host->stats().undecodable;
    s.skipped_other_tags += l.host->stats().skipped_other_tags;
  }
  return s;
}

std::vector<EstimatorAccount> Replayer::accounts() const {
  if (single_) return single_->accounts();
  // Each estimator's account summed over the lanes; what a lane says in words, with its lane
  // when there are several.
  std::vector<EstimatorAccount> out;
  const auto join = [&](std::string& to, const std::string& text, size_t k) {
    if (text.empty()) return;
    if (!to.empty()) to += "; ";
    if (lanes_.size() > 1) to += "lane " + std::to_string(k + 1) + ": ";
    to += text;
  };
  for (size_t k = 0; k < lanes_.size(); ++k) {
    const auto lane = lanes_[k].host->accounts();
    if (out.empty()) {
      out.resize(lane.size());
      for (size_t i = 0; i < lane.size(); ++i) {
        out[i].name = lane[i].name;
        out[i].inputs = lane[i].inputs;
      }
    }
    for (size_t i = 0; i < lane.size(); ++i) {
      EstimatorAccount& a = out[i];
      const EstimatorAccount& b = lane[i];
      if (a.messages_in == 0 && b.messages_in > 0) a.inputs = b.inputs;  // a lane that had input
      // An input every lane took is counted once, as one host would count it.
      a.messages_in += k == 0 ? b.messages_in : b.messages_in - b.shared_in;
      if (k == 0) a.shared_in = b.shared_in;
      a.estimates_out += b.estimates_out;
      a.drops += b.drops;
      join(a.consistency, b.consistency, k);
      join(a.consistency_problems, b.consistency_problems, k);
      join(a.problems, b.problems, k);
      join(a.notes, b.notes, k);
    }
  }
  // An estimate a later lane repeated was written once, and is counted once.
  for (const auto& [channel, n] : repeated_by_channel_)
    for (auto& a : out)
      if (a.name == lanes_.front().host->producer_of(channel)) a.estimates_out -= n;
  for (auto& a : out) {
    const auto repeated = repeated_drops_.find(a.name);
    if (repeated != repeated_drops_.end()) a.drops -= repeated->second;
    describe_account(a, !opts_.only.empty(), merger_->has_site());
  }
  for (auto& a : merger_->accounts()) out.push_back(std::move(a));  // ips-zones
  return out;
}

std::string Replayer::nothing_estimated() const {
  if (single_) return single_->nothing_estimated();
  const auto all = hosted();
  return replay::nothing_estimated(accounts(), all.size() == 1 && all.front() == "zones");
}

const TagSelector& Replayer::tag_selector() const {
  return single_ ? single_->tag_selector() : selector_;
}

bool Replayer::has_site() const { return single_ ? single_->has_site() : merger_->has_site(); }

std::vector<std::string> Replayer::hosted() const {
  if (single_) return single_->hosted();
  auto names = lanes_.front().host->hosted();
  for (const auto& n : merger_->hosted()) names.push_back(n);
  return names;
}

}  // namespace ips::replay
