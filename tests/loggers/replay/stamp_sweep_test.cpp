// One message with a bad time stamp, on every input channel of every estimator and of ips-fuse,
// at offsets from seconds to years ahead and behind: it costs at most the estimates of one second
// and never moves an estimate further from the truth than the clean run's worst. The estimators
// run in the replay host, as ips-replay runs them; the stamp is the message's own utime (the
// first field of every message type here), the log time is left as it was (the message arrived
// when the others did).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ips/altitude_t.hpp>
#include <ips/pose_t.hpp>
#include <ips/uwb_rx_t.hpp>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "drivers/sim/simulator.hpp"
#include "loggers/replay/replay_host.hpp"

namespace ips::replay {
namespace {

constexpr int64_t kStart = 1767225600000000;  // 2026-01-01T00:00:00Z
constexpr int64_t kSec = 1000000;
constexpr int64_t kYear = 365LL * 86400 * kSec;

struct Event {
  std::string channel;
  int64_t timestamp;
  std::vector<uint8_t> data;
};

std::vector<Event> simulate(const std::string& scenario, double duration_s) {
  sim::Scenario sc = sim::load_scenario(scenario);
  sc.duration_s = duration_s;
  sim::Simulator sim(sc, 1, kStart);
  std::vector<Event> out;
  sim::SimEvent e;
  while (sim.next(e)) out.push_back({e.kind, e.utime, e.data});
  return out;
}

std::vector<Event> replay(const std::vector<Event>& in, const std::set<std::string>& only,
                          bool keep_regenerated = false) {
  ReplayOptions ro;
  ro.only = only;
  ro.keep_regenerated = keep_regenerated;
  std::vector<Event> out;
  ReplayHost host(ro, CommonOptions{}, [&](const std::string& ch, int64_t ts, const uint8_t* d,
                                          size_t n) { out.push_back({ch, ts, {d, d + n}}); });
  for (const Event& e : in) host.process(e.channel, e.timestamp, e.data.data(), e.data.size());
  host.finish();
  return out;
}

// The message's utime: the 8 bytes after the fingerprint, big-endian.
int64_t stamp_of(const Event& e) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | e.data[8 + static_cast<size_t>(i)];
  return static_cast<int64_t>(v);
}
void set_stamp(Event& e, int64_t t) {
  const auto v = static_cast<uint64_t>(t);
  for (int i = 0; i < 8; ++i) e.data[8 + static_cast<size_t>(i)] = static_cast<uint8_t>(v >> (56 - 8 * i));
}

// `in` with a copy of the first `channel` message of the second half, its stamp moved by
// `offset`, right after the original.
std::vector<Event> with_bad_stamp(const std::vector<Event>& in, const std::string& channel,
                                  int64_t offset) {
  const int64_t mid = (in.front().timestamp + in.back().timestamp) / 2;
  std::vector<Event> out;
  bool done = false;
  for (const Event& e : in) {
    out.push_back(e);
    if (!done && e.channel == channel && e.timestamp >= mid) {
      Event bad = e;
      set_stamp(bad, stamp_of(e) + offset);
      out.push_back(bad);
      done = true;
    }
  }
  EXPECT_TRUE(done) << "no " << channel << " in the second half";
  return out;
}

struct Truth {
  std::map<std::string, std::vector<pose_t>> by_tag;
  // Horizontal error of a position at time t, by linear interpolation of the truth.
  double error(const pose_t& p) const {
    auto it = by_tag.find(p.tag_id);
    if (it == by_tag.end() || it->second.empty()) return NAN;
    const auto& v = it->second;
    auto after = std::lower_bound(v.begin(), v.end(), p.utime,
                                  [](const pose_t& a, int64_t t) { return a.utime < t; });
    if (after == v.begin() || after == v.end()) return NAN;
    const pose_t& a = *(after - 1);
    const pose_t& b = *after;
    const double f = static_cast<double>(p.utime - a.utime) / static_cast<double>(b.utime - a.utime);
    const double x = a.position[0] + f * (b.position[0] - a.position[0]);
    const double y = a.position[1] + f * (b.position[1] - a.position[1]);
    return std::hypot(p.position[0] - x, p.position[1] - y);
  }
};

Truth truth_of(const std::vector<Event>& events) {
  Truth t;
  for (const Event& e : events) {
    if (e.channel != "TRUTH") continue;
    pose_t p;
    if (p.decode(e.data.data(), 0, static_cast<int>(e.data.size())) < 0) continue;
    t.by_tag[p.tag_id].push_back(p);
  }
  return t;
}

// What one output channel of a replay says: how many estimates, their time span, the worst
// horizontal error of its poses.
struct Summary {
  int count = 0;
  int64_t first = INT64_MAX, last = INT64_MIN;
  double max_error = 0;
};

std::map<std::string, Summary> summarise(const std::vector<Event>& out,
                                         const std::set<std::string>& channels,
                                         const Truth& truth) {
  std::map<std::string, Summary> s;
  for (const Event& e : out) {
    if (!channels.count(e.channel)) continue;
    Summary& x = s[e.channel];
    ++x.count;
    const int64_t t = stamp_of(e);
    x.first = std::min(x.first, t);
    x.last = std::max(x.last, t);
    if (e.channel.rfind("POSE_", 0) == 0) {
      pose_t p;
      if (p.decode(e.data.data(), 0, static_cast<int>(e.data.size())) < 0) continue;
      const double err = truth.error(p);
      if (std::isfinite(err)) x.max_error = std::max(x.max_error, err);
    }
  }
  return s;
}

const std::vector<int64_t> kOffsets = {20 * kSec, kYear, 3 * kSec, -20 * kSec, -kYear};

// Replays `in` clean and with one bad stamp on each of `inputs` at each offset; every output in
// `outputs` keeps its estimates (all but one second's worth), its time span and its accuracy.
void sweep(const std::vector<Event>& in, const std::set<std::string>& only,
           const std::vector<std::string>& inputs, const std::set<std::string>& outputs,
           const Truth& truth) {
  const double duration_s =
      static_cast<double>(in.back().timestamp - in.front().timestamp) * 1e-6;
  const auto clean = summarise(replay(in, only), outputs, truth);
  for (const std::string& ch : outputs) ASSERT_GT(clean.count(ch) ? clean.at(ch).count : 0, 10) << ch;
  for (const std::string& input : inputs) {
    for (int64_t offset : kOffsets) {
      const auto bad = summarise(replay(with_bad_stamp(in, input, offset), only), outputs, truth);
      for (const auto& [ch, c] : clean) {
        SCOPED_TRACE("a " + input + " message stamped " + std::to_string(offset / kSec) +
                     " s off; output " + ch);
        ASSERT_TRUE(bad.count(ch));
        const Summary& b = bad.at(ch);
        const int per_second = static_cast<int>(std::ceil(c.count / duration_s));
        EXPECT_GE(b.count, c.count - per_second - 1);
        EXPECT_GE(b.first, c.first - kSec);
        EXPECT_LE(b.last, c.last + kSec);
        EXPECT_LE(b.max_error, c.max_error + 0.25);
      }
    }
  }
}

TEST(StampSweep, EveryInputOfTheLabEstimators) {
  const std::vector<Event> in = simulate("lab", 24);
  sweep(in, {"uwb_twr", "uwb_tdoa", "aoa", "pdr", "altitude", "fuse"},
        {"UWB_RANGE", "UWB_RX", "BLE_AOA", "IMU", "BARO", "INS_MODULE"},
        {"POSE_UWB", "POSE_TDOA", "POSE_AOA", "STEP", "ALTITUDE", "POSE_FUSED"}, truth_of(in));
}

TEST(StampSweep, OneWildCounterOfAnAnchorCostsNoMoreThanABadStamp) {
  // The counters from devices: one sync or blink reception whose 40-bit counter reads half a wrap
  // off (a glitch, a corrupt report): gated, never the clock's new state.
  const std::vector<Event> lab = simulate("lab", 24);
  const Truth truth = truth_of(lab);
  const std::set<std::string> only = {"uwb_tdoa", "fuse"};
  const std::set<std::string> outputs = {"POSE_TDOA", "POSE_FUSED"};
  const auto clean = summarise(replay(lab, only), outputs, truth);
  for (bool sync : {true, false}) {
    std::vector<Event> in;
    bool done = false;
    for (const Event& e : lab) {
      in.push_back(e);
      uwb_rx_t m;
      if (done || e.channel != "UWB_RX" || e.timestamp < lab.back().timestamp - 10 * kSec ||
          m.decode(e.data.data(), 0, static_cast<int>(e.data.size())) < 0 || m.is_sync != sync)
        continue;
      m.rx_counter = (m.rx_counter + (int64_t{1} << 39)) % (int64_t{1} << 40);
      Event bad = e;
      bad.data.resize(static_cast<size_t>(m.getEncodedSize()));
      m.encode(bad.data.data(), 0, static_cast<int>(bad.data.size()));
      in.push_back(bad);
      done = true;
    }
    ASSERT_TRUE(done);
    const auto bad = summarise(replay(in, only), outputs, truth);
    for (const auto& [ch, c] : clean) {
      SCOPED_TRACE(std::string(sync ? "a sync" : "a blink") + " reception with a wild counter; " + ch);
      const Summary& b = bad.at(ch);
      EXPECT_GE(b.count, c.count - static_cast<int>(std::ceil(c.count / 24.0)) - 1);
      EXPECT_LE(b.max_error, c.max_error + 0.25);
    }
  }
}

TEST(StampSweep, EveryInputOfTheFusionFromOtherEstimators) {
  // The other estimators' outputs, as a log of a live lab would hold them; ips-fuse alone.
  const std::vector<Event> lab = simulate("lab", 24);
  const std::vector<Event> in =
      replay(lab, {"uwb_twr", "uwb_tdoa", "aoa", "pdr", "altitude"}, true);
  sweep(in, {"fuse"}, {"POSE_TDOA", "POSE_AOA", "STEP", "ALTITUDE"}, {"POSE_FUSED"},
        truth_of(lab));
}

TEST(StampSweep, TheFootInertialNavigation) {
  const std::vector<Event> in = simulate("walk-square-foot", 24);
  sweep(in, {"ins", "fuse"}, {"IMU"}, {"POSE_INS", "POSE_FUSED"}, truth_of(in));
}

}  // namespace
}  // namespace ips::replay
