// ips-record's core: the bounded queue drops and counts instead of blocking, every part starts
// with SITE, parts split by size and by time without losing or reordering an event, a stop writes
// everything received, refusals say why, and a full disk pauses the recording (the log cut back
// to its last complete event, the sidecar saying so) until space returns, the gap counted.
#include "loggers/record/recorder.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <ips/site_t.hpp>
#include <lcm/lcm-cpp.hpp>

#include "core/log_reader.hpp"
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

std::string read_text(const fs::path& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

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
  EXPECT_NE(j.find("\"IMU\": {\"events\": 100, \"bytes\": 20000, \"dropped\": 150, \"lost_disk\": 0}"),
            std::string::npos)
      << j;
}

TEST(Recorder, DevFullPausesTheRecordingWithTheReasonInsteadOfEndingIt) {
  // /dev/full fails every write with ENOSPC: a full disk without mounting one.
  if (access("/dev/full", W_OK) != 0)
    GTEST_SKIP() << "/dev/full not writable here";
  TempDir dir;
  // The sidecar would be /dev/full.json: keep it out of /dev by recording under a symlink.
  fs::create_symlink("/dev/full", dir.path() / "full.lcm");
  auto ro = recorder_options(dir.path() / "full.lcm");
  ro.session.force = true;
  ro.site_wait_s = 0;
  ro.disk_poll_s = 3600;  // stays paused for the test
  Recorder r(ro);
  const Event e{"IMU", 1, std::vector<uint8_t>(1000)};
  int offered = 0;
  for (int i = 0; i < 5000 && !r.stats().paused; ++i, ++offered) {
    r.offer(e.channel, e.utime, e.data.data(), e.data.size());
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ASSERT_TRUE(r.stats().paused);
  EXPECT_NE(r.stats().pause.reason.find("No space left on device"), std::string::npos)
      << r.stats().pause.reason;
  r.stop("test");
  EXPECT_FALSE(r.error().has_value()) << *r.error();
  EXPECT_EQ(r.stats().written, 0);
  EXPECT_EQ(r.stats().lost_disk, offered);
  const std::string j = read_text(dir.path() / "full.json");
  EXPECT_NE(j.find("\"stopped_by\": \"test\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"reason\": \"disk full (No space left on device)\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"lost\": " + std::to_string(offered)), std::string::npos) << j;
}

TEST(DiskState, PausesCountsLossesPollsAtItsRateAndResumesWithEnoughSpace) {
  DiskState d(1000, 1.0);
  EXPECT_FALSE(d.paused());
  d.pause(10'000'000, "disk full (No space left on device)", {{"IMU", 3}});
  EXPECT_TRUE(d.paused());
  d.lose("IMU");
  d.lose("UWB_RANGE", 2);
  d.pause(10'100'000, "write error (again)", {{"IMU", 1}});  // still the same pause
  ASSERT_EQ(d.pauses().size(), 1u);
  EXPECT_EQ(d.pauses()[0].reason, "disk full (No space left on device)");
  EXPECT_EQ(d.pauses()[0].lost, 7);
  EXPECT_FALSE(d.poll_due(10'500'000)) << "polls at most once a second";
  EXPECT_TRUE(d.poll_due(11'000'000));
  EXPECT_FALSE(d.try_resume(11'000'000, 999)) << "not enough space yet";
  EXPECT_TRUE(d.paused());
  EXPECT_FALSE(d.poll_due(11'900'000));
  EXPECT_TRUE(d.try_resume(12'000'000, 1000));
  EXPECT_FALSE(d.paused());
  EXPECT_EQ(d.pauses()[0].start_utime, 10'000'000);
  EXPECT_EQ(d.pauses()[0].end_utime, 12'000'000);
  EXPECT_FALSE(d.poll_due(20'000'000)) << "nothing to poll while recording";
  d.pause(30'000'000, "disk quota exceeded (Disk quota exceeded)", {});
  d.lose("IMU");
  ASSERT_EQ(d.pauses().size(), 2u);
  EXPECT_EQ(d.pauses()[1].lost, 1);
  EXPECT_EQ(d.lost(), 8);
  EXPECT_EQ(d.lost_by_channel().at("IMU"), 6);
  EXPECT_EQ(d.lost_by_channel().at("UWB_RANGE"), 2);
  const std::string j = sidecar_json(SessionInfo{}, {}, {{"IMU", {5, 50, 0}}}, 0, 0, &d);
  for (const char* want :
       {"\"state\": \"paused\"", "\"recording\": false",
        "\"paused\": {\"reason\": \"disk quota exceeded (Disk quota exceeded)\", \"since_utime\": "
        "30000000, \"since\": \"1970-01-01T00:00:30.000000Z\", \"not_written\": 1}",
        "\"lost\": 8, \"pauses\": [",
        "{\"reason\": \"disk full (No space left on device)\", \"start_utime\": 10000000, "
        "\"start\": \"1970-01-01T00:00:10.000000Z\", \"end_utime\": 12000000, \"end\": "
        "\"1970-01-01T00:00:12.000000Z\", \"lost\": 7}",
        "\"end_utime\": null, \"end\": null, \"lost\": 1}",
        "\"IMU\": {\"events\": 5, \"bytes\": 50, \"dropped\": 0, \"lost_disk\": 6}"})
    EXPECT_NE(j.find(want), std::string::npos) << want << "\n" << j;
}

// write(2) that takes at most `room` more bytes (a partial write, then ENOSPC), like a disk
// filling up.
struct FillingDisk {
  std::shared_ptr<std::atomic<int64_t>> room = std::make_shared<std::atomic<int64_t>>(INT64_MAX);
  void install(SessionOptions& o) const {
    auto r = room;
    o.write_fn = [r](int fd, const void* data, size_t size) -> ssize_t {
      const int64_t left = r->load();
      if (left <= 0) {
        errno = ENOSPC;
        return -1;
      }
      const size_t n = std::min<size_t>(size, static_cast<size_t>(left));
      const ssize_t w = ::write(fd, data, n);
      if (w > 0) *r -= w;
      return w;
    };
    o.free_bytes_fn = [r](const fs::path&) -> uint64_t {
      return r->load() > (int64_t{1} << 40) ? uint64_t{1} << 40 : static_cast<uint64_t>(std::max<int64_t>(0, r->load()));
    };
  }
};

LogReadStats read_stats(const fs::path& path, std::vector<std::string>* channels = nullptr) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  EXPECT_NE(f, nullptr) << path;
  FileLogSource source(f);
  LogReader reader(source);
  while (const LogEvent* e = reader.next())
    if (channels) channels->push_back(e->channel);
  const LogReadStats s = reader.stats();
  std::fclose(f);
  return s;
}

TEST(SessionWriter, AWriteCutShortByAFullDiskLeavesTheLogEndingOnItsLastCompleteEvent) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "f.lcm";
  FillingDisk disk;
  disk.install(o);
  const auto events = lab_events(5);
  ASSERT_GT(events.size(), 400u);
  SessionWriter w(o);
  for (size_t i = 0; i < 100; ++i) w.write(events[i]);
  w.flush();
  const int64_t flushed = w.parts().back().bytes;
  // Room for a little more than 150 bytes: the next write-out stops inside an event.
  *disk.room = 150;
  std::map<std::string, int64_t> lost;
  size_t i = 100;
  try {
    for (; i < 300; ++i) w.write(events[i]);
    w.flush();
    FAIL() << "no DiskFullError";
  } catch (const DiskFullError& e) {
    EXPECT_NE(e.reason.find("No space left on device"), std::string::npos) << e.reason;
    lost = e.lost;
  }
  int64_t n_lost = 0;
  for (const auto& [ch, n] : lost) n_lost += n;
  // Everything handed to the writer is either in the file or counted as lost.
  EXPECT_EQ(w.events() + n_lost, static_cast<int64_t>(i)) << "written " << w.events();
  EXPECT_GT(n_lost, 0);
  const fs::path path = dir.path() / "f.lcm";
  EXPECT_EQ(static_cast<int64_t>(fs::file_size(path)), w.parts().back().bytes);
  EXPECT_GT(w.parts().back().bytes, flushed);
  EXPECT_LE(w.parts().back().bytes, flushed + 150);
  LogReadStats s = read_stats(path);
  EXPECT_EQ(s.garbage_bytes, 0);
  EXPECT_EQ(s.truncated_tail_bytes, 0);
  EXPECT_EQ(s.events, w.events());
  EXPECT_EQ(w.parts().back().last_utime, events[static_cast<size_t>(w.events() - 1)].utime);
  // Space again: the next write appends to the same file, which stays one valid log.
  *disk.room = INT64_MAX;
  const int64_t before = w.events();
  for (size_t k = i + 1; k < 400; ++k) w.write(events[k]);
  w.close();
  ASSERT_EQ(w.parts().size(), 1u);
  EXPECT_EQ(w.events(), before + static_cast<int64_t>(400 - i - 1));
  std::vector<std::string> channels;
  s = read_stats(path, &channels);
  EXPECT_EQ(s.garbage_bytes, 0);
  EXPECT_EQ(s.truncated_tail_bytes, 0);
  EXPECT_EQ(s.events, w.events());
  EXPECT_EQ(static_cast<int64_t>(fs::file_size(path)), w.parts().back().bytes);
  int64_t counted = 0;
  for (const auto& [ch, c] : w.channels()) counted += c.events;
  EXPECT_EQ(counted, w.events());
  // liblcm's own reader agrees, event numbers and all.
  EXPECT_EQ(static_cast<int64_t>(read_log(path).size()), w.events());
}

TEST(SessionWriter, BelowMinFreeItPausesWithoutLosingWhatWasWritten) {
  TempDir dir;
  SessionOptions o;
  o.out = dir.path() / "m.lcm";
  o.min_free_bytes = 1000;
  FillingDisk disk;
  disk.install(o);
  const auto events = lab_events(2);
  SessionWriter w(o);
  for (size_t i = 0; i < 50; ++i) w.write(events[i]);
  // Room for everything buffered and the next event, then below the minimum a few events later
  // (sized from the events, so that a larger SITE in the lab scenario does not make it a write
  // error instead).
  int64_t buffered = 0;
  for (size_t k = 0; k <= 50; ++k)
    buffered += 28 + static_cast<int64_t>(events[k].channel.size() + events[k].data.size());
  *disk.room = buffered + 1500;
  bool paused = false;
  size_t i = 50;
  for (; i < events.size() && !paused; ++i) {
    try {
      w.write(events[i]);
      w.flush();
    } catch (const DiskFullError& e) {
      paused = true;
      EXPECT_NE(e.reason.find("disk nearly full"), std::string::npos) << e.reason;
      EXPECT_TRUE(e.lost.empty());
    }
  }
  ASSERT_TRUE(paused);
  EXPECT_EQ(w.events(), static_cast<int64_t>(i));
  EXPECT_EQ(read_stats(o.out).events, w.events());
  // Still below: a try to resume pauses again (and does not take the file for someone else's).
  EXPECT_THROW(w.write(events[i]), DiskFullError);
  EXPECT_THROW(w.write(events[i]), DiskFullError);
  *disk.room = INT64_MAX;
  for (size_t k = i; k < i + 10; ++k) w.write(events[k]);
  w.close();
  ASSERT_EQ(w.parts().size(), 1u);
  EXPECT_EQ(read_stats(o.out).events, w.events());
  EXPECT_EQ(w.events(), static_cast<int64_t>(i + 10));
}

TEST(Recorder, AFullDiskPausesThenRecordingResumesByItselfWithTheGapCounted) {
  TempDir dir;
  auto ro = recorder_options(dir.path() / "p.lcm");
  ro.site_wait_s = 0;
  ro.disk_poll_s = 0.05;
  ro.resume_margin_bytes = 4096;
  FillingDisk disk;
  disk.install(ro.session);
  Recorder r(ro);
  const auto wait_for = [&](auto cond) {
    for (int k = 0; k < 2000 && !cond(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return cond();
  };
  const Event e{"IMU", 1767225600000000, std::vector<uint8_t>(100)};
  int64_t offered = 0;
  const auto offer = [&] {
    ASSERT_TRUE(r.offer(e.channel, e.utime + offered, e.data.data(), e.data.size()));
    ++offered;
  };
  for (int k = 0; k < 100; ++k) offer();
  ASSERT_TRUE(wait_for([&] { return r.stats().written == 100; }));
  *disk.room = 0;
  // Offered until the writer finds the disk full.
  ASSERT_TRUE(wait_for([&] {
    offer();
    return r.stats().paused;
  }));
  const auto paused = r.stats();
  EXPECT_EQ(paused.pause.reason, "disk full (No space left on device)");
  EXPECT_GT(paused.pause.start_utime, 0);
  EXPECT_EQ(paused.pause.end_utime, 0);
  for (int k = 0; k < 20; ++k) offer();  // lost: the disk is full
  ASSERT_TRUE(wait_for([&] { return r.stats().lost_disk + r.stats().written == offered; }));
  EXPECT_TRUE(r.stats().paused);
  // The sidecar says so (written in place or whole: the test's disk refuses only the log).
  ASSERT_TRUE(wait_for([&] {
    const std::string j = read_text(dir.path() / "p.json");
    return j.find("\"state\": \"paused\"") != std::string::npos &&
           j.find("\"not_written\": " + std::to_string(r.stats().lost_disk)) != std::string::npos;
  })) << read_text(dir.path() / "p.json");
  const int64_t lost = r.stats().lost_disk;
  EXPECT_GE(lost, 20);
  // Space returns: recording resumes by itself.
  *disk.room = INT64_MAX;
  ASSERT_TRUE(wait_for([&] { return !r.stats().paused; }));
  for (int k = 0; k < 50; ++k) offer();
  ASSERT_TRUE(wait_for([&] { return r.stats().written + r.stats().lost_disk == offered; }));
  r.stop("test");
  const auto s = r.stats();
  EXPECT_EQ(s.lost_disk, lost);
  EXPECT_EQ(s.pauses, 1);
  EXPECT_GT(s.pause.end_utime, s.pause.start_utime);
  EXPECT_EQ(s.written + s.lost_disk, offered);
  const LogReadStats rs = read_stats(dir.path() / "p.lcm");
  EXPECT_EQ(rs.events, s.written);
  EXPECT_EQ(rs.garbage_bytes, 0);
  EXPECT_EQ(rs.truncated_tail_bytes, 0);
  const std::string j = read_text(dir.path() / "p.json");
  for (const std::string& want :
       {std::string("\"state\": \"stopped\""), std::string("\"paused\": null"),
        "\"lost\": " + std::to_string(lost) + ", \"pauses\": [",
        "\"IMU\": {\"events\": " + std::to_string(s.written) + ", \"bytes\": " +
            std::to_string(s.written * 100) + ", \"dropped\": 0, \"lost_disk\": " +
            std::to_string(lost) + "}",
        "\"end_utime\": " + std::to_string(s.pause.end_utime)})
    EXPECT_NE(j.find(want), std::string::npos) << want << "\n" << j;
}

TEST(SidecarFile, IsPaddedSoThatWithoutRoomForANewFileItIsRewrittenInPlace) {
  TempDir dir;
  const fs::path path = dir.path() / "s.json";
  ASSERT_EQ(write_sidecar_file(path, "{\"a\": 1}\n"), "");
  const auto size = fs::file_size(path);
  EXPECT_EQ(size % 4096, 0u);
  EXPECT_GE(size, 4096u + 9);
  EXPECT_EQ(read_text(path).substr(0, 9), "{\"a\": 1}\n");
  // No new file can be made (here: its name is taken by a directory; on a full disk: no space).
  fs::create_directory(dir.path() / "s.json.tmp");
  const std::string longer = "{\"a\": 2, \"b\": \"" + std::string(3000, 'x') + "\"}\n";
  ASSERT_EQ(write_sidecar_file(path, longer), "");
  EXPECT_EQ(fs::file_size(path), size) << "in place, no new bytes";
  const std::string text = read_text(path);
  EXPECT_EQ(text.substr(0, longer.size()), longer);
  EXPECT_EQ(text.find_first_not_of(" \n", longer.size()), std::string::npos);
  // Longer than the room left: it says so, and the old one stays whole.
  const std::string err = write_sidecar_file(path, std::string(size + 10, ' '));
  EXPECT_NE(err.find("no room left"), std::string::npos) << err;
  EXPECT_EQ(read_text(path), text);
}

}  // namespace
}  // namespace ips::record
