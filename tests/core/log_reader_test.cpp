// The LCM log reader: reads back what liblcm's LogFile writes, and reads on past damage, counting
// every byte of the input as an event, garbage or a cut-short tail (format: LCM's "LCM Log File
// format", lcm-proj.github.io/lcm/content/log-file-format.html).
#include "core/log_reader.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <lcm/lcm-cpp.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/log_input.hpp"

namespace ips {
namespace {

namespace fs = std::filesystem;

struct Event {
  int64_t eventnum;
  int64_t timestamp_us;
  std::string channel;
  std::vector<uint8_t> data;
  int64_t offset;
  bool operator==(const Event&) const = default;
};

struct ReadResult {
  std::vector<Event> events;
  LogReadStats stats;
};

ReadResult read_all(LogByteSource& source, size_t chunk = size_t{1} << 20) {
  LogReader reader(source, chunk);
  ReadResult r;
  while (const LogEvent* e = reader.next())
    r.events.push_back({e->eventnum, e->timestamp_us, e->channel,
                        std::vector<uint8_t>(e->data, e->data + e->size), e->offset});
  EXPECT_EQ(reader.next(), nullptr);  // stays at the end
  r.stats = reader.stats();
  return r;
}

bool same_counts(const LogReadStats& a, const LogReadStats& b) {
  return a.events == b.events && a.event_bytes == b.event_bytes &&
         a.garbage_bytes == b.garbage_bytes && a.resyncs == b.resyncs &&
         a.truncated_tail_bytes == b.truncated_tail_bytes && a.read_up_to == b.read_up_to &&
         a.empty_channel_events == b.empty_channel_events;
}

// Read through copies into the reader's buffer, and (a source of known size) in place as a
// mapped file is: both must give the same events and counts.
ReadResult read_memory(const std::vector<uint8_t>& bytes, size_t chunk = size_t{1} << 20,
                       size_t max_read = SIZE_MAX, bool size_known = true) {
  MemoryLogSource source(bytes, max_read, size_known);
  ReadResult r = read_all(source, chunk);
  if (size_known && !bytes.empty()) {
    MemoryLogSource whole(bytes, SIZE_MAX, true, true);
    const ReadResult in_place = read_all(whole, chunk);
    EXPECT_EQ(in_place.events, r.events) << "read in place";
    EXPECT_TRUE(same_counts(in_place.stats, r.stats)) << "read in place";
  }
  return r;
}

// One event in the LCM log format, built by hand (big-endian fields).
std::vector<uint8_t> event_bytes(int64_t eventnum, int64_t timestamp, int32_t channel_len,
                                 int32_t data_len, const std::string& channel,
                                 const std::vector<uint8_t>& data) {
  std::vector<uint8_t> out;
  auto put = [&](uint64_t v, int bytes) {
    for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
  };
  put(0xEDA1DA01u, 4);
  put(static_cast<uint64_t>(eventnum), 8);
  put(static_cast<uint64_t>(timestamp), 8);
  put(static_cast<uint32_t>(channel_len), 4);
  put(static_cast<uint32_t>(data_len), 4);
  out.insert(out.end(), channel.begin(), channel.end());
  out.insert(out.end(), data.begin(), data.end());
  return out;
}

// Bytes that hold no LCM magic word anywhere (a seeded generator, redrawn where one appears).
std::vector<uint8_t> garbage(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> g(n);
  for (size_t i = 0; i < n; ++i) {
    g[i] = static_cast<uint8_t>(rng());
    while (i >= 3 && g[i - 3] == 0xED && g[i - 2] == 0xA1 && g[i - 1] == 0xDA && g[i] == 0x01)
      g[i] = static_cast<uint8_t>(rng());
  }
  return g;
}

class TempLog {
 public:
  TempLog() {
    char tmpl[] = "/tmp/ips-log-reader-XXXXXX";
    const int fd = mkstemp(tmpl);
    EXPECT_GE(fd, 0);
    if (fd >= 0) close(fd);
    path_ = tmpl;
  }
  ~TempLog() { fs::remove(path_); }
  const std::string& path() const { return path_; }
  std::vector<uint8_t> bytes() const {
    std::ifstream f(path_, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  }
  void write(const std::vector<uint8_t>& bytes) const {
    std::ofstream f(path_, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  }

 private:
  std::string path_;
};

// What lcm::LogFile is given: channels of 1 to 63 bytes, empty and multi-megabyte payloads (larger
// than the reader's 1 MiB chunk), timestamps before 1970 and in 2026.
std::vector<Event> written_events() {
  std::vector<Event> ev;
  std::mt19937 rng(7);
  const std::vector<size_t> sizes = {0, 1, 27, 28, 100, 4096, 70000, 3u << 20, 5, 0, 12};
  for (size_t i = 0; i < 40; ++i) {
    Event e;
    e.eventnum = static_cast<int64_t>(i);  // LogFile numbers events from 0
    e.timestamp_us = i == 3 ? -5 : 1767225600000000 + static_cast<int64_t>(i) * 12345;
    e.channel = i == 5 ? std::string(63, 'C') : i == 6 ? "X" : "UWB_RANGE_" + std::to_string(i);
    e.data.resize(sizes[i % sizes.size()]);
    for (auto& b : e.data) b = static_cast<uint8_t>(rng() & 0x7F);  // no 0xED: no magic inside
    ev.push_back(e);
  }
  return ev;
}

std::vector<Event> write_with_lcm(const std::string& path, std::vector<Event> events) {
  lcm::LogFile log(path, "w");
  EXPECT_TRUE(log.good());
  int64_t offset = 0;
  for (auto& e : events) {
    lcm::LogEvent le;
    le.eventnum = e.eventnum;
    le.timestamp = e.timestamp_us;
    le.channel = e.channel;
    le.datalen = static_cast<int32_t>(e.data.size());
    le.data = e.data.data();
    EXPECT_EQ(log.writeEvent(&le), 0);
    e.offset = offset;
    offset += static_cast<int64_t>(28 + e.channel.size() + e.data.size());
  }
  return events;
}

int64_t event_size(const Event& e) {
  return static_cast<int64_t>(28 + e.channel.size() + e.data.size());
}

// Every byte accounted for once.
void expect_all_bytes_counted(const LogReadStats& s, size_t input_size) {
  EXPECT_EQ(s.event_bytes + s.garbage_bytes + s.truncated_tail_bytes,
            static_cast<int64_t>(input_size));
  EXPECT_EQ(s.read_up_to, static_cast<int64_t>(input_size));
  EXPECT_FALSE(s.read_error);
}

TEST(LogReader, ReadsBackWhatLcmLogFileWrote) {
  TempLog log;
  const auto want = write_with_lcm(log.path(), written_events());
  const auto bytes = log.bytes();
  std::FILE* f = std::fopen(log.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  FileLogSource source(f);
  const auto r = read_all(source);
  std::fclose(f);
  EXPECT_EQ(r.events, want);
  EXPECT_EQ(r.stats.events, static_cast<int64_t>(want.size()));
  EXPECT_EQ(r.stats.garbage_bytes, 0);
  EXPECT_EQ(r.stats.resyncs, 0);
  EXPECT_EQ(r.stats.truncated_tail_bytes, 0);
  EXPECT_EQ(r.stats.input_size, static_cast<int64_t>(bytes.size()));
  expect_all_bytes_counted(r.stats, bytes.size());
}

TEST(LogReader, SpanFromHeadAndTailIsThatOfAWholePass) {
  TempLog log;
  auto events = written_events();
  events[36].timestamp_us += 10'000'000;  // the latest is not the last: the tail's maximum counts
  const auto want = write_with_lcm(log.path(), events);
  int64_t last = want.front().timestamp_us;
  for (const auto& e : want) last = std::max(last, e.timestamp_us);
  std::FILE* f = std::fopen(log.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  // Windows that start inside an event (of 3 MiB among them) and one wider than the file.
  for (const int64_t tail :
       {int64_t{1}, int64_t{100}, int64_t{5000}, int64_t{1} << 22, int64_t{1} << 30}) {
    const auto span = read_log_span(f, tail);
    ASSERT_TRUE(span) << tail;
    EXPECT_EQ(span->first_us, want.front().timestamp_us) << tail;
    EXPECT_EQ(span->last_us, last) << tail;
  }
  std::fclose(f);
  TempLog empty;
  empty.write({0x01, 0x02, 0x03});
  f = std::fopen(empty.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(read_log_span(f));
  std::fclose(f);
}

TEST(LogReader, AMappedFileIsReadInPlaceAsStdioReadsIt) {
  TempLog log;
  const auto want = write_with_lcm(log.path(), written_events());
  MappedFileLogSource mapped(log.path());
  ASSERT_FALSE(mapped.failed());
  ASSERT_EQ(mapped.whole().size(), log.bytes().size());
  const auto r = read_all(mapped);
  EXPECT_EQ(r.events, want);
  EXPECT_EQ(r.stats.garbage_bytes, 0);
  // Through LogInput, mapped or not: the same events, and their bytes stay valid while mapped.
  for (const bool map : {false, true}) {
    auto in = LogInput::open("test", log.path(), map);
    ASSERT_NE(in, nullptr);
    std::vector<const uint8_t*> kept;
    size_t i = 0;
    while (const LogEvent* e = in->next()) {
      ASSERT_LT(i, want.size());
      EXPECT_EQ(e->channel, want[i].channel);
      EXPECT_EQ(std::vector<uint8_t>(e->data, e->data + e->size), want[i].data);
      if (map) kept.push_back(e->data);
      ++i;
    }
    EXPECT_EQ(i, want.size());
    for (size_t k = 0; k < kept.size(); ++k) {
      if (want[k].data.empty()) continue;
      EXPECT_EQ(std::memcmp(kept[k], want[k].data.data(), want[k].data.size()), 0) << k;
    }
  }
  // An empty file cannot be mapped: failed(), and LogInput reads it through stdio instead.
  TempLog empty;
  MappedFileLogSource none(empty.path());
  EXPECT_TRUE(none.failed());
  auto in = LogInput::open("test", empty.path(), true);
  ASSERT_NE(in, nullptr);
  EXPECT_EQ(in->next(), nullptr);
}

// Expected events: `want` without those numbered in `lost`, shifted by `inserted` bytes from
// event `from` on.
std::vector<Event> without(const std::vector<Event>& want, std::vector<size_t> lost, size_t from,
                           int64_t inserted) {
  std::vector<Event> out;
  for (size_t i = 0; i < want.size(); ++i) {
    if (std::find(lost.begin(), lost.end(), i) != lost.end()) continue;
    out.push_back(want[i]);
    if (i >= from) out.back().offset += inserted;
  }
  return out;
}

TEST(LogReader, GarbageInsideAnEventCostsThatEventAndEverythingAfterIsRead) {
  TempLog log;
  const auto want = write_with_lcm(log.path(), written_events());
  auto bytes = log.bytes();
  // 3000 bytes into event 21's data (28 + 12 channel bytes + 12 data bytes): what a damaged
  // stretch of a disk does. The event's bytes and the garbage are skipped, nothing else.
  const size_t at = static_cast<size_t>(want[21].offset) + 45;
  const auto g = garbage(3000, 1);
  bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(at), g.begin(), g.end());
  const auto r = read_memory(bytes);
  EXPECT_EQ(r.events, without(want, {21}, 22, 3000));
  EXPECT_EQ(r.stats.garbage_bytes, event_size(want[21]) + 3000);
  EXPECT_EQ(r.stats.resyncs, 1);
  EXPECT_EQ(r.stats.truncated_tail_bytes, 0);
  expect_all_bytes_counted(r.stats, bytes.size());
}

TEST(LogReader, GarbageAtAnEventBoundaryCostsTheEventBeforeIt) {
  TempLog log;
  const auto want = write_with_lcm(log.path(), written_events());
  auto bytes = log.bytes();
  // Event 19 is intact but followed by no magic word: nothing tells it from one whose end was
  // damaged, so it is skipped with the garbage.
  const auto g = garbage(3000, 1);
  bytes.insert(bytes.begin() + want[20].offset, g.begin(), g.end());
  const auto r = read_memory(bytes);
  EXPECT_EQ(r.events, without(want, {19}, 20, 3000));
  EXPECT_EQ(r.stats.garbage_bytes, event_size(want[19]) + 3000);
  EXPECT_EQ(r.stats.resyncs, 1);
  expect_all_bytes_counted(r.stats, bytes.size());
}

TEST(LogReader, GarbageInsideAnEventHeaderLosesThatEventOnly) {
  TempLog log;
  const auto want = write_with_lcm(log.path(), written_events());
  auto bytes = log.bytes();
  // 0xFF bytes 10 bytes into event 12: its channel length reads as -1.
  const size_t at = static_cast<size_t>(want[12].offset) + 10;
  bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(at), 500, 0xFF);
  const auto r = read_memory(bytes);
  ASSERT_EQ(r.events.size(), want.size() - 1);
  for (size_t i = 0; i + 1 < want.size(); ++i) {
    Event w = want[i < 12 ? i : i + 1];
    if (i >= 12) w.offset += 500;
    EXPECT_EQ(r.events[i], w) << "event " << i;
  }
  EXPECT_EQ(r.stats.garbage_bytes, event_size(want[12]) + 500);
  EXPECT_EQ(r.stats.resyncs, 1);
  expect_all_bytes_counted(r.stats, bytes.size());
}

TEST(LogReader, FalseMagicInGarbageWithAHugeDataLengthIsSkipped) {
  const auto e1 = event_bytes(0, 100, 4, 3, "IMU1", {1, 2, 3});
  const auto e2 = event_bytes(1, 200, 4, 2, "BARO", {4, 5});
  // Garbage holding a magic word and a header whose data length is 2^31 - 1 (and, after it, one
  // whose length is LCM's largest, 2^28, running past the end of the input).
  auto bad = garbage(100, 2);
  const auto false1 = event_bytes(7, 7, 5, 0x7FFFFFFF, "GHOST", {});
  const auto false2 = event_bytes(8, 8, 5, 1 << 28, "GHOST", {9, 9, 9});
  bad.insert(bad.begin() + 40, false1.begin(), false1.end());
  bad.insert(bad.end(), false2.begin(), false2.end());
  bad.insert(bad.end(), 17, 0x00);
  std::vector<uint8_t> bytes = e1;
  bytes.insert(bytes.end(), bad.begin(), bad.end());
  bytes.insert(bytes.end(), e2.begin(), e2.end());
  for (bool size_known : {true, false}) {
    const auto r = read_memory(bytes, 64, SIZE_MAX, size_known);
    ASSERT_EQ(r.events.size(), 1u) << size_known;  // e1 is followed by garbage: skipped too
    EXPECT_EQ(r.events[0].channel, "BARO");
    EXPECT_EQ(r.events[0].data, (std::vector<uint8_t>{4, 5}));
    EXPECT_EQ(r.stats.garbage_bytes, static_cast<int64_t>(e1.size() + bad.size()));
    EXPECT_EQ(r.stats.resyncs, 1);
    expect_all_bytes_counted(r.stats, bytes.size());
  }
}

TEST(LogReader, HeaderWhoseLengthSwallowsTheNextEventIsGarbage) {
  const auto e1 = event_bytes(0, 100, 4, 3, "IMU1", {1, 2, 3});
  // A length bit flipped: claims 40 data bytes, holds 2, so it would swallow e2's header.
  const auto damaged = event_bytes(1, 150, 4, 40, "BARO", {4, 5});
  const auto e2 = event_bytes(2, 200, 4, 30, "TRUT", std::vector<uint8_t>(30, 6));
  std::vector<uint8_t> bytes = e1;
  bytes.insert(bytes.end(), damaged.begin(), damaged.end());
  bytes.insert(bytes.end(), e2.begin(), e2.end());
  const auto r = read_memory(bytes);
  ASSERT_EQ(r.events.size(), 2u);
  EXPECT_EQ(r.events[1].channel, "TRUT");
  EXPECT_EQ(r.stats.garbage_bytes, static_cast<int64_t>(damaged.size()));
  expect_all_bytes_counted(r.stats, bytes.size());
}

TEST(LogReader, ChannelLengthsOutsideLcmsLimitAreGarbageAnEmptyChannelIsAnEvent) {
  const auto ok = event_bytes(0, 1, 63, 1, std::string(63, 'A'), {1});
  const auto too_long = event_bytes(1, 2, 64, 1, std::string(64, 'B'), {2});
  const auto negative = event_bytes(2, 3, -1, 1, "", {3});
  const auto empty = event_bytes(3, 4, 0, 1, "", {4});
  const auto last = event_bytes(4, 5, 1, 0, "Z", {});
  std::vector<uint8_t> bytes = ok;
  for (const auto* e : {&too_long, &negative, &empty, &last})
    bytes.insert(bytes.end(), e->begin(), e->end());
  const auto r = read_memory(bytes);
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(r.events[0].channel, std::string(63, 'A'));
  EXPECT_EQ(r.events[1].channel, "");
  EXPECT_EQ(r.events[1].data, std::vector<uint8_t>{4});
  EXPECT_EQ(r.events[2].channel, "Z");
  EXPECT_EQ(r.stats.empty_channel_events, 1);
  EXPECT_EQ(r.stats.garbage_bytes, static_cast<int64_t>(too_long.size() + negative.size()));
  EXPECT_EQ(r.stats.resyncs, 1);  // one damaged stretch
  expect_all_bytes_counted(r.stats, bytes.size());
}

// An empty channel name is legal LCM: liblcm's own writer logs it. The reader returns it as an
// event; LogInput (what the tools read through) skips it, counts it and says so, not as damage.
TEST(LogInput, EventsOnAnEmptyChannelAreCountedAndSkippedNotDamage) {
  TempLog log;
  {
    lcm::LogFile w(log.path(), "w");
    ASSERT_TRUE(w.good());
    uint8_t payload[3] = {1, 2, 3};
    int n = 0;
    for (const char* channel : {"IMU", "", "IMU", "", "", "POSE"}) {
      lcm::LogEvent e;
      e.eventnum = n;
      e.timestamp = 1000 + n++;
      e.channel = channel;
      e.datalen = sizeof payload;
      e.data = payload;
      ASSERT_EQ(w.writeEvent(&e), 0);
    }
  }
  FILE* f = std::fopen(log.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  FileLogSource source(f);
  const auto all = read_all(source);
  std::fclose(f);
  EXPECT_EQ(all.events.size(), 6u);
  EXPECT_EQ(all.stats.empty_channel_events, 3);
  EXPECT_EQ(all.stats.garbage_bytes, 0);

  auto in = LogInput::open("ips-test", log.path());
  ASSERT_NE(in, nullptr);
  std::vector<std::string> channels;
  while (const LogEvent* e = in->next()) channels.push_back(e->channel);
  EXPECT_EQ(channels, (std::vector<std::string>{"IMU", "IMU", "POSE"}));
  testing::internal::CaptureStderr();
  EXPECT_TRUE(in->finish("done"));
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_EQ(err, "ips-test: " + log.path() +
                     ": 3 events on an empty channel, skipped (legal in LCM; no channel to read "
                     "them by)\n");
  EXPECT_EQ(in->stats().garbage_bytes, 0);
  EXPECT_EQ(in->stats().events, 6);
}

TEST(LogReader, LogCutAtEveryByteOfItsLastEventGivesTheEventsBeforeAndTheTail) {
  TempLog log;
  auto events = written_events();
  events.resize(11);           // the last one holds 12 bytes of data
  events[7].data.resize(100);  // and none is large: this reads the log 2 * 53 times
  const auto want = write_with_lcm(log.path(), events);
  const auto full = log.bytes();
  const size_t last = static_cast<size_t>(want.back().offset);
  for (size_t cut = last; cut < full.size(); ++cut) {
    const std::vector<uint8_t> bytes(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut));
    for (bool size_known : {true, false}) {
      const auto r = read_memory(bytes, size_known ? size_t{1} << 20 : 5, 3, size_known);
      ASSERT_EQ(r.events.size(), want.size() - 1) << "cut at " << cut;
      EXPECT_EQ(r.events.back(), want[want.size() - 2]);
      EXPECT_EQ(r.stats.truncated_tail_bytes, static_cast<int64_t>(cut - last)) << "cut " << cut;
      EXPECT_EQ(r.stats.garbage_bytes, 0) << "cut at " << cut;
      expect_all_bytes_counted(r.stats, bytes.size());
    }
  }
}

TEST(LogReader, EmptyInputHasNothing) {
  const auto r = read_memory({});
  EXPECT_TRUE(r.events.empty());
  EXPECT_EQ(r.stats.garbage_bytes, 0);
  EXPECT_EQ(r.stats.truncated_tail_bytes, 0);
  EXPECT_EQ(r.stats.input_size, 0);
  expect_all_bytes_counted(r.stats, 0);
}

TEST(LogReader, InputWithoutAnyMagicWordIsAllGarbage) {
  const std::string text = "just text, not a log\n";
  const std::vector<uint8_t> bytes(text.begin(), text.end());
  const auto r = read_memory(bytes);
  EXPECT_TRUE(r.events.empty());
  EXPECT_EQ(r.stats.garbage_bytes, static_cast<int64_t>(bytes.size()));
  EXPECT_EQ(r.stats.resyncs, 1);
  EXPECT_EQ(r.stats.truncated_tail_bytes, 0);
  expect_all_bytes_counted(r.stats, bytes.size());
  const auto g = garbage(100000, 3);
  const auto rg = read_memory(g, 4096, 1000, false);
  EXPECT_TRUE(rg.events.empty());
  EXPECT_EQ(rg.stats.garbage_bytes, 100000);
  EXPECT_EQ(rg.stats.resyncs, 1);
}

TEST(LogReader, FileAndMemorySourcesAgreeWhateverTheChunkAndReadSizes) {
  TempLog log;
  const auto events = write_with_lcm(log.path(), written_events());
  auto bytes = log.bytes();
  auto g1 = garbage(777, 4);
  const auto g2 = garbage(50, 5);
  g1.front() = g1.back() = 0x55;  // no magic word across its edges either
  bytes.insert(bytes.begin() + events[30].offset + 3, g1.begin(), g1.end());
  bytes.insert(bytes.begin() + events[8].offset, g2.begin(), g2.end());
  bytes.resize(bytes.size() - 9);  // and cut short
  log.write(bytes);

  std::FILE* f = std::fopen(log.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  FileLogSource file_source(f);
  const auto from_file = read_all(file_source);
  std::fclose(f);
  // Lost: 7 (followed by g2), 29 (followed by a broken magic word), 30 (broken), 39 (cut).
  std::vector<int64_t> numbers, want_numbers;
  for (const auto& e : from_file.events) numbers.push_back(e.eventnum);
  for (const auto& e : without(events, {7, 29, 30, 39}, 0, 0)) want_numbers.push_back(e.eventnum);
  EXPECT_EQ(numbers, want_numbers);
  EXPECT_EQ(from_file.stats.garbage_bytes,
            event_size(events[7]) + 50 + event_size(events[29]) + event_size(events[30]) + 777);
  EXPECT_EQ(from_file.stats.resyncs, 2);
  EXPECT_EQ(from_file.stats.truncated_tail_bytes, event_size(events.back()) - 9);
  expect_all_bytes_counted(from_file.stats, bytes.size());

  for (size_t chunk : {size_t{1}, size_t{7}, size_t{4096}, size_t{1} << 20}) {
    for (size_t max_read : {size_t{1}, size_t{13}, SIZE_MAX}) {
      if (chunk == 1 && max_read == SIZE_MAX) continue;
      for (bool size_known : {true, false}) {
        if (chunk == 1 && !size_known) continue;  // byte by byte through 3 MiB events: slow
        const auto m = read_memory(bytes, chunk, max_read, size_known);
        EXPECT_EQ(m.events, from_file.events) << chunk << " " << max_read << " " << size_known;
        LogReadStats s = m.stats, want = from_file.stats;
        s.input_size = want.input_size = 0;
        EXPECT_EQ(s.events, want.events);
        EXPECT_EQ(s.garbage_bytes, want.garbage_bytes);
        EXPECT_EQ(s.resyncs, want.resyncs);
        EXPECT_EQ(s.truncated_tail_bytes, want.truncated_tail_bytes);
        EXPECT_EQ(s.read_up_to, want.read_up_to);
      }
    }
  }
}

TEST(LogReader, FileSourceReadsFromTheCurrentPosition) {
  TempLog log;
  auto bytes = event_bytes(0, 1, 1, 2, "A", {1, 2});
  const auto e2 = event_bytes(1, 2, 1, 2, "B", {3, 4});
  bytes.insert(bytes.end(), e2.begin(), e2.end());
  log.write(bytes);
  std::FILE* f = std::fopen(log.path().c_str(), "rb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(std::fseek(f, 31, SEEK_SET), 0);
  FileLogSource source(f);
  EXPECT_EQ(source.size(), 31);
  const auto r = read_all(source);
  std::fclose(f);
  ASSERT_EQ(r.events.size(), 1u);
  EXPECT_EQ(r.events[0].channel, "B");
  EXPECT_EQ(r.events[0].offset, 0);
}

}  // namespace
}  // namespace ips
