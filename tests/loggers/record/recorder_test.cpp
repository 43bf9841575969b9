// ips-record's core: the bounded queue drops and counts instead of blocking, every part starts
// with SITE, parts split by size and by time without losing or reordering an event, a stop writes
// everything received, refusals say why, and a failing disk is reported.
#include "loggers/record/recorder.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <ips/site_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/node.hpp"
#include "drivers/sim/simulator.hpp"

namespace ips::record {
namespace {

namespace fs = std::filesystem;

struct Read {
  std::string channel;
  int64_t utime;
  std::vector<uint8_t> data;
};

std::vector<Read> read_log(const fs::path& path) {
  lcm::LogFile log(path.string(), "r");
  EXPECT_TRUE(log.good()) << path;
  std::vector<Read> out;
  while (const lcm::LogEvent* e = log.readNextEvent()) {
    const auto* d = static_cast<const uint8_t*>(e->data);
    out.push_back({e->channel, e->timestamp, {d, d + e->datalen}});
  }
  return out;
}

// The `lab` scenario's first `seconds` of events, as they would come off the bus (SITE among
// them, at the start).
std::vector<Event> lab_events(double seconds) {
  sim::Scenario sc = sim::load_scenario("lab");
  sc.duration_s = seconds;
  sim::Simulator sim(sc, 1, 1767225600000000);
  std::vector<Event> out;
  sim::SimEvent e;
  while (sim.next(e)) out.push_back({e.kind, e.utime, e.data});
  return out;
}

class TempDir {
 public:
  TempDir() {
    char tmpl[] = "/tmp/ips-record-test-XXXXXX";
    path_ = mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

bool is_site(const Read& r) {
  site_t s;
  return r.channel == "SITE" && decode_message(s, r.data.data(), r.data.size());
}

TEST(EventQueue, DropsAndCountsWhenTheUnwrittenBytesWouldExceedTheCapacity) {
  const Event probe{"UWB_RANGE", 1, std::vector<uint8_t>(100)};
  const size_t one = probe.footprint();
  EventQueue q(3 * one + one / 2);  // room for three
  int accepted = 0;
  for (int i = 0; i < 5; ++i) accepted += q.push(Event(probe)) ? 1 : 0;
  EXPECT_EQ(accepted, 3);
  EXPECT_EQ(q.dropped(), 2);
  EXPECT_EQ(q.dropped_by_channel().at("UWB_RANGE"), 2);
  EXPECT_EQ(q.unwritten_bytes(), 3 * one);

  // Popped but not yet written still counts: the bound covers what the writer holds.
  std::vector<Event> batch;
  ASSERT_TRUE(q.pop_all(batch, std::chrono::milliseconds(0)));
  EXPECT_EQ(batch.size(), 3u);
  EXPECT_FALSE(q.push(Event(probe)));
  q.release(2 * one);
  EXPECT_TRUE(q.push(Event(probe)));
  EXPECT_EQ(q.peak_bytes(), 3 * one);

  q.close();
  EXPECT_FALSE(q.push(Event(probe))) << "a closed queue takes nothing";
  batch.clear();
  EXPECT_TRUE(q.pop_all(batch, std::chrono::milliseconds(0))) << "what was queued drains";
  EXPECT_EQ(batch.size(), 1u);
  batch.clear();
  EXPECT_FALSE(q.pop_all(batch, std::chrono::milliseconds(0)));
}

TEST(SessionWriter, SplitsBySizeWithSiteFirstInEveryPartAndNothingLostOrReordered) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "s.lcm";
  o.split_mb = 0.05;
  const auto events = lab_events(10);
  {
    SessionWriter w(o);
    for (const auto& e : events) w.write(e);
    w.close();
    ASSERT_GE(w.parts().size(), 5u);
    int64_t total = 0;
    for (const auto& p : w.parts()) {
      EXPECT_EQ(static_cast<int64_t>(fs::file_size(p.path)), p.bytes) << p.path;
      EXPECT_LE(p.bytes, 50000) << p.path;
      total += p.events;
    }
    EXPECT_EQ(total, w.events());
  }
  std::vector<Read> body;
  for (int i = 0;; ++i) {
    const fs::path p = part_path(o, i);
    if (!fs::exists(p)) {
      EXPECT_GE(i, 5);
      break;
    }
    EXPECT_EQ(p.filename().string(), "s." + std::string(i < 10 ? "00" : "0") + std::to_string(i) + ".lcm");
    auto part = read_log(p);
    ASSERT_FALSE(part.empty());
    ASSERT_TRUE(is_site(part.front())) << p << " does not start with SITE";
    if (i > 0 && part.size() > 1) {
      EXPECT_EQ(part[0].utime, part[1].utime) << "the head carries the part's first receive time";
    }
    // The lab scenario's SITE is its first event: the first part needs no extra head.
    body.insert(body.end(), part.begin() + (i == 0 ? 0 : 1), part.end());
  }
  ASSERT_EQ(body.size(), events.size());
  for (size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(body[i].channel, events[i].channel) << i;
    EXPECT_EQ(body[i].utime, events[i].utime) << i;
    EXPECT_EQ(body[i].data, events[i].data) << i;
  }
}

TEST(SessionWriter, SplitsByReceiveTime) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "t.lcm";
  o.split_s = 3;
  const auto events = lab_events(10);  // 0 .. 10 s
  SessionWriter w(o);
  for (const auto& e : events) w.write(e);
  w.close();
  ASSERT_EQ(w.parts().size(), 4u);  // [0,3) [3,6) [6,9) [9,10]
  for (const auto& p : w.parts()) {
    EXPECT_LT(p.last_utime - p.first_utime, 3'000'000) << p.path;
    EXPECT_TRUE(p.site_head) << p.path;
  }
  EXPECT_GE(w.parts()[1].first_utime - w.parts()[0].first_utime, 3'000'000);
}

TEST(SessionWriter, AFileSiteHeadsTheFirstPartAndABusSiteReplacesItForLaterParts) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "h.lcm";
  o.split_s = 1;
  auto events = lab_events(3);
  ASSERT_EQ(events.front().channel, "SITE");
  const Event bus_site = events.front();
  events.erase(events.begin());
  site_t file_msg;
  ASSERT_TRUE(decode_message(file_msg, bus_site.data.data(), bus_site.data.size()));
  file_msg.source = "from a file";
  std::vector<uint8_t> file_site(static_cast<size_t>(file_msg.getEncodedSize()));
  file_msg.encode(file_site.data(), 0, static_cast<int>(file_site.size()));

  SessionWriter w(o);
  w.set_site(file_site);
  size_t i = 0;
  for (; events[i].utime < events.front().utime + 1'500'000; ++i) w.write(events[i]);
  w.write({"SITE", events[i].utime, bus_site.data});
  for (; i < events.size(); ++i) w.write(events[i]);
  w.close();
  ASSERT_EQ(w.parts().size(), 4u);  // [0,1) [1,2) [2,3) and the events at 3.0 s
  auto head = [&](int part) {
    site_t s;
    const auto log = read_log(part_path(o, part));
    EXPECT_TRUE(decode_message(s, log.front().data.data(), log.front().data.size()));
    return s.source;
  };
  EXPECT_EQ(head(0), "from a file");
  EXPECT_EQ(head(1), "from a file");
  EXPECT_NE(head(2), "from a file");
  EXPECT_NE(head(3), "from a file");
}

TEST(SessionWriter, WithoutASitePartsStartWithTheirFirstEvent) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "n.lcm";
  SessionWriter w(o);
  w.write({"UWB_RANGE", 5, {1, 2, 3}});
  w.close();
  const auto log = read_log(o.out);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0].channel, "UWB_RANGE");
  EXPECT_FALSE(w.parts()[0].site_head);
}

TEST(Preflight, RefusesAnUnwritableTargetExistingFilesAndANearlyFullDisk) {
  TempDir dir;
  SessionOptions o;
  auto message = [&] {
    try {
      preflight(o);
    } catch (const RecordError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  o.out = "/proc/ips-record-test/s.lcm";  // no file can be created under /proc, not even by root
  EXPECT_NE(message().find("cannot"), std::string::npos) << message();

  o.out = dir.path() / "sub" / "s.lcm";
  EXPECT_EQ(message(), "accepted");
  EXPECT_TRUE(fs::is_directory(dir.path() / "sub")) << "the directory is created";

  std::ofstream(dir.path() / "sub" / "s.lcm") << "x";
  EXPECT_NE(message().find("exists; choose another --out or give --force"), std::string::npos);
  o.force = true;
  EXPECT_EQ(message(), "accepted");

  o.min_free_bytes = free_bytes(dir.path()) + (uint64_t{1} << 40);
  EXPECT_NE(message().find("disk nearly full"), std::string::npos) << message();

  o = {};
  o.out = dir.path() / "split.lcm";
  o.split_mb = 1;
  std::ofstream(dir.path() / "split.000.lcm") << "x";
  EXPECT_NE(message().find("split.000.lcm' exists"), std::string::npos) << message();
  std::ofstream(dir.path() / "split.json") << "x";
  o.out = dir.path() / "split.lcm";
  o.split_mb = 0;
  EXPECT_NE(message().find("split.json' exists"), std::string::npos) << message();
}

TEST(SidecarJson, HasTheSessionPartsAndChannelsWithNamesEscaped) {
  SessionInfo info;
  info.version = "0.1.0";
  info.host = "lab-pc";
  info.start_utime = 1767225600000000;  // 2026-01-01T00:00:00Z
  info.end_utime = 1767225661500000;
  info.stopped_by = "SIGINT";
  std::vector<PartInfo> parts{{"/x/s.000.lcm", 10, 1000, 1, 2, true},
                              {"/x/s.001.lcm", 5, 400, 3, 4, true}};
  std::map<std::string, ChannelCount> channels{{"UWB_RANGE", {14, 800, 2}},
                                               {"bad\"name\n", {1, 10, 0}}};
  const std::string j = sidecar_json(info, parts, channels, 2, 4096);
  for (const char* want :
       {"\"start\": \"2026-01-01T00:00:00.000000Z\"", "\"end\": \"2026-01-01T00:01:01.500000Z\"",
        "\"recording\": false", "\"stopped_by\": \"SIGINT\"", "\"events\": 15",
        "\"bytes\": 1400", "\"dropped\": 2", "\"file\": \"s.001.lcm\"",
        "\"UWB_RANGE\": {\"events\": 14, \"bytes\": 800, \"dropped\": 2}",
        "\"bad\\\"name\\u000a\": {", "\"queue_peak_bytes\": 4096", "\"host\": \"lab-pc\""})
    EXPECT_NE(j.find(want), std::string::npos) << want << "\n" << j;
  info.end_utime = 0;
  info.stopped_by.clear();
  const std::string running = sidecar_json(info, {}, {}, 0, 0);
  EXPECT_NE(running.find("\"recording\": true"), std::string::npos) << running;
  EXPECT_NE(running.find("\"end\": null"), std::string::npos) << running;
  EXPECT_NE(running.find("\"parts\": []"), std::string::npos) << running;
}

RecorderOptions recorder_options(const fs::path& out) {
  RecorderOptions ro;
  ro.session.out = out;
  ro.flush_interval_s = 0.01;
  ro.info.start_utime = 1767225600000000;
  return ro;
}

TEST(Recorder, HoldsTheFirstEventsUntilSiteArrivesSoTheLogStartsWithIt) {
  TempDir dir;
  auto events = lab_events(2);
  ASSERT_EQ(events.front().channel, "SITE");
  std::rotate(events.begin(), events.begin() + 1, events.begin() + 50);  // SITE is 50th now
  Recorder r(recorder_options(dir.path() / "w.lcm"));
  for (const auto& e : events) ASSERT_TRUE(r.offer(e.channel, e.utime, e.data.data(), e.data.size()));
  r.stop("test");
  EXPECT_FALSE(r.site_missing());
  const auto log = read_log(dir.path() / "w.lcm");
  ASSERT_EQ(log.size(), events.size() + 1);
  EXPECT_TRUE(is_site(log.front()));
  EXPECT_EQ(log[50].channel, "SITE") << "the bus's SITE stays where it arrived too";
  std::ifstream sidecar(dir.path() / "w.json");
  const std::string j((std::istreambuf_iterator<char>(sidecar)), {});
  EXPECT_NE(j.find("\"events\": " + std::to_string(events.size() + 1)), std::string::npos) << j;
  EXPECT_NE(j.find("\"stopped_by\": \"test\""), std::string::npos) << j;
}

TEST(Recorder, AStopWritesEverythingReceivedAndDropsBeyondTheQueueAreCounted) {
  TempDir dir;
  auto ro = recorder_options(dir.path() / "d.lcm");
  // No SITE comes: the writer holds everything for the site wait, so the queue fills for sure.
  ro.site_wait_s = 30;
  const Event e{"IMU", 1767225600000000, std::vector<uint8_t>(200)};
  ro.queue_bytes = 100 * e.footprint();
  Recorder r(ro);
  int accepted = 0;
  for (int i = 0; i < 250; ++i) accepted += r.offer(e.channel, e.utime + i, e.data.data(), e.data.size()) ? 1 : 0;
  EXPECT_EQ(accepted, 100);
  EXPECT_EQ(r.stats().dropped, 150);
  r.stop("test");  // ends the wait: everything held is written
  EXPECT_TRUE(r.site_missing());
  EXPECT_EQ(read_log(dir.path() / "d.lcm").size(), 100u);
  EXPECT_EQ(r.stats().written, 100);
  std::ifstream sidecar(dir.path() / "d.json");
  const std::string j((std::istreambuf_iterator<char>(sidecar)), {});
  EXPECT_NE(j.find("\"IMU\": {\"events\": 100, \"bytes\": 20000, \"dropped\": 150}"),
            std::string::npos)
      << j;
}

TEST(Recorder, AFullDiskStopsTheRecordingWithTheReason) {
  // /dev/full fails every write with ENOSPC: a full disk without mounting one.
  if (access("/dev/full", W_OK) != 0 || access("/dev", W_OK) != 0)
    GTEST_SKIP() << "/dev/full or /dev not writable here";
  auto ro = recorder_options("/dev/full");
  ro.session.force = true;
  ro.site_wait_s = 0;
  TempDir dir;
  // The sidecar would be /dev/full.json: keep it out of /dev by recording under a symlink.
  fs::create_symlink("/dev/full", dir.path() / "full.lcm");
  ro.session.out = dir.path() / "full.lcm";
  Recorder r(ro);
  const Event e{"IMU", 1, std::vector<uint8_t>(1000)};
  for (int i = 0; i < 200 && !r.error(); ++i) {
    r.offer(e.channel, e.utime, e.data.data(), e.data.size());
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  r.stop("test");
  ASSERT_TRUE(r.error().has_value());
  EXPECT_NE(r.error()->find("No space left on device"), std::string::npos) << *r.error();
  std::ifstream sidecar(dir.path() / "full.json");
  const std::string j((std::istreambuf_iterator<char>(sidecar)), {});
  EXPECT_NE(j.find("\"stopped_by\": \"error: write to"), std::string::npos) << j;
}

}  // namespace
}  // namespace ips::record
