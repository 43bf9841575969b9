#pragma once
// Reads the events of an LCM log (the format of lcm-logger and lcm::LogFile) and carries on past
// damage, which liblcm's reader does not: it stops quietly at the first event header it cannot
// read. Used by every tool that reads logs (ips-export, ips-replay).
//
// The LCM log format: events back to back, each
//   u32 magic 0xEDA1DA01, i64 eventnum, i64 timestamp (us), i32 channel length, i32 data length,
//   channel bytes, data bytes
// all big-endian (LCM log file format, lcm-proj.github.io/lcm/content/log-file-format.html).
//
// Every byte of the input ends up in exactly one of: an event returned, garbage skipped, or the
// cut-short tail. The rules, in order, at an offset p where an event should start:
//   - no magic word at p: the bytes up to the next magic word are garbage;
//   - a header whose channel length is outside 0..kMaxChannelLength or whose data length is
//     outside 0..kMaxDataLength: the header is garbage, and reading resynchronises at the next
//     magic word after p;
//   - an event running past the end of the input: the end of the log is cut short (the tail),
//     unless there is a magic word after p, in which case the header was damaged (or a false
//     magic inside garbage) and the bytes up to that magic word are garbage; a header, or 1 to 3
//     bytes of a magic word, at the very end are the tail too;
//   - an event is returned when it is followed by the next event's magic word or by the end of
//     the input (or by a magic word cut short there). Followed by anything else, damage began
//     inside it (its bytes, or its length, are not what was recorded: LCM logs have no checksum,
//     so this is the only sign), and it is garbage up to the next magic word after p. Damage
//     that starts exactly at an event boundary, or in an event's magic word, therefore costs the
//     event before it too.
//
// An empty channel name is legal in LCM (liblcm publishes and logs it): such an event is returned
// like any other, and counted apart (empty_channel_events) for the tools that skip it.
//
// Memory: the reader holds one event at a time, in a buffer of chunk_bytes that grows only for
// an event larger than that, to at most kMaxEventBytes + 4 bytes, and only for bytes that exist:
// a length checked against the size of the input when known, and otherwise grown at most to
// twice what was actually read.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace ips {

// Where the log's bytes come from: a file, or bytes in memory (tests, fuzzing).
class LogByteSource {
 public:
  virtual ~LogByteSource() = default;
  // Copies up to `capacity` of the next bytes to `out`; returns how many. 0 only at the end.
  virtual size_t read(uint8_t* out, size_t capacity) = 0;
  // Number of bytes from the first read to the end, or -1 when not known (a pipe).
  virtual int64_t size() const = 0;
  // True when reading stopped because of an I/O error rather than the end of the input.
  virtual bool failed() const { return false; }
  // All of the input at once, when it is in memory as a whole (a mapped file): the reader then
  // reads it in place, without copying, and its events' bytes stay valid as long as the source.
  // Empty (a null data()) otherwise.
  virtual std::span<const uint8_t> whole() const { return {}; }
};

// Reads a std::FILE* from its current position (not owned, not closed). The size is known for a
// regular file.
class FileLogSource final : public LogByteSource {
 public:
  explicit FileLogSource(std::FILE* file);
  size_t read(uint8_t* out, size_t capacity) override;
  int64_t size() const override { return size_; }
  bool failed() const override { return failed_; }

 private:
  std::FILE* file_;
  int64_t size_ = -1;
  bool failed_ = false;
};

// A regular file mapped into memory (mmap) as a whole, read in place: a replay at the speed of
// the disk's cache. failed() after opening when the file could not be mapped (then nothing is
// read: use FileLogSource).
class MappedFileLogSource final : public LogByteSource {
 public:
  explicit MappedFileLogSource(const std::string& path);
  ~MappedFileLogSource() override;
  MappedFileLogSource(const MappedFileLogSource&) = delete;
  MappedFileLogSource& operator=(const MappedFileLogSource&) = delete;
  size_t read(uint8_t* out, size_t capacity) override;
  int64_t size() const override { return static_cast<int64_t>(size_); }
  bool failed() const override { return data_ == nullptr; }
  std::span<const uint8_t> whole() const override { return {data_, size_}; }

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  size_t pos_ = 0;
};

// Reads bytes in memory (not copied: they must outlive the source). max_read limits each read and
// size_known = false hides the size, to exercise what a pipe does; in_place offers them as
// whole(), as a mapped file does.
class MemoryLogSource final : public LogByteSource {
 public:
  explicit MemoryLogSource(std::span<const uint8_t> bytes, size_t max_read = SIZE_MAX,
                           bool size_known = true, bool in_place = false)
      : bytes_(bytes),
        max_read_(max_read == 0 ? 1 : max_read),
        size_known_(size_known),
        in_place_(in_place) {}
  size_t read(uint8_t* out, size_t capacity) override;
  int64_t size() const override { return size_known_ ? static_cast<int64_t>(bytes_.size()) : -1; }
  std::span<const uint8_t> whole() const override {
    return in_place_ ? bytes_ : std::span<const uint8_t>{};
  }

 private:
  std::span<const uint8_t> bytes_;
  size_t pos_ = 0;
  size_t max_read_;
  bool size_known_;
  bool in_place_;
};

// One event. channel and data belong to the reader and are valid until its next call to next().
struct LogEvent {
  int64_t eventnum = 0;
  int64_t timestamp_us = 0;  // the log's own time stamp (lcm-logger: receive time)
  std::string channel;
  const uint8_t* data = nullptr;
  size_t size = 0;
  int64_t offset = 0;  // of its magic word, from the start of the input
};

struct LogReadStats {
  int64_t events = 0;
  int64_t empty_channel_events = 0;  // of those, on an empty channel (legal, but no tool reads them)
  int64_t event_bytes = 0;           // headers, channels and data of the events returned
  int64_t garbage_bytes = 0;         // skipped as damaged
  int64_t resyncs = 0;               // separate runs of garbage (places the log is damaged)
  int64_t truncated_tail_bytes = 0;  // an incomplete last event: the log is cut short
  int64_t read_up_to = 0;            // bytes consumed: event_bytes + garbage + tail so far
  int64_t input_size = -1;           // the source's size when known (for a progress %)
  bool read_error = false;           // the input ended on an I/O error
};

class LogReader {
 public:
  static constexpr uint32_t kMagic = 0xEDA1DA01u;
  static constexpr size_t kHeaderBytes = 28;
  // LCM refuses to publish longer names (LCM_MAX_CHANNEL_NAME_LENGTH in lcm/lcm.h), so no
  // recorded event has one; liblcm's own reader allows up to 999.
  static constexpr int32_t kMaxChannelLength = 63;
  // LCM refuses to publish larger messages (LCM_MAX_MESSAGE_SIZE in lcm/lcm.h, 2^28 bytes).
  static constexpr int32_t kMaxDataLength = 1 << 28;
  static constexpr size_t kMaxEventBytes = kHeaderBytes + kMaxChannelLength + kMaxDataLength;

  explicit LogReader(LogByteSource& source, size_t chunk_bytes = size_t{1} << 20);
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  // The next event in file order, or nullptr once the input is used up (stats() is then final).
  const LogEvent* next();
  const LogReadStats& stats() const { return stats_; }

 private:
  struct Scan {
    int64_t skipped;  // bytes consumed looking for the magic word
    bool found;       // a magic word now starts the buffer; else fewer than 4 bytes are left
  };
  size_t avail() const { return end_ - begin_; }
  bool fill(size_t n);
  void consume(size_t n);
  bool magic_at(size_t i) const;
  // Index of the first magic word starting in [from, to) of the buffer (to + 3 <= end_), or to.
  size_t find_magic(size_t from, size_t to) const;
  Scan scan_to_magic(size_t skip_first);
  void add_garbage(int64_t start, int64_t n);
  void finish();

  LogByteSource& source_;
  size_t chunk_;
  std::vector<uint8_t> buf_;
  const uint8_t* base_ = nullptr;  // buf_'s bytes, or the source's whole() read in place
  size_t begin_ = 0, end_ = 0;     // unconsumed bytes at base_
  bool eof_ = false, done_ = false;
  int64_t last_garbage_end_ = -1;
  LogReadStats stats_;
  LogEvent event_;
};

// A log's first event's time stamp and the latest one among the events of its last tail_bytes
// (widened until it holds an event): a timeline's span without a pass over the whole file.
// Nullopt when the file holds no event. Moves the file's position.
struct LogSpan {
  int64_t first_us = 0;
  int64_t last_us = 0;
};
std::optional<LogSpan> read_log_span(std::FILE* file, int64_t tail_bytes = int64_t{1} << 22);

}  // namespace ips
