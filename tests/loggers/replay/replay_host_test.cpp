// The replay host: inputs pass through, estimates follow the input that caused them, regenerated
// channels are dropped unless kept, and the same events give the same bytes.
#include "loggers/replay/replay_host.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <functional>
#include <ips/altitude_t.hpp>
#include <ips/baro_t.hpp>
#include <ips/ble_aoa_t.hpp>
#include <ips/clock_t.hpp>
#include <ips/imu_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/site_t.hpp>
#include <ips/step_t.hpp>
#include <ips/uwb_range_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <ips/zone_event_t.hpp>
#include <map>
#include <set>
#include <stdexcept>

#include "core/site.hpp"
#include "drivers/sim/simulator.hpp"
#include "loggers/replay/replayer.hpp"

namespace ips::replay {
namespace {

struct Out {
  std::string channel;
  int64_t timestamp;
  std::vector<uint8_t> data;
  bool operator==(const Out&) const = default;
};

// Replays a simulated scenario, with extra_inputs (in time order) before the simulated events of
// the same or a later time.
// `inspect` sees the host after finish().
std::vector<Out> replay(const ReplayOptions& ro, double duration_s = 20,
                        const std::vector<Out>& extra_inputs = {},
                        const std::string& scenario = "lab",
                        const std::function<void(const Replayer&)>& inspect = {}, int walkers = 1) {
  sim::Scenario sc = sim::load_scenario(scenario);
  sc.duration_s = duration_s;
  sim::replicate_walkers(sc, walkers);
  sim::Simulator sim(sc, 1, 1767225600000000);
  std::vector<Out> out;
  Replayer host(ro, CommonOptions{},
                [&](const std::string& ch, int64_t ts, const uint8_t* d, size_t n) {
                  out.push_back({ch, ts, {d, d + n}});
                });
  auto extra = extra_inputs.begin();
  auto process_extra_until = [&](int64_t t) {
    for (; extra != extra_inputs.end() && extra->timestamp <= t; ++extra)
      host.process(extra->channel, extra->timestamp, extra->data.data(), extra->data.size());
  };
  sim::SimEvent e;
  while (sim.next(e)) {
    process_extra_until(e.utime);
    host.process(e.kind, e.utime, e.data.data(), e.data.size());
  }
  process_extra_until(INT64_MAX);
  host.finish();
  if (inspect) inspect(host);
  return out;
}

TEST(ReplayHost, InputsPassThroughAndEstimatesFollowTheirInput) {
  auto out = replay({});
  int poses = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "POSE_UWB") continue;
    ++poses;
    ASSERT_GT(i, 0u);
    EXPECT_EQ(out[i - 1].channel, "UWB_RANGE");  // the range that produced it, just before
    EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
    pose_t p;
    ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    EXPECT_EQ(p.source, "uwb_twr");
  }
  EXPECT_NEAR(poses, 200, 2);  // 10 Hz for 20 s
}

// --jobs 2: ips-fuse, ips-zones and the sink on a second thread give the same calls of the sink,
// in the same order, as one thread does; with every estimator, and with the fusion alone.
TEST(ReplayHost, TwoThreadsGiveTheSameOutputAsOne) {
  for (const std::set<std::string>& only :
       {std::set<std::string>{}, std::set<std::string>{"fuse", "zones"}}) {
    ReplayOptions one;
    one.only = only;
    ReplayOptions two = one;
    two.threads = 2;
    int64_t estimates_one = 0, estimates_two = 0;
    const auto a = replay(one, 30, {}, "lab",
                          [&](const Replayer& h) { estimates_one = h.stats().estimates_out; });
    const auto b = replay(two, 30, {}, "lab",
                          [&](const Replayer& h) { estimates_two = h.stats().estimates_out; });
    ASSERT_GT(estimates_one, 300) << only.size();
    EXPECT_EQ(estimates_one, estimates_two) << only.size();
    ASSERT_EQ(a.size(), b.size()) << only.size();
    EXPECT_TRUE(a == b) << only.size();
  }
}

// --shard K/N (and --tags): the hosted estimators take only their tags' messages, as live
// shards do; every input is still passed through. Three shards of a 6-tag lab estimate disjoint
// sets of tags whose union is every tag, each tag with as many fused and UWB poses as in the
// whole replay (within one), and each shard counts the messages of the others' tags it skipped.
TEST(ReplayHost, ShardsSplitTheTagsAndTogetherEstimateEveryOne) {
  const auto poses_by_tag = [](const std::vector<Out>& out) {
    std::map<std::string, std::map<std::string, int>> n;  // channel -> tag -> poses
    for (const auto& o : out) {
      if (o.channel != "POSE_FUSED" && o.channel != "POSE_UWB") continue;
      pose_t p;
      EXPECT_GT(p.decode(o.data.data(), 0, static_cast<int>(o.data.size())), 0);
      ++n[o.channel][p.tag_id];
    }
    return n;
  };
  int64_t inputs_whole = 0;
  const auto whole = poses_by_tag(replay(
      {}, 20, {}, "lab", [&](const Replayer& h) { inputs_whole = h.stats().passed_through; }, 6));
  ASSERT_EQ(whole.at("POSE_FUSED").size(), 6u);
  std::map<std::string, std::map<std::string, int>> joined;
  int64_t skipped = 0;
  for (int k = 1; k <= 3; ++k) {
    ReplayOptions ro;
    ro.shard = std::to_string(k) + "/3";
    int64_t passed = 0;
    const auto part = poses_by_tag(replay(
        ro, 20, {}, "lab",
        [&](const Replayer& h) {
          passed = h.stats().passed_through;
          skipped += h.stats().skipped_other_tags;
        },
        6));
    EXPECT_EQ(passed, inputs_whole) << ro.shard;  // every input still passed through
    for (const auto& [channel, tags] : part)
      for (const auto& [tag, n] : tags) {
        EXPECT_EQ(shard_of(tag, 3), k) << tag;
        EXPECT_FALSE(joined[channel].count(tag)) << tag << " on two shards";
        joined[channel][tag] = n;
      }
  }
  // The same tags on each channel, and as many poses within one: the fusion learns each anchor's
  // noise from all the tags it hears (core/consistency.hpp), so a shard's differs a little and a
  // pose can fall either side of the publish period (tests/integration/shards_live_netns.sh).
  for (const auto& [channel, tags] : whole) {
    ASSERT_EQ(joined[channel].size(), tags.size()) << channel;
    for (const auto& [tag, n] : tags) EXPECT_NEAR(joined[channel][tag], n, 1) << channel << " " << tag;
  }
  EXPECT_GT(skipped, inputs_whole);  // each tag's messages skipped by the two other shards
  // --tags: one tag by name, one by a glob.
  ReplayOptions ro;
  ro.tags = "T1,T1-5*";
  const auto some = poses_by_tag(replay(ro, 20, {}, "lab", {}, 6));
  EXPECT_EQ(some.at("POSE_FUSED").size(), 2u);
  EXPECT_EQ(some.at("POSE_FUSED").at("T1"), whole.at("POSE_FUSED").at("T1"));
  EXPECT_TRUE(some.at("POSE_FUSED").count("T1-5"));
  ro.tags = "";
  ro.shard = "4/3";
  EXPECT_THROW(replay(ro, 1), ConfigError);
}

// Replayer with --lanes L (loggers/replay/replayer.hpp). The events' bytes are not stable here
// (the simulator reuses its buffer), so the replayer copies them.
namespace {
// The estimates on POSE_* channels, per channel and tag, in order.
std::map<std::pair<std::string, std::string>, std::vector<Out>> poses_by_tag(
    const std::vector<Out>& out) {
  std::map<std::pair<std::string, std::string>, std::vector<Out>> n;
  for (const auto& o : out) {
    if (o.channel.rfind("POSE_", 0) != 0) continue;
    pose_t p;
    EXPECT_GT(p.decode(o.data.data(), 0, static_cast<int>(o.data.size())), 0);
    n[{o.channel, p.tag_id}].push_back(o);
  }
  return n;
}
std::map<std::string, int> events_by_channel(const std::vector<Out>& out) {
  std::map<std::string, int> n;
  for (const auto& o : out) ++n[o.channel];
  return n;
}
}  // namespace

// The output depends on the lanes, never on the threads that run them.
TEST(Replayer, LanesGiveTheSameBytesOnAnyNumberOfThreads) {
  ReplayOptions ro;
  ro.lanes = 4;
  int64_t estimates = 0;
  const auto one = replay(
      ro, 12, {}, "lab",
      [&](const Replayer& h) {
        estimates = h.stats().estimates_out;
        EXPECT_EQ(h.threads(), 3);  // one lane worker, the caller's, the merging one
        EXPECT_EQ(h.lanes(), 4);
      },
      6);
  ASSERT_GT(estimates, 3000);
  for (int threads : {2, 3, 8}) {
    ro.threads = threads;
    const auto other = replay(
        ro, 12, {}, "lab",
        [&](const Replayer& h) { EXPECT_EQ(h.threads(), std::min(threads, 4) + 2); }, 6);
    ASSERT_EQ(other.size(), one.size()) << threads;
    EXPECT_TRUE(other == one) << threads;
  }
}

// Replays `walkers` tags of the lab in `lanes` lanes on two threads and without lanes; expects
// the same bytes. Returns the replay without lanes; `repeated`: estimates written once.
std::vector<Out> expect_lanes_are_one_instance(int lanes, int walkers, int64_t& repeated,
                                               const std::set<std::string>& only = {}) {
  ReplayOptions ro;
  ro.lanes = lanes;
  ro.threads = 2;
  ro.only = only;
  ReplayOptions one;
  one.only = only;
  const auto whole = replay(one, 20, {}, "lab", {}, walkers);
  const auto laned = replay(
      ro, 20, {}, "lab", [&](const Replayer& h) { repeated = h.repeated_estimates(); }, walkers);
  EXPECT_EQ(laned.size(), whole.size());
  EXPECT_TRUE(laned == whole);
  return whole;
}

// Several tags in lanes: the estimators whose tags share nothing that changes an estimate give
// one instance's bytes. ips-uwb-twr learns each range's noise per link (tag, anchor), so a tag's
// ranges are weighed by its own innovations only; ips-pdr and ips-ins keep nothing across tags.
// (The others still differ in lanes: docs/development.md, "Tags in lanes".)
TEST(Replayer, TagsInLanesAreOneInstanceWhereNothingIsShared) {
  int64_t repeated = 0;
  const auto n =
      events_by_channel(expect_lanes_are_one_instance(4, 6, repeated, {"uwb_twr", "pdr", "ins"}));
  EXPECT_GT(n.count("POSE_UWB") ? n.at("POSE_UWB") : 0, 1000);
  for (const char* estimate : {"POSE_PDR", "STEP"})
    EXPECT_GT(n.count(estimate) ? n.at(estimate) : 0, 50) << estimate;
}

// A LAN repeats datagrams now and then (the soak's switch 0.5 % of them). Every estimator knows a
// copy (a range, a reception, an angle, an IMU sample, a reading: counted as a duplicate) and
// makes from a log with copies the estimates, byte for byte, of the log without. Here every 7th
// message of a 2-tag lab comes twice.
TEST(ReplayHost, ALansCopiesChangeNoEstimate) {
  const auto run = [](int copy_every, int64_t& duplicates) {
    sim::Scenario sc = sim::load_scenario("lab");
    sc.duration_s = 30;
    sim::replicate_walkers(sc, 2);
    sim::Simulator sim(sc, 1, 1767225600000000);
    std::vector<Out> estimates;
    std::set<std::string> inputs;
    Replayer host(ReplayOptions{}, CommonOptions{},
                  [&](const std::string& ch, int64_t ts, const uint8_t* d, size_t n) {
                    if (!inputs.count(ch)) estimates.push_back({ch, ts, {d, d + n}});
                  });
    sim::SimEvent e;
    for (int k = 1; sim.next(e); ++k) {
      inputs.insert(e.kind);
      host.process(e.kind, e.utime, e.data.data(), e.data.size());
      if (copy_every > 0 && k % copy_every == 0)
        host.process(e.kind, e.utime, e.data.data(), e.data.size());
    }
    host.finish();
    duplicates = 0;
    for (const auto& a : host.accounts()) duplicates += a.drops.count(DropReason::kDuplicate);
    return estimates;
  };
  int64_t dup_plain = 0, dup_copied = 0;
  const auto plain = run(0, dup_plain);
  const auto copied = run(7, dup_copied);
  const auto n = events_by_channel(plain);
  for (const char* estimate :
       {"POSE_UWB", "POSE_TDOA", "POSE_AOA", "POSE_PDR", "ALTITUDE", "POSE_FUSED"})
    EXPECT_GT(n.count(estimate) ? n.at(estimate) : 0, 50) << estimate;
  EXPECT_GT(dup_copied, dup_plain + 1000);
  ASSERT_EQ(copied.size(), plain.size());
  for (size_t k = 0; k < plain.size(); ++k)
    ASSERT_TRUE(copied[k] == plain[k]) << k << " " << plain[k].channel;
}

// One lane is the replay without lanes, byte for byte: the merge puts every input and estimate
// where one host does, and ips-zones (behind the lanes) hears the poses in the same order.
TEST(Replayer, OneLaneIsTheWholeReplay) {
  int64_t repeated = 0;
  const auto whole = expect_lanes_are_one_instance(1, 3, repeated);
  EXPECT_GT(events_by_channel(whole).at("ZONE_EVENT"), 0);
  EXPECT_EQ(repeated, 0);
}

// One tag in several lanes (a recording of one tag, as every real one of docs/real-data.md): its
// lane is one instance, the others hear only what serves every tag (the sync master, the
// reference barometer) and write nothing twice, so the bytes are one instance's.
TEST(Replayer, OneTagInSeveralLanesIsOneInstance) {
  int64_t repeated = 0;
  const auto n = events_by_channel(expect_lanes_are_one_instance(4, 1, repeated));
  EXPECT_GT(repeated, 0);  // the other lanes' CLOCK, written once
  for (const char* estimate : {"POSE_UWB", "POSE_TDOA", "POSE_AOA", "ALTITUDE", "POSE_FUSED"})
    EXPECT_GT(n.count(estimate) ? n.at(estimate) : 0, 100) << estimate;
}

// With L lanes each tag's estimates are, byte for byte, those of the replay of its shard alone
// (--shard K/L): a lane is a shard. Every input is written once, an anchor's CLOCK that every
// lane makes the same is written once, and the accounts count each input as one host does (an
// anchor's range, which every lane takes, once) and each estimate as written.
TEST(Replayer, EachTagIsEstimatedAsByTheShardOfItsLane) {
  constexpr int kLanes = 3;
  ReplayOptions ro;
  ro.lanes = kLanes;
  ro.threads = 2;
  int64_t repeated = 0, twr_in = 0, skipped = 0;
  std::map<std::string, EstimatorAccount> lane_accounts, one_accounts;
  const auto lanes = replay(
      ro, 12, {}, "lab",
      [&](const Replayer& h) {
        repeated = h.repeated_estimates();
        skipped = h.stats().skipped_other_tags;
        for (const auto& a : h.accounts()) {
          lane_accounts[a.name] = a;
          if (a.name == "uwb_twr") twr_in = a.messages_in;
        }
      },
      6);
  const auto one = replay(
      {}, 12, {}, "lab",
      [&](const Replayer& h) {
        for (const auto& a : h.accounts()) one_accounts[a.name] = a;
      },
      6);
  EXPECT_EQ(skipped, 0);
  ASSERT_GT(twr_in, 2000);
  const auto lane_poses = poses_by_tag(lanes);
  size_t compared = 0;
  std::set<std::string> tags;
  int64_t shards_twr_in = 0;
  std::vector<Out> first_shard;  // every input, and what every shard makes alike
  for (int k = 1; k <= kLanes; ++k) {
    ReplayOptions shard;
    shard.shard = std::to_string(k) + "/" + std::to_string(kLanes);
    const auto part = replay(
        shard, 12, {}, "lab",
        [&](const Replayer& h) {
          for (const auto& a : h.accounts())
            if (a.name == "uwb_twr") shards_twr_in += a.messages_in;
        },
        6);
    if (k == 1) first_shard = part;
    for (const auto& [key, poses] : poses_by_tag(part)) {
      if (shard_of(key.second, kLanes) != k) continue;  // a pose of the log's (TRUTH is not one)
      ASSERT_TRUE(lane_poses.count(key)) << key.first << " " << key.second;
      EXPECT_TRUE(lane_poses.at(key) == poses) << key.first << " " << key.second;
      compared += poses.size();
      tags.insert(key.second);
    }
  }
  EXPECT_EQ(tags.size(), 6u);
  // Each tag's ranges went to its lane. A range between two anchors (every shard takes it) went
  // to the first lane only: every estimator drops it. The sync master's broadcasts, which serve
  // every tag, went to every lane and are counted once.
  EXPECT_GT(shards_twr_in, twr_in);
  EXPECT_EQ(lane_accounts.at("uwb_twr").shared_in, 0);
  EXPECT_GT(lane_accounts.at("uwb_tdoa").shared_in, 0);
  for (const char* name : {"uwb_twr", "fuse"}) {
    const int64_t survey = one_accounts.at(name).drops.count(DropReason::kSurveyRange);
    EXPECT_GT(survey, 50) << name;
    EXPECT_EQ(lane_accounts.at(name).drops.count(DropReason::kSurveyRange), survey) << name;
  }
  ASSERT_EQ(lane_accounts.size(), one_accounts.size());
  const auto n_written = events_by_channel(lanes), n_one = events_by_channel(one);
  const auto written = [&](std::initializer_list<const char*> channels) {
    int64_t n = 0;
    for (const char* c : channels) n += n_written.count(c) ? n_written.at(c) : 0;
    return n;
  };
  for (const auto& [name, a] : lane_accounts) {
    if (name == "fuse" || name == "zones") continue;  // they take estimates, which lanes change
    EXPECT_EQ(a.messages_in, one_accounts.at(name).messages_in) << name;
  }
  // ips-fuse takes the log's inputs as one host does, and each estimate it is handed once, as
  // its lane's own: also one that a shared input caused (a sync master's broadcast closes a
  // lane's blink: more of them with fewer tags in a lane).
  const auto fed = [](const std::map<std::string, int>& n) {
    int64_t total = 0;
    for (const char* c : {"POSE_TDOA", "POSE_AOA", "POSE_INS", "STEP", "ALTITUDE"})
      total += n.count(c) ? n.at(c) : 0;
    return total;
  };
  EXPECT_GT(fed(n_written), 1000);
  EXPECT_EQ(lane_accounts.at("fuse").messages_in - fed(n_written),
            one_accounts.at("fuse").messages_in - fed(n_one));
  EXPECT_EQ(lane_accounts.at("uwb_tdoa").estimates_out, written({"POSE_TDOA", "CLOCK"}));
  EXPECT_EQ(lane_accounts.at("uwb_twr").estimates_out, written({"POSE_UWB"}));
  EXPECT_EQ(lane_accounts.at("fuse").estimates_out, written({"POSE_FUSED"}));
  EXPECT_EQ(lane_accounts.at("pdr").estimates_out, written({"STEP", "POSE_PDR"}));
  EXPECT_EQ(n_written.at("CLOCK"), n_one.at("CLOCK"));
  size_t lane_pose_count = 0;
  for (const auto& [key, poses] : lane_poses) lane_pose_count += poses.size();
  EXPECT_EQ(compared, lane_pose_count);  // nothing else among the lanes' poses
  // Inputs once each, and CLOCK once: every lane hears the sync master, as every shard does.
  const auto n_lanes = events_by_channel(lanes), n_shard = events_by_channel(first_shard);
  for (const char* input : {"UWB_RANGE", "UWB_RX", "BLE_AOA", "IMU", "BARO", "TRUTH", "SITE"})
    EXPECT_EQ(n_lanes.at(input), n_shard.at(input)) << input;
  ASSERT_GT(n_shard.at("CLOCK"), 10);
  EXPECT_EQ(n_lanes.at("CLOCK"), n_shard.at("CLOCK"));
  EXPECT_EQ(repeated, (kLanes - 1) * n_shard.at("CLOCK"));
}

// What serves every tag goes to every lane, and each lane's estimators drop it when it is bad:
// such a drop is the input's own, made alike by every lane, and counted once, as one host counts
// it (before: once per lane, so that more were dropped than came in).
TEST(Replayer, ABadInputThatServesEveryTagIsDroppedOnce) {
  const int64_t t0 = 1767225600000000;
  std::vector<Out> bad;
  for (int k = 0; k < 25; ++k) {
    const int64_t t = t0 + 1000000 + 200000 * k;
    uwb_rx_t rx;  // a sync master's broadcast without a counter frequency
    rx.utime = t;
    rx.source = "test";
    rx.anchor_id = "D2";
    rx.sender_id = "D1";
    rx.is_sync = true;
    rx.seq = k;
    rx.rx_counter = 1000;
    rx.counter_hz = 0;
    rx.rx_power_dbm = rx.fp_power_dbm = rx.quality = NAN;
    std::vector<uint8_t> b(static_cast<size_t>(rx.getEncodedSize()));
    rx.encode(b.data(), 0, static_cast<int>(b.size()));
    bad.push_back({"UWB_RX", t, b});
    baro_t ref;  // a reference station's reading of no pressure
    ref.utime = t + 1;
    ref.source = "test";
    ref.sensor_id = "REF";
    ref.pressure_pa = -1;
    ref.temperature_c = ref.humidity_pct = ref.known_height_m = NAN;
    ref.is_reference = true;
    b.assign(static_cast<size_t>(ref.getEncodedSize()), 0);
    ref.encode(b.data(), 0, static_cast<int>(b.size()));
    bad.push_back({"BARO", t + 1, b});
  }
  const auto invalid = [&](const ReplayOptions& ro) {
    std::map<std::string, int64_t> n;
    replay(
        ro, 12, bad, "lab",
        [&](const Replayer& h) {
          for (const auto& a : h.accounts()) n[a.name] = a.drops.count(DropReason::kInvalid);
        },
        4);
    return n;
  };
  const auto one = invalid({});
  ReplayOptions ro;
  ro.lanes = 3;
  const auto lanes = invalid(ro);
  for (const char* name : {"uwb_tdoa", "altitude", "fuse"}) {
    EXPECT_GE(one.at(name), 25) << name;
    EXPECT_EQ(lanes.at(name), one.at(name)) << name;
  }
}

// --tags and --shard with lanes: the dispatcher skips the other tags' messages (counted) and still
// writes them.
TEST(Replayer, LanesTakeOnlyTheSelectedTags) {
  ReplayOptions ro;
  ro.lanes = 2;
  ro.tags = "T1,T1-5*";
  int64_t skipped = 0, events_in = 0, passed = 0;
  const auto out = replay(
      ro, 12, {}, "lab",
      [&](const Replayer& h) {
        skipped = h.stats().skipped_other_tags;
        events_in = h.stats().events_in;
        passed = h.stats().passed_through;
        EXPECT_FALSE(h.tag_selector().selects_all());
      },
      6);
  std::set<std::string> fused;
  for (const auto& [key, poses] : poses_by_tag(out))
    if (key.first == "POSE_FUSED") fused.insert(key.second);
  EXPECT_EQ(fused, (std::set<std::string>{"T1", "T1-5"}));
  EXPECT_GT(skipped, 1000);
  EXPECT_EQ(passed, events_in);  // the other tags' messages too
  // Within --shard K/N the hash is taken over N first: the shard's tags spread over the lanes
  // (by shard_of(id, 2) alone, every tag of shard 1 would be in lane 1 of 2).
  std::set<int> lanes_of_shard_1;
  for (const std::string id : {"T1", "T1-2", "T1-3", "T1-4", "T1-5", "T1-6"}) {
    EXPECT_EQ(Replayer::lane_of_tag(id, 4, 0), shard_of(id, 4) - 1) << id;  // a lane is a shard
    if (shard_of(id, 2) == 1) lanes_of_shard_1.insert(Replayer::lane_of_tag(id, 2, 2));
  }
  EXPECT_EQ(lanes_of_shard_1, (std::set<int>{0, 1}));
  ro.tags = "";
  ro.shard = "1/2";
  int64_t estimated = 0;
  const auto shard = replay(
      ro, 12, {}, "lab",
      [&](const Replayer& h) {
        const auto cpu = h.cpu_times();
        ASSERT_EQ(cpu.lanes_s.size(), 2u);
        for (const auto& a : h.accounts())
          if (a.name == "fuse") estimated = a.estimates_out;
      },
      6);
  std::set<std::string> shard_fused;
  for (const auto& [key, poses] : poses_by_tag(shard))
    if (key.first == "POSE_FUSED") shard_fused.insert(key.second);
  for (const auto& id : shard_fused) EXPECT_EQ(shard_of(id, 2), 1) << id;
  EXPECT_GE(shard_fused.size(), 2u);
  EXPECT_GT(estimated, 0);
  ro.lanes = 1025;
  EXPECT_THROW(replay(ro, 1), ConfigError);
}

// A failure in the second stage (here the sink's) reaches the caller, from process() or finish(),
// and the host still closes cleanly.
TEST(ReplayHost, AnErrorOnTheSecondThreadIsThrownToTheCaller) {
  // And with lanes, from the merging thread: the workers stop, the caller gets it.
  for (int lanes : {0, 3}) {
    sim::Scenario sc = sim::load_scenario("lab");
    sc.duration_s = 20;
    sim::Simulator sim(sc, 1, 1767225600000000);
    ReplayOptions ro;
    ro.threads = 2;
    ro.lanes = lanes;
    int calls = 0;
    Replayer host(ro, CommonOptions{}, [&](const std::string&, int64_t, const uint8_t*, size_t) {
      if (++calls == 1000) throw std::runtime_error("disk on fire");
    });
    std::string what;
    try {
      sim::SimEvent e;
      while (sim.next(e)) host.process(e.kind, e.utime, e.data.data(), e.data.size());
      host.finish();
    } catch (const std::runtime_error& e) {
      what = e.what();
    }
    EXPECT_EQ(what, "disk on fire") << lanes;
    EXPECT_EQ(calls, 1000) << lanes;  // nothing run after the failure
  }
}

// The TDoA estimator is hosted too: the lab's D1..D4 give POSE_TDOA after a UWB_RX report and a
// CLOCK per anchor after each sync; --only uwb_tdoa hosts it alone.
TEST(ReplayHost, HostsTheTdoaEstimator) {
  for (bool alone : {false, true}) {
    ReplayOptions ro;
    if (alone) ro.only = {"uwb_tdoa"};
    auto out = replay(ro);
    int poses = 0, clocks = 0, uwb_poses = 0;
    std::set<std::string> clock_anchors;
    for (size_t i = 0; i < out.size(); ++i) {
      if (out[i].channel == "POSE_UWB") ++uwb_poses;
      if (out[i].channel == "CLOCK") {
        ++clocks;
        clock_t c;
        ASSERT_GT(c.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
        clock_anchors.insert(c.anchor_id);
        EXPECT_EQ(c.master_id, "D1");
      }
      if (out[i].channel != "POSE_TDOA") continue;
      ++poses;
      EXPECT_EQ(out[i - 1].channel, "UWB_RX");
      EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
      pose_t p;
      ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
      EXPECT_EQ(p.source, "uwb_tdoa");
    }
    EXPECT_GT(poses, 100) << alone;  // 10 Hz blinks for 20 s, once the clocks are synchronised
    EXPECT_GT(clocks, 10) << alone;  // a sync every 2 s
    // Every anchor, the master's own (offset and rate 0) included.
    EXPECT_EQ(clock_anchors, (std::set<std::string>{"D1", "D2", "D3", "D4"})) << alone;
    EXPECT_EQ(uwb_poses > 0, !alone);
  }
}

// The AoA estimator: on aoa-hall, POSE_AOA after the BLE_AOA event that closed an epoch (the
// first of the next advertisement), stamped with its log time; the last epoch comes out at
// finish(), stamped with the last event's time.
TEST(ReplayHost, HostsTheAoaEstimator) {
  ReplayOptions ro;
  ro.only = {"aoa"};
  const auto out = replay(ro, 10, {}, "aoa-hall");
  int poses = 0;
  int64_t last_input = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "POSE_AOA") {
      last_input = out[i].timestamp;
      continue;
    }
    ++poses;
    EXPECT_EQ(out[i].timestamp, last_input);
    pose_t p;
    ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    EXPECT_EQ(p.source, "aoa");
    EXPECT_EQ(p.tag_id, "T1");
    EXPECT_LE(p.utime, out[i].timestamp);  // the epoch's time, before the event that closed it
  }
  EXPECT_NEAR(poses, 100, 1);  // 10 advertisements a second for 10 s
  EXPECT_EQ(out.back().channel, "POSE_AOA");  // the last epoch, flushed at the end
  EXPECT_EQ(replay(ro, 10, {}, "aoa-hall"), out);
}

// The PDR estimator: on walk-square (10 s standing, then walking at 1.8 steps/s), a STEP and a
// POSE_PDR after the IMU sample that completed the step, with the same log time.
TEST(ReplayHost, HostsThePdrEstimator) {
  ReplayOptions ro;
  ro.only = {"pdr"};
  const auto out = replay(ro, 30, {}, "walk-square");
  int steps = 0, poses = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel == "STEP") {
      ++steps;
      EXPECT_EQ(out[i - 1].channel, "IMU");
      EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
      step_t s;
      ASSERT_GT(s.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
      EXPECT_EQ(s.index, steps);
      EXPECT_EQ(s.source, "pdr");
      EXPECT_TRUE(s.heading_known);
    }
    if (out[i].channel == "POSE_PDR") {
      ++poses;
      EXPECT_EQ(out[i - 1].channel, "STEP");
    }
  }
  // 20 s of walking at 1.3 m/s with 0.72 m steps: 36 steps.
  EXPECT_NEAR(steps, 36, 1);
  EXPECT_EQ(poses, steps);
}

// The foot INS: on walk-square-foot (10 s standing, then walking), POSE_INS at 10 Hz once
// aligned, each right after the IMU sample that produced it, with its log time.
TEST(ReplayHost, HostsTheInsEstimator) {
  ReplayOptions ro;
  ro.only = {"ins"};
  const auto out = replay(ro, 20, {}, "walk-square-foot");
  int poses = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "POSE_INS") continue;
    ++poses;
    EXPECT_EQ(out[i - 1].channel, "IMU");
    EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
    pose_t p;
    ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    EXPECT_EQ(p.source, "ins");
  }
  EXPECT_GT(poses, 150);  // 10 Hz over 20 s, less the alignment
  EXPECT_LE(poses, 200);
}

TEST(ReplayHost, HostsTheAltitudeEstimator) {
  ReplayOptions ro;
  ro.only = {"altitude"};
  const auto out = replay(ro, 20, {}, "baro-steps");
  int altitudes = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "ALTITUDE") continue;
    ++altitudes;
    // Released by the reading that brought the reference up to the tag's time.
    EXPECT_EQ(out[i - 1].channel, "BARO");
    EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
    altitude_t a;
    ASSERT_GT(a.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    EXPECT_EQ(a.source, "altitude");
    EXPECT_EQ(a.tag_id, "T1");
    EXPECT_LT(a.utime, out[i].timestamp);
    // T1 at 1.82 m; its sensor reads 25 Pa high and the scenario's site has no offsets: 2.12 m
    // low.
    EXPECT_NEAR(a.height_m, 1.82 - 2.12, 0.15);
  }
  EXPECT_EQ(altitudes, 200);  // 10 Hz over 20 s, the last held back then released by finish()
}

// The fusion alone on corridor-L (UWB_RANGE and INS_MODULE): POSE_FUSED right after the range
// or INS_MODULE pose that brought the track past its publish time, with the same log time.
TEST(ReplayHost, HostsTheFuseEstimator) {
  ReplayOptions ro;
  ro.only = {"fuse"};
  const auto out = replay(ro, 20, {}, "corridor-L");
  int poses = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "POSE_FUSED") continue;
    ++poses;
    ASSERT_GT(i, 0u);
    EXPECT_TRUE(out[i - 1].channel == "UWB_RANGE" || out[i - 1].channel == "INS_MODULE")
        << out[i - 1].channel;
    EXPECT_EQ(out[i - 1].timestamp, out[i].timestamp);
    pose_t p;
    ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    EXPECT_EQ(p.source.rfind("fuse", 0), 0u) << p.source;
    EXPECT_EQ(p.tag_id, "T1");
  }
  // Published at most every publish_period_s (0.1 s), and only when a message moves the track:
  // the ranges come every 0.125 s (4 anchors at 2 Hz each), so one pose per range, 160 in 20 s.
  EXPECT_GT(poses, 150);
  EXPECT_LE(poses, 201);
}

// Hosted alone on `lab`, the fusion takes the log's UWB_RX blinks and BLE_AOA angles tightly:
// ips-uwb-tdoa's clocks and ips-aoa's grouping run inside it; angles are in every pose, and once
// the clocks have locked nearly every pose has blinks in it (a pose names what
// came since the previous one: a 0.1 s window can miss the 10 Hz blink, 2 % are lost).
TEST(ReplayHost, FuseTakesTheLogsBlinksAndAnglesTightly) {
  ReplayOptions ro;
  ro.only = {"fuse"};
  const auto out = replay(ro, 10);
  int fused = 0, tight = 0, first_tight = -1, angles = 0;
  for (const auto& o : out) {
    if (o.channel != "POSE_FUSED") continue;
    pose_t p;
    ASSERT_GT(p.decode(o.data.data(), 0, static_cast<int>(o.data.size())), 0);
    if (p.source.find("ble_aoa") != std::string::npos) ++angles;
    if (p.source.find("uwb_tdoa") != std::string::npos) {
      ++tight;
      if (first_tight < 0) first_tight = fused;
    }
    ++fused;
  }
  std::printf("lab 10 s: %d fused poses, %d with blinks from pose %d on\n", fused, tight,
              first_tight);
  // 10 s at 10 Hz. The clocks lock after the second sync round (syncs every 2 s).
  EXPECT_GT(fused, 90);
  ASSERT_GE(first_tight, 0);
  EXPECT_LT(first_tight, 60);
  EXPECT_GE(tight, 0.85 * (fused - first_tight));
  EXPECT_GE(angles, 0.85 * fused);
}

// With every estimator hosted, the fusion reads the regenerated POSE_TDOA, ALTITUDE, ... (the
// log's own events on those channels are dropped), each right after it was written, and only
// once, even when the log's events are kept.
TEST(ReplayHost, FuseGetsRegeneratedInputs) {
  for (bool keep : {false, true}) {
    ReplayOptions ro;
    ro.keep_regenerated = keep;
    const auto out = replay(ro);
    int fused = 0, from_regenerated = 0;
    for (size_t i = 0; i < out.size(); ++i) {
      if (out[i].channel != "POSE_FUSED") continue;
      ++fused;
      pose_t p;
      ASSERT_GT(p.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
      EXPECT_EQ(p.source.rfind("fuse", 0), 0u) << p.source;
      if (p.source.find("tdoa") != std::string::npos ||
          p.source.find("altitude") != std::string::npos)
        ++from_regenerated;
    }
    EXPECT_GT(fused, 0) << keep;
    EXPECT_GT(from_regenerated, 0) << keep;
  }
}

// Kept log events on a channel a hosted estimator regenerates do not reach the fusion: an old
// POSE_TDOA stream in the log (here the lab's POSE_UWB, 0.3 m off) leaves POSE_FUSED as it is
// without it.
TEST(ReplayHost, FuseIgnoresKeptEventsOfHostedProducers) {
  auto fused_only = [](const std::vector<Out>& out) {
    std::vector<Out> f;
    for (const auto& o : out)
      if (o.channel == "POSE_FUSED") f.push_back(o);
    return f;
  };
  ReplayOptions twr;
  twr.only = {"uwb_twr"};
  std::vector<Out> old_tdoa;
  for (const auto& o : replay(twr, 10)) {
    if (o.channel != "POSE_UWB") continue;
    pose_t p;
    ASSERT_GT(p.decode(o.data.data(), 0, static_cast<int>(o.data.size())), 0);
    p.source = "uwb_tdoa";
    p.position[0] += 0.3;
    std::vector<uint8_t> bytes(static_cast<size_t>(p.getEncodedSize()));
    p.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    old_tdoa.push_back({"POSE_TDOA", o.timestamp, bytes});
  }
  ASSERT_GT(old_tdoa.size(), 50u);
  ReplayOptions keep;
  keep.keep_regenerated = true;
  const auto fused = fused_only(replay(keep, 10));
  ASSERT_FALSE(fused.empty());
  EXPECT_EQ(fused_only(replay(keep, 10, old_tdoa)), fused);
  // Without uwb_tdoa hosted, the fusion reads the log's POSE_TDOA, and the old stream tells.
  keep.only = {"uwb_twr", "fuse"};
  EXPECT_NE(fused_only(replay(keep, 10, old_tdoa)), fused_only(replay(keep, 10)));
}

// ips-zones hosted with the fusion hears POSE_FUSED as it is written: its events follow the pose
// that confirmed them (same log time), stamped earlier at the boundary crossing; hosted alone on
// TRUTH it reads the log.
TEST(ReplayHost, HostsZonesOnTheFusedPosesOrOnTheLog) {
  ReplayOptions ro;
  ro.only = {"fuse", "zones"};
  const auto out = replay(ro, 25);
  std::vector<zone_event_t> events;
  for (size_t i = 0; i < out.size(); ++i) {
    if (out[i].channel != "ZONE_EVENT") continue;
    zone_event_t e;
    ASSERT_GT(e.decode(out[i].data.data(), 0, static_cast<int>(out[i].data.size())), 0);
    ASSERT_GT(i, 0u);
    EXPECT_TRUE(out[i - 1].channel == "POSE_FUSED" || out[i - 1].channel == "ZONE_EVENT")
        << out[i - 1].channel;
    EXPECT_LE(e.utime, out[i].timestamp);
    EXPECT_EQ(e.pose_channel, "POSE_FUSED");
    events.push_back(e);
  }
  // The first lap (21 s): bench in and out, store in, dwell, out, entrance in and out; bench in.
  ASSERT_EQ(events.size(), 8u);
  const std::vector<std::pair<std::string, int8_t>> want = {
      {"bench", zone_event_t::EVENT_ENTER},    {"bench", zone_event_t::EVENT_LEAVE},
      {"store", zone_event_t::EVENT_ENTER},    {"store", zone_event_t::EVENT_DWELL},
      {"store", zone_event_t::EVENT_LEAVE},    {"entrance", zone_event_t::EVENT_ENTER},
      {"entrance", zone_event_t::EVENT_LEAVE}, {"bench", zone_event_t::EVENT_ENTER}};
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(events[i].zone_id, want[i].first) << i;
    EXPECT_EQ(events[i].event, want[i].second) << i;
  }

  ro.only = {"zones"};
  ro.zones_pose_channel = "TRUTH";
  int truth_events = 0;
  for (const auto& o : replay(ro, 25)) truth_events += o.channel == "ZONE_EVENT";
  EXPECT_EQ(truth_events, 8);
}

TEST(ReplayHost, SameEventsSameBytes) { EXPECT_EQ(replay({}), replay({})); }

TEST(ReplayHost, RegeneratedChannelsAreDroppedUnlessKept) {
  pose_t stale{};
  stale.source = "old_version";
  std::vector<uint8_t> bytes(static_cast<size_t>(stale.getEncodedSize()));
  stale.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const std::vector<Out> old_estimate = {{"POSE_UWB", 1, bytes}};
  auto count_old = [](const std::vector<Out>& out) {
    int n = 0;
    for (const auto& o : out) n += o.channel == "POSE_UWB" && o.timestamp == 1;
    return n;
  };
  EXPECT_EQ(count_old(replay({}, 2, old_estimate)), 0);
  ReplayOptions keep;
  keep.keep_regenerated = true;
  EXPECT_EQ(count_old(replay(keep, 2, old_estimate)), 1);
}

TEST(ReplayHost, OnlyNamesKnownEstimators) {
  ReplayOptions ro;
  ro.only = {"uwb_twr"};
  EXPECT_NO_THROW(ReplayHost(ro, CommonOptions{}, [](auto&&...) {}));
  ro.only = {"uwb_twr", "teleport"};
  try {
    ReplayHost(ro, CommonOptions{}, [](auto&&...) {});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(),
                 "--only: unknown estimator 'teleport' (uwb_twr, uwb_tdoa, aoa, pdr, ins, "
                 "altitude, fuse, zones)");
  }
}

TEST(ReplayHost, BadInputIsCountedAndPassedThrough) {
  std::vector<Out> out;
  ReplayHost host({}, CommonOptions{}, [&](const std::string& ch, int64_t ts, const uint8_t* d,
                                          size_t n) { out.push_back({ch, ts, {d, d + n}}); });
  const uint8_t garbage[7] = {1, 2, 3, 4, 5, 6, 7};
  host.process("UWB_RANGE", 1, garbage, sizeof garbage);
  site_t broken{};
  broken.source = "x";
  broken.name = "y";
  broken.site_yaml = "anchors: [";
  std::vector<uint8_t> b(static_cast<size_t>(broken.getEncodedSize()));
  broken.encode(b.data(), 0, static_cast<int>(b.size()));
  host.process("SITE", 2, b.data(), b.size());
  EXPECT_EQ(host.stats().undecodable, 1);
  EXPECT_EQ(host.stats().bad_sites, 1);
  EXPECT_EQ(out.size(), 2u);  // nothing is lost: both go to the output log as they were
}

// --- Nothing silent: per estimator, what went in, what came out, and why inputs gave nothing. ---

template <class Msg>
Out event(const std::string& channel, int64_t t, const Msg& m) {
  std::vector<uint8_t> b(static_cast<size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return {channel, t, std::move(b)};
}

constexpr int64_t kT0 = 1767225600000000;  // 2026-01-01, as the simulated logs

// A site of four uwb anchors A1..A4 (the lab's) and no anchor of another kind, as a SITE message.
Out uwb_site_event() {
  const Site site = parse_site_text(
      "name: uwb-only\n"
      "anchors:\n"
      "  - {id: A1, kind: uwb, position: [0.0, 0.0, 2.4]}\n"
      "  - {id: A2, kind: uwb, position: [10.0, 0.0, 2.4]}\n"
      "  - {id: A3, kind: uwb, position: [10.0, 8.0, 2.4]}\n"
      "  - {id: A4, kind: uwb, position: [0.0, 8.0, 2.4]}\n"
      "tags:\n"
      "  - {id: T1, height_m: 1.2}\n",
      "uwb-only site");
  return event("SITE", kT0, site_to_msg(site, kT0, "test"));
}

ble_aoa_t aoa_event(int64_t t, const std::string& anchor) {
  ble_aoa_t m{};
  m.utime = t;
  m.source = "test";
  m.anchor_id = anchor;
  m.tag_id = "T1";
  m.azimuth_deg = 10;
  m.elevation_deg = 20;
  m.rssi_dbm = -60;
  m.channel = 37;
  return m;
}

struct HostRun {
  std::vector<EstimatorAccount> accounts;
  std::string nothing;
  std::vector<Out> out;
};

HostRun run_host(const ReplayOptions& ro, const std::vector<Out>& events) {
  HostRun r;
  ReplayHost host(ro, CommonOptions{}, [&](const std::string& ch, int64_t ts, const uint8_t* d,
                                          size_t n) { r.out.push_back({ch, ts, {d, d + n}}); });
  for (const auto& e : events) host.process(e.channel, e.timestamp, e.data.data(), e.data.size());
  host.finish();
  r.accounts = host.accounts();
  r.nothing = host.nothing_estimated();
  return r;
}

TEST(ReplayHostAccounts, NoSiteInTheLogIsTheReasonAndSaysWhatToDo) {
  ReplayOptions ro;
  ro.only = {"aoa"};
  std::vector<Out> events;
  for (int i = 0; i < 20; ++i) events.push_back(event("BLE_AOA", kT0 + i * 50000,
                                                      aoa_event(kT0 + i * 50000, "B1")));
  const HostRun r = run_host(ro, events);
  ASSERT_EQ(r.accounts.size(), 1u);
  const EstimatorAccount& a = r.accounts[0];
  EXPECT_EQ(a.name, "aoa");
  EXPECT_EQ(a.messages_in, 20);
  EXPECT_EQ(a.estimates_out, 0);
  EXPECT_EQ(a.drops.count(DropReason::kNoSite), 20);
  EXPECT_EQ(a.drops.total(), 20);
  EXPECT_TRUE(a.silent);
  EXPECT_TRUE(a.warn);
  EXPECT_EQ(a.line,
            "aoa: 20 BLE_AOA in, 0 estimates out: 20 no site (the log has no SITE: give --site "
            "FILE)");
  EXPECT_EQ(r.nothing, "no hosted estimator gave an estimate: " + a.line);
}

TEST(ReplayHostAccounts, ASiteWithoutAoaAnchorsIsTheReason) {
  ReplayOptions ro;
  ro.only = {"aoa", "fuse"};
  std::vector<Out> events{uwb_site_event()};
  // B1 is no anchor of the lab; A1 is one, of kind uwb: the site has no ble_aoa anchor at all.
  for (int i = 0; i < 10; ++i)
    events.push_back(event("BLE_AOA", kT0 + i * 50000, aoa_event(kT0 + i * 50000, i % 2 ? "A1" : "B1")));
  const HostRun r = run_host(ro, events);
  ASSERT_EQ(r.accounts.size(), 2u);
  const EstimatorAccount& a = r.accounts[0];
  EXPECT_EQ(a.drops.count(DropReason::kNoAnchorsOfKind), 10);
  EXPECT_EQ(a.line, "aoa: 10 BLE_AOA in, 0 estimates out: 10 no anchors of its kind in the site");
  EXPECT_TRUE(a.warn);
  // The fusion groups the same angles and says the same.
  EXPECT_EQ(r.accounts[1].name, "fuse");
  EXPECT_EQ(r.accounts[1].messages_in, 10);
  EXPECT_EQ(r.accounts[1].drops.count(DropReason::kNoAnchorsOfKind), 10);
  EXPECT_EQ(r.nothing, "no hosted estimator gave an estimate: " + a.line);
}

TEST(ReplayHostAccounts, NanGyroIsInvalidForPdrAndIns) {
  ReplayOptions ro;
  ro.only = {"pdr", "ins"};
  std::vector<Out> events{uwb_site_event()};
  for (int i = 0; i < 100; ++i) {
    imu_t m{};
    m.utime = kT0 + 10000 + i * 10000;
    m.source = "test";
    // A string, not the literal: GCC 12 at -O3 takes the literal's inlined copy into m{} for a
    // read of uninitialised bytes (-Wmaybe-uninitialized, a false positive).
    m.device_id = std::string("T1");
    m.device_utime = -1;
    m.accel[2] = 9.81;
    // 30 samples with a NaN gyroscope, after some with one (a device whose first samples have
    // none is an accelerometer-only phone to ips-pdr: its steps are counted without heading).
    m.gyro[0] = i >= 10 && i < 40 ? std::nan("") : 0.0;
    for (double& b : m.mag_ut) b = std::nan("");
    events.push_back(event("IMU", m.utime, m));
  }
  const HostRun r = run_host(ro, events);
  ASSERT_EQ(r.accounts.size(), 2u);
  for (const auto& a : r.accounts) {
    EXPECT_EQ(a.messages_in, 100) << a.name;
    EXPECT_EQ(a.drops.count(DropReason::kInvalid), 30) << a.name;
    // The other 70: a device at rest, aligning (ins needs alignment_s of stillness first).
    EXPECT_EQ(a.drops.count(DropReason::kNoSite), 0) << a.name;
  }
  EXPECT_EQ(r.accounts[0].name, "pdr");
  EXPECT_EQ(r.accounts[1].name, "ins");
  EXPECT_NE(r.accounts[1].line.find("30 invalid"), std::string::npos) << r.accounts[1].line;
  EXPECT_TRUE(r.accounts[1].silent);
  EXPECT_TRUE(r.accounts[1].warn);  // invalid input is a fault
}

// Ranges far too short for where the tag is (0.3 m from an anchor 1.2 m above it) are outliers:
// gated, counted, and named in the account of an estimator that still tracks the tag.
TEST(ReplayHostAccounts, GatedOutliersAreCountedAndNamed) {
  ReplayOptions ro;
  ro.only = {"uwb_twr"};
  std::vector<Out> outliers;
  for (int k = 3; k <= 8; ++k) {
    uwb_range_t m{};
    m.utime = kT0 + k * 1000000 + 50000;
    m.source = "test";
    m.tag_id = "T1";
    m.anchor_id = "A1";
    m.range_m = 0.3;
    m.rx_power_dbm = m.fp_power_dbm = m.quality = std::nanf("");
    outliers.push_back(event("UWB_RANGE", m.utime, m));
  }
  DropReasons clean, dirty;
  int64_t clean_out = 0;
  replay(ro, 10, {}, "lab", [&](const Replayer& h) {
    clean = h.accounts()[0].drops;
    clean_out = h.accounts()[0].estimates_out;
  });
  EstimatorAccount acc;
  replay(ro, 10, outliers, "lab", [&](const Replayer& h) { acc = h.accounts()[0]; });
  dirty = acc.drops;
  EXPECT_GE(dirty.count(DropReason::kGated), clean.count(DropReason::kGated) + 6);
  EXPECT_GT(acc.estimates_out, clean_out / 2);
  EXPECT_FALSE(acc.silent);
  EXPECT_FALSE(acc.warn);
  EXPECT_NE(acc.line.find(" gated"), std::string::npos) << acc.line;
  EXPECT_EQ(acc.line.rfind("uwb_twr: ", 0), 0u) << acc.line;
}

TEST(ReplayHostAccounts, ALogWithNoInputForTheHostedEstimatorsSaysSo) {
  ReplayOptions ro;
  ro.only = {"pdr", "altitude"};
  const HostRun r = run_host(ro, {uwb_site_event()});
  EXPECT_EQ(r.nothing,
            "the log holds no input for the hosted estimators (pdr: IMU, altitude: BARO): nothing "
            "estimated");
  ASSERT_EQ(r.accounts.size(), 2u);
  EXPECT_EQ(r.accounts[0].line, "pdr: 0 IMU in, 0 estimates out");
  EXPECT_FALSE(r.accounts[0].silent);
}

// The simulated lab: every estimator with input says what came of it; nothing is missing.
TEST(ReplayHostAccounts, TheLabAccountsForEveryHostedEstimator) {
  std::vector<EstimatorAccount> acc;
  std::string nothing = "?";
  replay({}, 20, {}, "lab", [&](const Replayer& h) {
    acc = h.accounts();
    nothing = h.nothing_estimated();
  });
  EXPECT_EQ(nothing, "");
  ASSERT_EQ(acc.size(), ReplayHost::available().size());
  int64_t out = 0;
  for (const auto& a : acc) {
    EXPECT_EQ(a.line.rfind(a.name + ": " + std::to_string(a.messages_in) + " ", 0), 0u) << a.line;
    EXPECT_EQ(a.drops.count(DropReason::kNoSite), 0) << a.name;
    out += a.estimates_out;
  }
  EXPECT_GT(acc[0].estimates_out, 100);  // uwb_twr
  EXPECT_GT(out, acc[0].estimates_out);
}

}  // namespace
}  // namespace ips::replay
