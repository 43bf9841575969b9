#pragma once
// ips-record's core, without LCM sockets: a bounded queue between the thread that receives from
// the bus and one writer thread, and the writer that puts events into standard LCM log files (the
// lcm_eventlog format, written with write(2) so that what reached the disk is known exactly),
// SITE first in every file, split by size and/or time, flushed on an interval, described by a
// JSON sidecar. A full disk pauses the recording (the log is cut back to its last complete event)
// and it resumes by itself when space returns; the gap is counted.
//
// Why not simply lcm-logger (docs/programs.md#ips-record): its split files do not start with
// SITE, it cannot split by time, its drop count is a line on stdout, and it does not watch the
// free space.
#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace ips::record {

// A recording cannot start or go on (target not writable, disk nearly full, write failed).
struct RecordError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A write that the disk refused for want of space or because of the device (ENOSPC, EDQUOT, EIO),
// or free space below --min-free-mb: the recorder pauses and resumes when space returns. The part
// being written was cut back to its last complete event and closed; `lost` are the events that
// had been handed to the writer but are not in it (per channel).
struct DiskFullError : RecordError {
  DiskFullError(const std::string& what, std::string reason_, std::map<std::string, int64_t> lost_)
      : RecordError(what), reason(std::move(reason_)), lost(std::move(lost_)) {}
  std::string reason;  // "disk full (No space left on device)", "disk nearly full (...)", ...
  std::map<std::string, int64_t> lost;
};

// True for the errno values that pause rather than end a recording: ENOSPC, EDQUOT, EIO.
bool pauses_recording(int err);

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
  uint64_t min_free_bytes = 0;  // refuse to start, and pause, below this much free disk space
  std::string site_channel = "SITE";
  // For tests: replace write(2) and the free-space query (a full disk without mounting one).
  std::function<ssize_t(int fd, const void* data, size_t size)> write_fn;
  std::function<uint64_t(const std::filesystem::path& dir)> free_bytes_fn;
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

class PartFile;

// Writes events into the parts of one session. Single-threaded. Events are buffered (up to 256
// KiB) and written with write(2) at every flush. Throws DiskFullError when the disk refuses a
// write (or is below min_free_bytes, checked at every part and every flush): the part is then cut
// back to its last complete event and closed, and the counts are those of what is in it. The
// next write() after that reopens the part to append to it (or starts the next one when it is
// due), so the caller decides when to resume. Any other failure is a RecordError.
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
  // Writes the buffer out and syncs it to the disk, then checks the free space.
  void flush();
  void close();
  // Free bytes on the file system of the log (through free_bytes_fn when given).
  uint64_t free_space() const;

  const std::vector<PartInfo>& parts() const { return parts_; }
  const std::map<std::string, ChannelCount>& channels() const { return channels_; }
  int64_t events() const { return events_; }

 private:
  void open_part(int64_t first_utime);
  bool reopen_part();
  void append(std::string_view channel, int64_t utime, const void* data, size_t size);
  void write_out();
  void check_free_space();
  // After the part file failed: takes the lost events out of the counts, closes the part, throws.
  [[noreturn]] void fail_part(int err);

  SessionOptions o_;
  std::unique_ptr<PartFile> log_;
  bool reopen_ = false;  // the last part was closed by a full disk: append to it when resuming
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

// One pause of the recording for want of disk space.
struct Pause {
  std::string reason;       // "disk full (No space left on device)", ...
  int64_t start_utime = 0;  // wall clock
  int64_t end_utime = 0;    // 0 while paused
  int64_t lost = 0;         // messages not written because of it
};

// The recorder's disk state machine: recording -> paused (a write refused) -> recording (enough
// free space again, looked at once per poll period). Pure (times are given), for tests.
class DiskState {
 public:
  // resume_free_bytes: free space needed to resume; poll_s: how often to look while paused.
  DiskState(uint64_t resume_free_bytes, double poll_s)
      : resume_free_(resume_free_bytes), poll_us_(static_cast<int64_t>(poll_s * 1e6)) {}
  bool paused() const { return !pauses_.empty() && pauses_.back().end_utime == 0; }
  // Enters a pause (already paused: only counts the losses).
  void pause(int64_t now_utime, const std::string& reason,
             const std::map<std::string, int64_t>& lost);
  // A message that arrived while paused, not written.
  void lose(const std::string& channel, int64_t n = 1);
  // Paused: whether to look at the free space now (once per poll period).
  bool poll_due(int64_t now_utime) const;
  // Paused: the free space seen now; true (the pause is over) when it is enough to resume.
  bool try_resume(int64_t now_utime, uint64_t free_bytes);

  const std::vector<Pause>& pauses() const { return pauses_; }
  int64_t lost() const { return lost_; }
  const std::map<std::string, int64_t>& lost_by_channel() const { return lost_by_channel_; }
  uint64_t resume_free_bytes() const { return resume_free_; }

 private:
  uint64_t resume_free_;
  int64_t poll_us_;
  int64_t last_poll_ = 0;
  std::vector<Pause> pauses_;
  int64_t lost_ = 0;
  std::map<std::string, int64_t> lost_by_channel_;
};

// "2026-01-01T00:00:00.000000Z" (UTC), or "-" for 0.
std::string iso_utc(int64_t utime);

// The sidecar JSON (docs/programs.md#ips-record): pure, for tests. `channels` carry `dropped`
// (queue full); the disk's pauses and losses per channel come from `disk`.
std::string sidecar_json(const SessionInfo& info, const std::vector<PartInfo>& parts,
                         const std::map<std::string, ChannelCount>& channels, int64_t dropped,
                         size_t queue_peak_bytes, const DiskState* disk = nullptr);

// Writes the sidecar `text` to `path`: normally a new file renamed over the old one (a reader
// never sees half of it), padded with spaces to a reserve (JSON allows trailing white space) so
// that, when the disk is full and no new file can be made, a later text can still be written in
// place over the old one's bytes, which needs no new blocks. Returns "" or why it failed.
std::string write_sidecar_file(const std::filesystem::path& path, const std::string& text);

struct RecorderOptions {
  SessionOptions session;
  size_t queue_bytes = 64u << 20;
  double flush_interval_s = 0.1;
  // Without a site from a file, how long to hold the first events waiting for SITE on the bus
  // (so that the log starts with it). 0: do not wait.
  double site_wait_s = 3.0;
  std::vector<uint8_t> site;  // encoded site_t from --site, or empty
  SessionInfo info;
  // Paused for want of disk space: look at the free space this often, and resume once it is at
  // least min_free_bytes plus this margin.
  double disk_poll_s = 1.0;
  uint64_t resume_margin_bytes = 1u << 20;
};

struct RecorderStats {
  int64_t written = 0;
  int64_t dropped = 0;
  size_t unwritten_bytes = 0;
  size_t parts = 0;
  int64_t bytes = 0;  // in all parts
  // The disk: paused now, the current pause (else the last; reason empty: never paused).
  bool paused = false;
  Pause pause;
  int64_t pauses = 0;
  int64_t lost_disk = 0;      // messages not written because of the disk, all pauses
  std::string sidecar_error;  // why the last sidecar write failed, else empty
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

  // The writer's failure (it then stops writing); empty while all is well. A full disk is not a
  // failure: the recorder pauses (stats().paused) and resumes by itself.
  std::optional<std::string> error() const;
  RecorderStats stats() const;
  // Set once when the site wait ended without a site (for a warning by the caller).
  bool site_missing() const { return site_missing_; }
  // What the bus lost on the way to us (a JSON object): in the sidecars written from now on.
  void set_loss_json(std::string json);

 private:
  void writer_loop();
  // Writes whatever it can (the sidecar_error of stats() says why not): false when it could not.
  bool write_sidecar();
  SessionInfo info_with_loss() const;

  RecorderOptions o_;
  EventQueue queue_;
  SessionWriter writer_;
  std::thread thread_;
  mutable std::mutex stats_mutex_;  // guards error_ and the snapshot below
  std::optional<std::string> error_;
  RecorderStats snapshot_;
  std::map<std::string, int64_t> lost_by_channel_;  // queued when the writer failed
  DiskState disk_;        // the writer thread's
  DiskState disk_view_;   // its copy for the sidecar and stats(), under stats_mutex_
  std::string sidecar_error_;  // under stats_mutex_
  std::atomic<bool> site_missing_{false};
  std::string loss_json_;  // under stats_mutex_
  bool stopped_ = false;
};

}  // namespace ips::record
