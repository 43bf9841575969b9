#pragma once
// A replay as ips-replay runs it: one ReplayHost, or, with ReplayOptions::lanes L, the tags split
// into L lanes that run side by side.
//
// Lanes. A lane is a ReplayHost with its own instance of every hosted estimator but ips-zones,
// taking the tags whose shard among L is its own (--shard K/L: core/tag_selector.hpp), as L shards
// of a live site do (within --shard K/N, the hash over N first: the tags of shard K spread over
// the lanes). A dispatcher (the caller's thread) reads each event's tag once and hands it to its
// lane only; what serves every tag (a site, a sync master's broadcast, a reference station's
// reading, an anchor's or a station's own message) goes to every lane. `threads` workers (at most
// L) run the lanes, each a fixed set of them, over batches of events. A merging thread takes the
// batches in log order and writes each input (or drops it, when the lanes regenerate its
// channel), then the estimates it caused in lane order, through one more ReplayHost that hosts
// ips-zones (it sees every tag's poses) and makes every call of the sink. So the output depends on
// L and never on the threads: `--lanes 8 --jobs 1` and `--lanes 8 --jobs 2` give the same bytes.
//
// What lanes change: the estimates are those of L shards, not of one instance. Whatever one
// estimator learns across tags (each BLE anchor's angle noise, the TDoA anchors' clocks) each
// lane learns from its own tags, and blinks and epochs close at other events (docs/
// development.md "Tags in lanes"). Range noise is learned per link: the same in lanes.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "loggers/replay/replay_host.hpp"

namespace ips::replay {

class Replayer {
 public:
  // Throws ConfigError as ReplayHost does, and for lanes outside 0 (none) to kMaxShards.
  Replayer(const ReplayOptions& opts, const CommonOptions& channels, ReplayHost::Sink sink);
  ~Replayer();
  Replayer(const Replayer&) = delete;
  Replayer& operator=(const Replayer&) = delete;

  // As ReplayHost::process. With lanes, an event whose bytes are not stable is copied.
  void process(const std::string& channel, int64_t timestamp, const uint8_t* data, size_t size,
               bool stable = false);
  void finish();

  // After finish(): with lanes, the lanes' counters are added.
  ReplayStats stats() const;
  std::vector<EstimatorAccount> accounts() const;
  std::string nothing_estimated() const;
  const TagSelector& tag_selector() const;
  bool has_site() const;
  std::vector<std::string> hosted() const;
  int lanes() const { return static_cast<int>(lanes_.size()); }
  // The lane (0-based) of a tag among `lanes`, the tags sharded N ways (--shard K/N; 0: not).
  static int lane_of_tag(std::string_view id, int lanes, int shards);
  // Estimates that a lane made with the same bytes as an earlier lane for the same event and
  // channel (an anchor's CLOCK), written once.
  int64_t repeated_estimates() const { return repeated_; }
  // ... per channel ("CLOCK" 1673).
  const std::map<std::string, int64_t>& repeated_by_channel() const { return repeated_by_channel_; }
  // The threads the replay runs on (the caller's included).
  int threads() const;
  // With lanes, after finish(): the CPU each lane took (on whichever worker), the caller's thread
  // (reading, dispatching) and the merging one's (merging, ips-zones, the sink), in seconds. What
  // the lanes would take on more cores follows from them.
  struct CpuTimes {
    std::vector<double> lanes_s;
    double caller_s = 0.0, merging_s = 0.0;
  };
  CpuTimes cpu_times() const;

 private:
  static constexpr int32_t kToNoLane = -2;
  static constexpr int32_t kToEveryLane = -1;
  struct Event {
    const std::string* channel;
    int64_t timestamp;
    const uint8_t* data;  // null until submitted when copied: then at `offset` in the job's bytes
    size_t offset, size;
    int32_t lane;  // a lane's index, kToEveryLane or kToNoLane
    bool copied;   // into the job's bytes, which go when the job is merged
  };
  struct Estimate {
    uint32_t event;  // the index in its job of the event that caused it; the job's size: finish()
    const std::string* channel;
    int64_t timestamp;
    size_t offset, size;
  };
  struct LaneOutput {
    std::vector<Estimate> estimates;
    std::vector<uint8_t> bytes;
    // What its estimators dropped of shared inputs (ReplayHost::take_shared_drops).
    std::vector<ReplayHost::SharedDrops> shared_drops;
  };
  struct Job {
    std::vector<Event> events;
    std::vector<uint8_t> bytes;                      // copies of unstable events
    std::vector<std::vector<uint32_t>> lane_events;  // per lane, the indices of its events
    std::vector<LaneOutput> output;                  // per lane
    bool finish = false;                             // the lanes' finish() after the events
    int pending = 0;                                 // workers yet to run it
  };
  struct Lane {
    std::unique_ptr<ReplayHost> host;
    std::unordered_set<std::string> channels;  // the names its estimates were written on
    LaneOutput* output = nullptr;              // the job it runs
    uint32_t event = 0;                        // ... and the event in it
    double cpu_s = 0.0;                        // its worker's CPU time while running it
  };
  // The lane of an event (kToEveryLane, kToNoLane), from its input to the lanes' hosts.
  using Input = ReplayHost::Input;
  int32_t lane_of(Input input, const uint8_t* data, size_t size);
  int32_t lane_of_id(const std::string& id);
  void submit();
  void worker(size_t index);
  void run(Job& job, size_t worker_index);
  void merge(Job& job);
  void count_repeated_drops(const Job& job);  // into repeated_drops_ (the merging thread)
  void stop_threads();  // stops and joins every thread started
  void merging();       // the merging thread: each job, in order, once every worker has run it
  void record_error();  // the current exception, from a worker or the merging thread
  void rethrow_worker_error();
  std::unique_ptr<Job> take_spare_job();  // a merged job, emptied, or a new one (under mutex_)

  ReplayOptions opts_;
  CommonOptions channels_;
  std::unique_ptr<ReplayHost> single_;  // no lanes
  std::vector<Lane> lanes_;
  std::unique_ptr<ReplayHost> merger_;             // ips-zones and the sink, behind the lanes
  std::unordered_map<std::string, Input> routes_;  // keys' addresses are stable: Event::channel
  TagSelector selector_;                           // --tags, --shard
  std::unordered_set<std::string> non_tags_;       // the site's anchors and stations
  std::string last_site_yaml_;
  int64_t events_in_ = 0, skipped_ = 0, end_timestamp_ = 0;
  // Estimates a later lane repeated byte for byte, written once: in all and per channel.
  int64_t repeated_ = 0;
  std::map<std::string, int64_t> repeated_by_channel_;
  // Per estimator, the drops that lanes after the first made alike for a shared input (a bad
  // broadcast): the input's own drop, counted once.
  std::map<std::string, DropReasons, std::less<>> repeated_drops_;
  double caller_cpu_start_s_ = 0.0, caller_cpu_s_ = 0.0, merging_cpu_s_ = 0.0;
  std::unique_ptr<Job> job_;

  std::vector<std::thread> workers_;
  std::thread merging_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::unique_ptr<Job>> in_flight_;  // submitted, oldest first
  uint64_t submitted_ = 0, retired_ = 0;
  bool stop_ = false;
  bool finished_ = false;
  bool merged_all_ = false;  // the merging thread merged the last job
  std::exception_ptr worker_error_;
  std::atomic<bool> worker_failed_{false};
  std::vector<std::unique_ptr<Job>> spare_jobs_;  // merged, to fill again
  struct Placed {  // an estimate of a job: its event, lane and index in the lane's list
    uint32_t event, lane, index;
  };
  std::vector<Placed> merge_order_;  // the merging thread's
};

}  // namespace ips::replay
