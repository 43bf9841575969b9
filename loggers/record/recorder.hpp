#pragma once
// ips-record's core, without LCM sockets: a bounded queue between the thread that receives from
// the bus and one writer thread, and the writer that puts events into standard LCM log files with
// liblcm's own log writer (the one lcm-logger uses), SITE first in every file, split by size
// and/or time, flushed on an interval, described by a JSON sidecar.
//
// Why not simply lcm-logger (docs/programs.md#ips-record): its split files do not start with
// SITE, it cannot split by time, its drop count is a line on stdout, and it does not watch the
// free space.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace lcm {
class LogFile;
}

namespace ips::record {

// A recording cannot start or go on (target not writable, disk nearly full, write failed).
struct RecordError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Event {
  std::string channel;
  int64_t utime = 0;  // receive time, as lcm-logger records it
  std::vector<uint8_t> data;
  // What the event holds in memory while it waits to be written (counted against the queue).
  size_t footprint() const { return sizeof(Event) + channel.size() + data.size(); }
};

// Never blocks the receiving thread: an event that would take the unwritten bytes past the
// capacity is dropped and counted (per channel). Bytes count as unwritten until the writer
// releases them, so events the writer holds are within the bound too.
class EventQueue {
 public:
  explicit EventQueue(size_t capacity_bytes) : capacity_(capacity_bytes) {}
  // False when the event was dropped (queue full or closed).
  bool push(Event&& e);
  // Moves every queued event to the end of `out`, waiting up to `timeout` for the first. False
  // once the queue is closed and empty.
  bool pop_all(std::vector<Event>& out, std::chrono::milliseconds timeout);
  // The writer is done with events of this many footprint bytes.
  void release(size_t bytes);
  // No more pushes; pop_all drains what is left.
  void close();

  size_t unwritten_bytes() const;
  size_t peak_bytes() const;
  int64_t dropped() const;
  std::map<std::string, int64_t> dropped_by_channel() const;

 private:
  const size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;
  std::vector<Event> events_;
  size_t unwritten_ = 0, peak_ = 0;
  int64_t dropped_ = 0;
  std::map<std::string, int64_t> dropped_by_channel_;
  bool closed_ = false;
};

struct SessionOptions {
  // The log file. When splitting, the parts are <stem>.000<ext>, <stem>.001<ext>, ...
  std::filesystem::path out;
  double split_mb = 0;  // start a new part before a part would exceed this size (0: never)
  double split_s = 0;   // start a new part after this much receive time (0: never)
  bool force = false;   // overwrite existing files
  uint64_t min_free_bytes = 0;  // refuse to start, and stop, below this much free disk space
  std::string site_channel = "SITE";
};

// The sidecar's name: the log's name with .json for its extension (session.lcm -> session.json).
std::filesystem::path sidecar_path(const std::filesystem::path& out);
// The name of part `index` (0-based) when splitting, else `out` itself.
std::filesystem::path part_path(const SessionOptions& o, int index);

// Checks before anything is written: creates the directory if missing, then refuses (RecordError
// with the path and the reason) a directory that cannot be written, files that exist (without
// force) and a file system with less than min_free_bytes available.
void preflight(const SessionOptions& o);

// Free bytes for an unprivileged writer on the file system holding `dir`.
uint64_t free_bytes(const std::filesystem::path& dir);

struct ChannelCount {
  int64_t events = 0;   // in the files, SITE heads included
  int64_t bytes = 0;    // message bytes in the files
  int64_t dropped = 0;  // never written: queue full
};

struct PartInfo {
  std::string path;
  int64_t events = 0;  // the SITE head included
  int64_t bytes = 0;   // file size
  int64_t first_utime = 0, last_utime = 0;
  bool site_head = false;  // starts with SITE
};

// Writes events into the parts of one session. Single-threaded; throws RecordError when a write
// fails or the disk is nearly full (checked at every part and every flush).
class SessionWriter {
 public:
  explicit SessionWriter(SessionOptions o);
  ~SessionWriter();
  SessionWriter(const SessionWriter&) = delete;
  SessionWriter& operator=(const SessionWriter&) = delete;

  // An encoded site_t: the head of every part opened from now on. A valid site_t written on the
  // site channel replaces it.
  void set_site(std::vector<uint8_t> site);
  bool has_site() const { return !site_.empty(); }

  // Opens or rotates to a new part when due, then appends the event.
  void write(const Event& e);
  void flush();
  void close();

  const std::vector<PartInfo>& parts() const { return parts_; }
  const std::map<std::string, ChannelCount>& channels() const { return channels_; }
  int64_t events() const { return events_; }

 private:
  void open_part(int64_t first_utime);
  void append(std::string_view channel, int64_t utime, const void* data, size_t size);
  void check_free_space() const;

  SessionOptions o_;
  std::unique_ptr<lcm::LogFile> log_;
  std::vector<uint8_t> site_;
  std::vector<PartInfo> parts_;
  std::map<std::string, ChannelCount> channels_;
  int64_t events_ = 0;
};

// What the sidecar says besides the counts.
struct SessionInfo {
  std::string program = "ips-record";
  std::string version;
  std::string host;
  std::string lcm_url;
  std::string channels_regex;
  std::string site_source;  // "file <path>", "bus", or "none"
  int64_t start_utime = 0;
  int64_t end_utime = 0;  // 0 while recording
  std::string stopped_by;  // "SIGINT", "duration", "error: ...", or empty while recording
  std::string loss_json;  // "loss": what the bus lost before us (ips::BusLoss::json()), or empty
};

// The sidecar JSON (docs/programs.md#ips-record): pure, for tests.
std::string sidecar_json(const SessionInfo& info, const std::vector<PartInfo>& parts,
                         const std::map<std::string, ChannelCount>& channels, int64_t dropped,
                         size_t queue_peak_bytes);

struct RecorderOptions {
  SessionOptions session;
  size_t queue_bytes = 64u << 20;
  double flush_interval_s = 0.1;
  // Without a site from a file, how long to hold the first events waiting for SITE on the bus
  // (so that the log starts with it). 0: do not wait.
  double site_wait_s = 3.0;
  std::vector<uint8_t> site;  // encoded site_t from --site, or empty
  SessionInfo info;
};

struct RecorderStats {
  int64_t written = 0;
  int64_t dropped = 0;
  size_t unwritten_bytes = 0;
  size_t parts = 0;
  int64_t bytes = 0;  // in all parts
};

// The queue, the writer thread and the sidecar. offer() may be called from one thread while the
// writer runs in another.
class Recorder {
 public:
  // Runs preflight() (throws RecordError) and writes the first sidecar; starts the writer thread.
  explicit Recorder(RecorderOptions o);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Never blocks; false when the event was dropped.
  bool offer(std::string_view channel, int64_t utime, const void* data, size_t size);
  // Writes everything still queued, closes the part, writes the final sidecar. Idempotent.
  void stop(const std::string& stopped_by);

  // The writer's failure (it then stops writing); empty while all is well.
  std::optional<std::string> error() const;
  RecorderStats stats() const;
  // Set once when the site wait ended without a site (for a warning by the caller).
  bool site_missing() const { return site_missing_; }
  // What the bus lost on the way to us (a JSON object): in the sidecars written from now on.
  void set_loss_json(std::string json);

 private:
  void writer_loop();
  void write_sidecar();
  SessionInfo info_with_loss() const;

  RecorderOptions o_;
  EventQueue queue_;
  SessionWriter writer_;
  std::thread thread_;
  mutable std::mutex stats_mutex_;  // guards error_ and the snapshot below
  std::optional<std::string> error_;
  RecorderStats snapshot_;
  std::map<std::string, int64_t> lost_by_channel_;  // queued when the writer failed
  std::atomic<bool> site_missing_{false};
  std::string loss_json_;  // under stats_mutex_
  bool stopped_ = false;
};

}  // namespace ips::record
