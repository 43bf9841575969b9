#pragma once
// Hosts every estimator in one process for deterministic replay: fed a log's events in file
// order, it passes the inputs through and adds every hosted estimator's output, stamped with the
// log time of the input that caused it. Pure: no file, clock or socket; the same events in give
// the same bytes out.
//
// With ReplayOptions::threads 2 it runs in two stages on two threads: the caller's thread
// decodes and runs the estimators that feed the fusion (uwb_twr ... altitude); the second runs
// ips-fuse and ips-zones and makes every call of the sink, in the order one thread makes them. The
// output is the same bytes either way: the second stage takes the first's work as a tape of
// operations (writes, and what to hand the fusion) and plays it in order.
#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "core/cli.hpp"
#include "core/drop_reasons.hpp"
#include "core/site.hpp"
#include "core/tag_selector.hpp"
#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/ins/ins_estimator.hpp"
#include "estimators/pdr/pdr_estimator.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "estimators/zones/zone_monitor.hpp"
#include "fusion/fuse_estimator.hpp"

namespace ips::replay {

struct ReplayOptions {
  std::set<std::string> only;        // estimator names to host; empty: all
  bool keep_regenerated = false;     // keep input events on channels the hosted estimators produce
  std::string site_path;             // use this site file instead of the log's SITE messages
  std::shared_ptr<const Site> site;  // or this site (before site_path), e.g. a sweep's
  // The poses ips-zones watches (its --pose-channel): from the hosted estimator that produces
  // them, else from the log (TRUTH, or POSE_FUSED with `fuse` not hosted).
  std::string zones_pose_channel = "POSE_FUSED";
  // 1: everything on the caller's thread; 2: ips-fuse, ips-zones and the sink on a second thread
  // (the same output). More is taken as 2.
  int threads = 1;
  // --tags and --shard (core/tag_selector.hpp): the hosted estimators take only these tags'
  // messages, as live instances of a partitioned site do; the others are still passed through
  // to the output and counted in ReplayStats::skipped_other_tags. Empty: every tag.
  std::string tags;
  std::string shard;
  // --lanes L (loggers/replay/replayer.hpp): the tags split into L lanes by their shard among L
  // (core/tag_selector.hpp), each lane with its own instance of every estimator but ips-zones, as
  // L shards of a live site have; `threads` run the lanes side by side. The output depends on L,
  // never on the threads. 0: no lanes, one instance of each estimator.
  int lanes = 0;
  // For the hosts of a replay in lanes: a lane writes only its estimates (no inputs); `except`
  // names estimators not hosted (after `only`); `produced_elsewhere` names channels that other
  // hosts (the lanes) regenerate, whose log events this host drops as its own.
  bool pass_through = true;
  std::set<std::string> except;
  std::set<std::string> produced_elsewhere;
};

struct ReplayStats {
  int64_t events_in = 0;
  int64_t passed_through = 0;
  int64_t dropped_regenerated = 0;  // input events on channels the estimators regenerate
  int64_t estimates_out = 0;
  int64_t undecodable = 0;          // on an estimator's input channel but not its type
  int64_t bad_sites = 0;
  int64_t skipped_other_tags = 0;  // messages of tags outside --tags / --shard, not estimated
};

// One hosted estimator's account of a replay: what went in, what came out, and why inputs gave no
// estimate.
struct EstimatorAccount {
  std::string name;           // "aoa"
  std::string inputs;         // the channels it reads: "BLE_AOA"
  int64_t messages_in = 0;    // messages handed to it
  int64_t shared_in = 0;      // of them, those its host shared with other hosts (set_shared_input)
  int64_t estimates_out = 0;  // messages it produced (POSE_*, STEP, CLOCK, ALTITUDE)
  DropReasons drops;
  // "aoa: 7949 BLE_AOA in, 0 estimates out: 7949 no site (the log has no SITE: give --site
  // FILE)"; `silent` when it had input and gave nothing: then the line says why (its three
  // largest reasons).
  std::string line;
  bool silent = false;
  // Silent for a fault (no site, no anchors of its kind, invalid input, ...), or silent though
  // asked for by name (--only): worth a warning. An estimator hosted by default that only waited
  // (an INS that never saw a foot at rest in a hand-held phone's IMU) is not.
  bool warn = false;
  // Its innovations against the noise it assumes over the run (core/consistency.hpp
  // run_summary()), and the channels out of line at the end in words; "" when not checked.
  std::string consistency;
  std::string consistency_problems;
  // What kept it from estimating, in its own words at the end (the estimator's problems():
  // ips-pdr "no gyroscope on P1: ...", ips-ins "T1: no stance phase ..."); "" when none.
  std::string problems;
  // Its own account of the run (the estimator's run_notes(): ips-pdr's steps and magnetometer
  // updates, ips-altitude's detected changes of height); "" when it has none.
  std::string notes;
};

// An account's `line`, `silent` and `warn` from its name, inputs, counts and drops (`only_given`:
// the estimators were named with --only; `site_applied`: the replay had a site).
void describe_account(EstimatorAccount& a, bool only_given, bool site_applied);
// ReplayHost::nothing_estimated() of these accounts (`zones_alone`: ips-zones is the only one).
std::string nothing_estimated(const std::vector<EstimatorAccount>& accounts, bool zones_alone);

class ReplayHost {
 public:
  using Sink = std::function<void(const std::string& channel, int64_t timestamp,
                                  const uint8_t* data, size_t size)>;
  // Throws ConfigError for an unknown estimator in opts.only or a bad opts.site_path.
  ReplayHost(const ReplayOptions& opts, const CommonOptions& channels, Sink sink);

  ~ReplayHost();
  ReplayHost(const ReplayHost&) = delete;
  ReplayHost& operator=(const ReplayHost&) = delete;

  // One log event (channel, log timestamp, payload). stable: the payload stays valid until
  // finish() (a mapped log), so the second stage may read it where it is, uncopied. The sink
  // may be called later, from the second stage's thread, with threads 2; an exception there is
  // thrown here (or by finish()).
  void process(const std::string& channel, int64_t timestamp, const uint8_t* data, size_t size,
               bool stable = false);
  // An estimate made by another host (a lane) for the input of `timestamp`: written as this
  // host's own, and heard by its ips-zones as it would hear its own estimators'.
  void estimate(const std::string& channel, int64_t timestamp, const uint8_t* data, size_t size);
  // At the end of the log: estimators that hold inputs back (the TDoA estimator waits for a
  // blink's last report, the AoA estimator for an epoch's window to pass, the altitude estimator
  // for the reference's next reading) emit what they hold, stamped with the last event's time;
  // the fusion gets it as it would live. Returns when the sink has had everything. A lane, which
  // sees only its own events, is given the log's last time as `end_timestamp`.
  void finish(std::optional<int64_t> end_timestamp = std::nullopt);

  const ReplayStats& stats() const { return stats_; }
  // Per hosted estimator, in the order of available().
  std::vector<EstimatorAccount> accounts() const;
  // Why the replay estimated nothing, in one line: the log holds input for no hosted estimator,
  // or none of them gave an estimate. "" when one did.
  std::string nothing_estimated() const;
  // The channels the hosted estimators regenerate.
  const std::set<std::string>& produced_channels() const { return produced_channels_; }
  // The tags the hosted estimators take (--tags, --shard).
  const TagSelector& tag_selector() const { return tags_; }
  // A site came from --site or a SITE message of the log.
  bool has_site() const { return site_applied_; }
  // The input a channel's events are to the hosted estimators, as process() takes them: kOther
  // when none of them reads the channel. The kFuse* inputs are ips-fuse's, read from the log
  // (feed_fuse_from_log) when no hosted estimator regenerates them. The tag of an event is its
  // message's tag_id, but a kUwbRx event's sender_id, a kImu event's device_id and a kBaro
  // event's sensor_id; a sync master's kUwbRx and a reference kBaro serve every tag. Depends
  // only on what the constructor set, so any thread may ask.
  enum class Input : uint8_t {
    kOther,
    kSite,
    kUwbRange,
    kUwbRx,
    kUwbTdoa,
    kBleAoa,
    kImu,
    kBaro,
    kFusePose,     // pose_t: INS_MODULE, POSE_INS, POSE_TDOA, POSE_AOA
    kFuseStep,     // step_t
    kFuseAltitude  // altitude_t
  };
  Input input_of(const std::string& channel) const;
  // The hosted estimator that writes a channel ("uwb_tdoa" for CLOCK), or "" for none.
  std::string producer_of(const std::string& channel) const {
    const auto it = producers_.find(channel);
    return it == producers_.end() ? std::string() : it->second;
  }
  // The inputs process() is given from now on are given to other hosts as well (a lane's: a
  // message every lane takes): the accounts count them in EstimatorAccount::shared_in too.
  void set_shared_input(bool shared) { shared_input_ = shared; }
  // What a hosted estimator dropped while it took a shared input: the `ordinal`-th shared input
  // its stage was given (the same input in every host given the same shared inputs), when the
  // estimator's drops grew. Every lane drops a bad broadcast alike; the Replayer counts such a
  // drop once. Both stages record them, so shared inputs are for a host on one thread (a lane's:
  // ReplayOptions::threads 1), as the Replayer makes its lanes.
  struct SharedDrops {
    uint64_t ordinal;
    const char* estimator;  // its name, as in accounts()
    DropReasons drops;      // those made while it took the input
  };
  // Appends those recorded since the last call to `into`.
  void take_shared_drops(std::vector<SharedDrops>& into) {
    into.insert(into.end(), shared_drops_.begin(), shared_drops_.end());
    shared_drops_.clear();
  }
  // Names of the estimators hosted, and of every estimator that can be.
  std::vector<std::string> hosted() const;
  static std::vector<std::string> available();

 private:
  // Encodes and writes an estimate to the sink.
  template <class Msg>
  void write(const std::string& channel, const Msg& msg);
  // An estimate of a hosted estimator: written, then handed to the hosted fusion when it is one
  // of its inputs, since the log's events on that channel are not (they are regenerated).
  template <class Msg>
  void emit(const std::string& channel, const Msg& msg);
  void feed_fuse(const std::string& channel, const pose_t& m);
  void feed_fuse(const std::string& channel, const step_t& m);
  void feed_fuse(const std::string& channel, const altitude_t& m);
  void feed_fuse(const std::string&, const clock_t&) {}
  // A log event on one of the fusion's inputs that no hosted estimator produces.
  void feed_fuse_from_log(const std::string& channel, const uint8_t* data, size_t size);
  void apply_site(const Site& site);
  // Whether a message of this tag is for the hosted estimators (--tags, --shard); false counts
  // it. One selector per stage: each remembers its decisions.
  bool take(const std::string& id) { return take(tags_, id, stats_.skipped_other_tags); }
  bool stage_take(const std::string& id) { return take(stage_tags_, id, stage_skipped_); }
  static bool take(TagSelector& sel, const std::string& id, int64_t& skipped) {
    if (sel.selects_all() || sel.selects(id)) return true;
    ++skipped;
    return false;
  }
  // A log event for the hosted ips-zones: its poses, ALTITUDE, HEALTH.
  void feed_zones_from_log(const std::string& channel, const uint8_t* data, size_t size);

  // ---- The second stage: ips-fuse, ips-zones and every sink call, as a tape of operations ----
  enum class Op : uint8_t {
    kWrite,         // bytes to the sink (an input passed through)
    kEstimate,      // an estimate that only goes to the sink (CLOCK)
    kEmitPose,      // an estimate of a hosted estimator: written, then to the fusion (feed_fuse)
    kEmitStep,
    kEmitAltitude,
    kFuseRange,     // a log event for the fusion: UWB_RANGE
    kFuseRx,        // UWB_RX
    kFusePair,      // UWB_TDOA
    kFuseAoa,       // BLE_AOA
    kFuseImu,       // IMU
    kFuseFromLog,   // any other of its inputs (feed_fuse_from_log)
    kZonesFromLog,  // feed_zones_from_log
    kSite,          // apply the site (sites_[index]) to ips-fuse and ips-zones
    kFinish,        // ips-fuse's flush at the end
  };
  struct Step {
    Op op;
    uint32_t channel;     // index into channel_names_
    int64_t timestamp;    // the log time of the input that caused it
    const uint8_t* data;  // stable bytes, or null: then at `offset` in the batch's bytes
    size_t offset, size;
    bool shared = false;  // its input was given to other hosts as well (set_shared_input)
  };
  struct Batch {
    std::vector<Step> steps;
    std::vector<uint8_t> bytes;
  };
  uint32_t intern(const std::string& channel);
  // Hands a step to the second stage: run now (one thread), or taped (two).
  void post(Op op, uint32_t channel, const uint8_t* data, size_t size, bool stable);
  void post(Op op, const std::string& channel, const uint8_t* data, size_t size, bool stable) {
    post(op, intern(channel), data, size, stable);
  }
  // What the host does with a channel's log events, worked out once per channel name.
  struct ChannelInfo {
    uint32_t id = 0;  // interned
    Input input = Input::kOther;
    bool produced = false;  // a hosted estimator regenerates it
    bool to_zones = false;  // the hosted ips-zones reads it from the log
  };
  const ChannelInfo& classify(const std::string& channel);
  std::unordered_map<std::string, ChannelInfo> channel_info_;
  void run(const Step& s, const uint8_t* data);
  void run_batch(const Batch& b);
  void submit();  // the current batch to the second thread
  void worker();
  void rethrow_worker_error();
  // Emits an estimate of a first-stage estimator (encoded, then posted as `op`).
  template <class Msg>
  void emit_encoded(Op op, const std::string& channel, const Msg& msg);
  template <class Msg>
  void zones_hear(const std::string& channel, const Msg& msg);

  std::vector<uint8_t> stage_buffer_;  // the second stage's encoding buffer
  std::vector<std::string> channel_names_;
  std::unordered_map<std::string, uint32_t> channel_index_;
  std::vector<std::unique_ptr<Site>> sites_;
  int64_t stage_timestamp_ = 0;    // the second stage's now: the step it runs
  int64_t stage_undecodable_ = 0;  // decoding failures in the second stage
  int64_t stage_skipped_ = 0;      // messages of other tags in the second stage
  TagSelector tags_;                // the first stage's
  TagSelector stage_tags_;          // the second stage's
  bool threaded_ = false;
  Batch batch_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Batch> queue_;   // submitted, not yet run
  std::vector<Batch> spare_;  // run, to fill again
  bool stop_ = false;
  bool busy_ = false;  // the worker runs a batch
  std::exception_ptr worker_error_;
  std::atomic<bool> worker_failed_{false};

  // Messages in and estimates out per estimator, in the order of available().
  enum Hosted { kTwrIndex, kTdoaIndex, kAoaIndex, kPdrIndex, kInsIndex, kAltitudeIndex, kFuseIndex,
                kZonesIndex, kNumHosted };
  struct Counts {
    int64_t in = 0;
    int64_t out = 0;
    int64_t shared_in = 0;  // of `in`, inputs given to other hosts as well
  };
  void count_in(Hosted index, bool shared) {
    ++counts_[index].in;
    if (shared) ++counts_[index].shared_in;
  }
  void produce(const char* estimator, const std::string& channel) {
    produced_channels_.insert(channel);
    producers_.emplace(channel, estimator);
  }
  bool shared_input_ = false;  // set_shared_input(): the first stage's
  bool stage_shared_ = false;  // the step the second stage runs: its input was shared
  uint64_t shared_inputs_ = 0, stage_shared_inputs_ = 0;  // taken by each stage so far
  std::vector<SharedDrops> shared_drops_;
  // Runs `take` (hands an input to `est`); when the input is shared, records what `est` dropped
  // meanwhile as the `ordinal`-th shared input's.
  template <class Est, class Take>
  void take_shared(bool shared, uint64_t ordinal, const char* name, const Est& est, Take&& take) {
    if (!shared) {
      take();
      return;
    }
    const DropReasons before = est.drop_reasons();
    take();
    DropReasons grew = est.drop_reasons();
    grew -= before;
    if (grew.total() != 0) shared_drops_.push_back(SharedDrops{ordinal, name, grew});
  }
  std::map<std::string, std::string> producers_;  // produced channel -> the hosted estimator
  std::array<Counts, kNumHosted> counts_{};
  bool site_applied_ = false;
  CommonOptions channels_;
  Sink sink_;
  ReplayOptions opts_;
  ReplayStats stats_;
  std::set<std::string> produced_channels_;
  std::set<std::string> fuse_log_channels_;  // the fusion's inputs feed_fuse_from_log takes
  int64_t now_timestamp_ = 0;
  std::vector<uint8_t> buffer_;
  std::string last_site_yaml_;
  std::unique_ptr<uwb_twr::TwrEstimator> twr_;
  std::unique_ptr<uwb_tdoa::TdoaEstimator> tdoa_;
  std::unique_ptr<aoa::AoaEstimator> aoa_;
  std::unique_ptr<pdr::PdrEstimator> pdr_;
  std::unique_ptr<ins::InsEstimator> ins_;
  std::unique_ptr<altitude::AltitudeEstimator> altitude_;
  std::unique_ptr<fusion::FuseEstimator> fuse_;
  std::unique_ptr<zones::ZoneMonitor> zones_;
};

}  // namespace ips::replay
