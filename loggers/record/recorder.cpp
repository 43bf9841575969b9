#include "loggers/record/recorder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <utility>
#include <ips/site_t.hpp>

#include "core/log_writer.hpp"
#include "core/node.hpp"
#include "core/text_escape.hpp"

namespace fs = std::filesystem;

namespace ips::record {

// ---- EventQueue ----

bool EventQueue::push(Event&& e) {
  const size_t need = e.footprint();
  {
    std::lock_guard lock(mutex_);
    if (closed_ || unwritten_ + need > capacity_) {
      ++dropped_;
      ++dropped_by_channel_[e.channel];
      return false;
    }
    unwritten_ += need;
    peak_ = std::max(peak_, unwritten_);
    events_.push_back(std::move(e));
  }
  ready_.notify_one();
  return true;
}

bool EventQueue::pop_all(std::vector<Event>& out, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  ready_.wait_for(lock, timeout, [&] { return !events_.empty() || closed_; });
  for (auto& e : events_) out.push_back(std::move(e));
  events_.clear();
  return !closed_ || !out.empty();
}

void EventQueue::release(size_t bytes) {
  std::lock_guard lock(mutex_);
  unwritten_ -= std::min(bytes, unwritten_);
}

void EventQueue::close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  ready_.notify_all();
}

size_t EventQueue::unwritten_bytes() const {
  std::lock_guard lock(mutex_);
  return unwritten_;
}
size_t EventQueue::peak_bytes() const {
  std::lock_guard lock(mutex_);
  return peak_;
}
int64_t EventQueue::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}
std::map<std::string, int64_t> EventQueue::dropped_by_channel() const {
  std::lock_guard lock(mutex_);
  return dropped_by_channel_;
}

// ---- files ----

namespace {

bool splitting(const SessionOptions& o) { return o.split_mb > 0 || o.split_s > 0; }

std::string mb(uint64_t bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.0f MB", static_cast<double>(bytes) / 1e6);
  return buf;
}

fs::path directory_of(const fs::path& out) {
  return out.has_parent_path() ? out.parent_path() : fs::path(".");
}

}  // namespace

fs::path sidecar_path(const fs::path& out) {
  fs::path p = out;
  return p.replace_extension(".json");
}

fs::path part_path(const SessionOptions& o, int index) {
  if (!splitting(o)) return o.out;
  char num[16];
  std::snprintf(num, sizeof num, ".%03d", index);
  fs::path p = o.out;
  const std::string ext = p.has_extension() ? p.extension().string() : std::string();
  return p.replace_extension().concat(num + ext);
}

uint64_t free_bytes(const fs::path& dir) {
  struct statvfs st {};
  if (statvfs(dir.c_str(), &st) != 0)
    throw RecordError("cannot query free space on '" + dir.string() + "': " + std::strerror(errno));
  return static_cast<uint64_t>(st.f_bavail) * st.f_frsize;
}

void preflight(const SessionOptions& o) {
  if (o.out.empty()) throw RecordError("no output file given (--out FILE.lcm)");
  if (o.out.filename().empty() || o.out.filename() == "." || o.out.filename() == "..")
    throw RecordError("'" + o.out.string() + "' names a directory; give a file (--out DIR/FILE.lcm)");
  const fs::path dir = directory_of(o.out);
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    fs::create_directories(dir, ec);
    if (ec) throw RecordError("cannot create directory '" + dir.string() + "': " + ec.message());
  } else if (!fs::is_directory(dir, ec)) {
    throw RecordError("'" + dir.string() + "' is not a directory");
  }
  // Try it for real: permission bits say nothing for root, and nothing about read-only mounts.
  const fs::path probe = dir / (".ips-record-probe-" + std::to_string(getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) throw RecordError("cannot write in '" + dir.string() + "': " + std::strerror(errno));
  ::close(fd);
  ::unlink(probe.c_str());
  if (!o.force) {
    for (const fs::path& p : {part_path(o, 0), sidecar_path(o.out)})
      if (fs::exists(p, ec))
        throw RecordError("'" + p.string() + "' exists; choose another --out or give --force");
  }
  const uint64_t avail = free_bytes(dir);
  if (avail < o.min_free_bytes)
    throw RecordError("disk nearly full: " + mb(avail) + " free on '" + dir.string() +
                      "', at least " + mb(o.min_free_bytes) + " required (--min-free-mb)");
}

// ---- PartFile ----

bool pauses_recording(int err) { return err == ENOSPC || err == EDQUOT || err == EIO; }

// One log file being written: events encoded into a buffer (lcm_eventlog's record: magic, event
// number, time stamp, channel and data lengths, big-endian, then the bytes) and written with
// write(2), so that after a refused write the file can be cut back to its last complete event.
class PartFile {
 public:
  struct Buffered {
    size_t end;  // in the buffer
    std::string channel;
    int64_t utime;
    size_t data_size;
    bool head;  // the SITE head, not a message from the bus
  };

  // Throws RecordError (with errno kept in err()) when the file cannot be opened.
  PartFile(const fs::path& path, bool append, const SessionOptions& o)
      : path_(path.string()), write_(o.write_fn) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC | (append ? 0 : O_TRUNC),
                 0644);
    if (fd_ < 0) {
      open_errno_ = errno;
      return;
    }
    struct stat st {};
    if (::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode)) {
      on_disk_ = static_cast<int64_t>(st.st_size);
      regular_ = true;
    }
  }
  ~PartFile() {
    if (fd_ >= 0) ::close(fd_);
  }
  PartFile(const PartFile&) = delete;
  PartFile& operator=(const PartFile&) = delete;

  int open_errno() const { return fd_ < 0 ? open_errno_ : 0; }
  size_t buffered() const { return buf_.size(); }

  void add(std::string_view channel, int64_t eventnum, int64_t utime, const void* data,
           size_t size, bool head) {
    append_log_event(buf_, channel, eventnum, utime, data, size);
    pending_.push_back({buf_.size(), std::string(channel), utime, size, head});
  }

  // Writes the buffer; 0, or the errno of the refused write. After a refusal the file is cut
  // back to its last complete event and lost() holds the events that are not in it.
  int write_out() {
    size_t done = 0;
    int err = 0;
    while (done < buf_.size()) {
      const ssize_t n = write_ ? write_(fd_, buf_.data() + done, buf_.size() - done)
                               : ::write(fd_, buf_.data() + done, buf_.size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        err = n == 0 ? ENOSPC : errno;
        break;
      }
      done += static_cast<size_t>(n);
    }
    size_t keep = done, kept_events = pending_.size();
    if (err != 0) {
      keep = 0;
      kept_events = 0;
      while (kept_events < pending_.size() && pending_[kept_events].end <= done)
        keep = pending_[kept_events++].end;
      // Shrinking a file needs no space. A device (not a regular file) cannot be cut back.
      if (keep != done && regular_)
        (void)!::ftruncate(fd_, static_cast<off_t>(on_disk_ + static_cast<int64_t>(keep)));
      lost_.assign(pending_.begin() + static_cast<std::ptrdiff_t>(kept_events), pending_.end());
    }
    if (kept_events > 0) last_utime_ = pending_[kept_events - 1].utime;
    on_disk_ += static_cast<int64_t>(keep);
    buf_.clear();
    pending_.clear();
    return err;
  }

  // 0, or the errno of a failed fdatasync (EINVAL: a device that cannot be synced, no failure).
  int sync() { return ::fdatasync(fd_) == 0 || errno == EINVAL ? 0 : errno; }

  std::vector<Buffered> take_lost() { return std::exchange(lost_, {}); }
  // The time stamp of the last event written (0: none yet in this object).
  int64_t last_utime() const { return last_utime_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::function<ssize_t(int, const void*, size_t)> write_;
  int fd_ = -1;
  int open_errno_ = 0;
  bool regular_ = false;
  int64_t on_disk_ = 0;
  int64_t last_utime_ = 0;
  std::vector<uint8_t> buf_;
  std::vector<Buffered> pending_;
  std::vector<Buffered> lost_;
};

// ---- SessionWriter ----

namespace {
// Events are written out once this many bytes wait in the buffer (and at every flush).
constexpr size_t kWriteBufferBytes = 256 * 1024;

int64_t record_bytes(size_t channel, size_t data) {
  return static_cast<int64_t>(28 + channel + data);
}

std::string disk_reason(int err) {
  const std::string why = std::strerror(err);
  if (err == ENOSPC) return "disk full (" + why + ")";
  if (err == EDQUOT) return "disk quota exceeded (" + why + ")";
  return "write error (" + why + ")";
}
}  // namespace

SessionWriter::SessionWriter(SessionOptions o) : o_(std::move(o)) {}
SessionWriter::~SessionWriter() = default;

void SessionWriter::set_site(std::vector<uint8_t> site) { site_ = std::move(site); }

uint64_t SessionWriter::free_space() const {
  const fs::path dir = directory_of(o_.out);
  return o_.free_bytes_fn ? o_.free_bytes_fn(dir) : free_bytes(dir);
}

void SessionWriter::check_free_space() {
  if (o_.min_free_bytes == 0) return;
  const uint64_t avail = free_space();
  if (avail >= o_.min_free_bytes) return;
  if (log_) {
    close();  // writes what is buffered (or throws DiskFullError itself)
    reopen_ = true;
  }
  const fs::path dir = directory_of(o_.out);
  throw DiskFullError("disk nearly full: " + mb(avail) + " free on '" + dir.string() +
                          "' (below --min-free-mb " + mb(o_.min_free_bytes) + ")",
                      "disk nearly full (" + mb(avail) + " free, below --min-free-mb " +
                          mb(o_.min_free_bytes) + ")",
                      {});
}

void SessionWriter::fail_part(int err) {
  const std::string what = "write to '" + log_->path() + "' failed: " + std::strerror(err);
  std::map<std::string, int64_t> lost;
  PartInfo& part = parts_.back();
  for (const auto& b : log_->take_lost()) {
    if (!b.head) ++lost[b.channel];
    --part.events;
    part.bytes -= record_bytes(b.channel.size(), b.data_size);
    ChannelCount& c = channels_[b.channel];
    --c.events;
    c.bytes -= static_cast<int64_t>(b.data_size);
    --events_;
  }
  if (log_->last_utime() != 0) part.last_utime = log_->last_utime();
  if (part.events == 0) {
    part.site_head = false;
    part.last_utime = part.first_utime;
  }
  log_.reset();
  reopen_ = true;
  if (!pauses_recording(err)) throw RecordError(what);
  throw DiskFullError(what, disk_reason(err), std::move(lost));
}

void SessionWriter::write_out() {
  if (const int err = log_->write_out()) fail_part(err);
}

void SessionWriter::open_part(int64_t first_utime) {
  close();
  check_free_space();
  const fs::path path = part_path(o_, static_cast<int>(parts_.size()));
  if (!o_.force && !parts_.empty() && fs::exists(path))
    throw RecordError("'" + path.string() + "' exists; not overwriting it");
  auto file = std::make_unique<PartFile>(path, false, o_);
  if (const int err = file->open_errno()) {
    const std::string what = "cannot create '" + path.string() + "': " + std::strerror(err);
    if (pauses_recording(err)) throw DiskFullError(what, disk_reason(err), {});
    throw RecordError(what);
  }
  log_ = std::move(file);
  PartInfo part;
  part.path = path.string();
  part.first_utime = first_utime;
  part.last_utime = first_utime;
  parts_.push_back(part);
  if (!site_.empty()) {
    // The head carries the part's first receive time, so that time never runs backwards.
    append(o_.site_channel, first_utime, site_.data(), site_.size());
    parts_.back().site_head = true;
  }
}

// Resuming after a full disk: appends to the part it interrupted when that file is still there
// (a new part when splitting and it is gone; without splitting, the file is made anew).
bool SessionWriter::reopen_part() {
  if (parts_.empty()) return false;
  PartInfo& part = parts_.back();
  std::error_code ec;
  if (!fs::is_regular_file(part.path, ec)) {
    if (splitting(o_) || fs::exists(part.path, ec)) return false;
    parts_.pop_back();  // without splitting, the same name: counted anew
    return false;
  }
  check_free_space();
  auto file = std::make_unique<PartFile>(part.path, true, o_);
  if (const int err = file->open_errno()) {
    const std::string what = "cannot open '" + part.path + "': " + std::strerror(err);
    if (pauses_recording(err)) throw DiskFullError(what, disk_reason(err), {});
    throw RecordError(what);
  }
  const auto size = static_cast<int64_t>(fs::file_size(part.path, ec));
  if (!ec) part.bytes = size;  // what is really there (a cut that could not be made)
  log_ = std::move(file);
  if (part.events == 0 && !site_.empty()) {
    append(o_.site_channel, part.first_utime, site_.data(), site_.size());
    part.site_head = true;
  }
  return true;
}

void SessionWriter::append(std::string_view channel, int64_t utime, const void* data,
                           size_t size) {
  PartInfo& part = parts_.back();
  const bool head = part.events == 0 && channel == o_.site_channel && data == site_.data();
  log_->add(channel, part.events, utime, data, size, head);  // liblcm numbers each file's events
  ++part.events;
  part.bytes += record_bytes(channel.size(), size);
  part.last_utime = utime;
  ChannelCount& c = channels_[std::string(channel)];
  ++c.events;
  c.bytes += static_cast<int64_t>(size);
  ++events_;
}

void SessionWriter::write(const Event& e) {
  if (e.data.size() > static_cast<size_t>(INT32_MAX)) return;  // LCM cannot carry it anyway
  // Written out before anything else: when this throws, `e` is not in the log, and every event
  // before it is either in the log or counted as lost.
  if (log_ && log_->buffered() >= kWriteBufferBytes) write_out();
  if (!log_ && reopen_) {
    reopen_part();  // a DiskFullError leaves reopen_ set: the next try appends again
    reopen_ = false;
  }
  const int64_t record = record_bytes(e.channel.size(), e.data.size());
  bool rotate = !log_;
  if (log_ && parts_.back().events > (parts_.back().site_head ? 1 : 0)) {
    const PartInfo& part = parts_.back();
    if (o_.split_mb > 0 && static_cast<double>(part.bytes + record) > o_.split_mb * 1e6)
      rotate = true;
    if (o_.split_s > 0 && static_cast<double>(e.utime - part.first_utime) >= o_.split_s * 1e6)
      rotate = true;
  }
  if (rotate) open_part(e.utime);
  append(e.channel, e.utime, e.data.data(), e.data.size());
  if (e.channel == o_.site_channel) {
    site_t site;
    if (decode_message(site, e.data.data(), e.data.size())) {
      site_ = e.data;
      if (parts_.back().events == 1) parts_.back().site_head = true;  // no head needed
    }
  }
}

void SessionWriter::flush() {
  if (!log_) return;
  write_out();
  // To the disk, as lcm-logger does: a crash of the machine loses at most one flush interval.
  if (const int err = log_->sync()) fail_part(err);
  check_free_space();
}

void SessionWriter::close() {
  if (!log_) return;
  write_out();
  if (const int err = log_->sync()) fail_part(err);
  log_.reset();
}

namespace {

std::string iso_time(int64_t utime) { return utime <= 0 ? "null" : "\"" + iso_utc(utime) + "\""; }

std::string num(int64_t v) { return std::to_string(v); }

}  // namespace

std::string iso_utc(int64_t utime) {
  if (utime <= 0) return "-";
  const time_t secs = static_cast<time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d.%06" PRId64 "Z", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, utime % 1000000);
  return buf;
}

// ---- DiskState ----

void DiskState::pause(int64_t now_utime, const std::string& reason,
                      const std::map<std::string, int64_t>& lost) {
  if (!paused()) {
    pauses_.push_back({reason, now_utime, 0, 0});
    last_poll_ = now_utime;
  }
  for (const auto& [channel, n] : lost) lose(channel, n);
}

void DiskState::lose(const std::string& channel, int64_t n) {
  if (n <= 0) return;
  lost_ += n;
  lost_by_channel_[channel] += n;
  if (!pauses_.empty()) pauses_.back().lost += n;
}

bool DiskState::poll_due(int64_t now_utime) const {
  return paused() && now_utime - last_poll_ >= poll_us_;
}

bool DiskState::try_resume(int64_t now_utime, uint64_t free_bytes) {
  if (!paused()) return true;
  last_poll_ = now_utime;
  if (free_bytes < resume_free_) return false;
  pauses_.back().end_utime = std::max<int64_t>(now_utime, pauses_.back().start_utime + 1);
  return true;
}

// ---- sidecar ----

std::string sidecar_json(const SessionInfo& info, const std::vector<PartInfo>& parts,
                         const std::map<std::string, ChannelCount>& channels, int64_t dropped,
                         size_t queue_peak_bytes, const DiskState* disk) {
  const bool paused = disk && disk->paused();
  const char* state = info.end_utime > 0 ? "stopped" : paused ? "paused" : "recording";
  int64_t events = 0, bytes = 0;
  for (const auto& p : parts) {
    events += p.events;
    bytes += p.bytes;
  }
  std::string j = "{\n";
  j += "  \"program\": " + json_quote(info.program) + ",\n";
  j += "  \"version\": " + json_quote(info.version) + ",\n";
  j += "  \"host\": " + json_quote(info.host) + ",\n";
  j += "  \"lcm_url\": " + json_quote(info.lcm_url) + ",\n";
  j += "  \"channels_regex\": " + json_quote(info.channels_regex) + ",\n";
  j += "  \"site_source\": " + json_quote(info.site_source) + ",\n";
  j += "  \"start_utime\": " + num(info.start_utime) + ",\n";
  j += "  \"start\": " + iso_time(info.start_utime) + ",\n";
  j += "  \"end_utime\": " + (info.end_utime > 0 ? num(info.end_utime) : "null") + ",\n";
  j += "  \"end\": " + iso_time(info.end_utime) + ",\n";
  j += "  \"state\": " + json_quote(state) + ",\n";
  j += "  \"recording\": " + std::string(state == std::string_view("recording") ? "true" : "false") +
       ",\n";
  j += "  \"stopped_by\": " + (info.stopped_by.empty() ? "null" : json_quote(info.stopped_by)) +
       ",\n";
  j += "  \"events\": " + num(events) + ",\n";
  j += "  \"bytes\": " + num(bytes) + ",\n";
  j += "  \"dropped\": " + num(dropped) + ",\n";
  // The disk: the pause now on (null when none), the messages it cost, every pause.
  j += "  \"disk\": {\"paused\": ";
  if (paused) {
    const Pause& p = disk->pauses().back();
    j += "{\"reason\": " + json_quote(p.reason) + ", \"since_utime\": " + num(p.start_utime) +
         ", \"since\": " + iso_time(p.start_utime) + ", \"not_written\": " + num(p.lost) + "}";
  } else {
    j += "null";
  }
  j += ", \"lost\": " + num(disk ? disk->lost() : 0) + ", \"pauses\": [";
  if (disk) {
    const auto& ps = disk->pauses();
    for (size_t i = 0; i < ps.size(); ++i) {
      const Pause& p = ps[i];
      j += std::string(i ? ",\n" : "\n") + "    {\"reason\": " + json_quote(p.reason) +
           ", \"start_utime\": " + num(p.start_utime) + ", \"start\": " + iso_time(p.start_utime) +
           ", \"end_utime\": " + (p.end_utime > 0 ? num(p.end_utime) : "null") +
           ", \"end\": " + iso_time(p.end_utime) + ", \"lost\": " + num(p.lost) + "}";
    }
    if (!ps.empty()) j += "\n  ";
  }
  j += "]},\n";
  j += "  \"queue_peak_bytes\": " + std::to_string(queue_peak_bytes) + ",\n";
  if (!info.loss_json.empty()) j += "  \"loss\": " + info.loss_json + ",\n";
  j += "  \"parts\": [";
  for (size_t i = 0; i < parts.size(); ++i) {
    const auto& p = parts[i];
    j += std::string(i ? ",\n" : "\n") + "    {\"file\": " +
         json_quote(fs::path(p.path).filename().string()) + ", \"events\": " + num(p.events) +
         ", \"bytes\": " + num(p.bytes) + ", \"first_utime\": " + num(p.first_utime) +
         ", \"last_utime\": " + num(p.last_utime) +
         ", \"site_first\": " + (p.site_head ? "true" : "false") + "}";
  }
  j += parts.empty() ? "],\n" : "\n  ],\n";
  j += "  \"channels\": {";
  bool first = true;
  for (const auto& [name, c] : channels) {
    j += std::string(first ? "\n" : ",\n") + "    " + json_quote(name) +
         ": {\"events\": " + num(c.events) + ", \"bytes\": " + num(c.bytes) +
         ", \"dropped\": " + num(c.dropped);
    if (disk) {
      const auto it = disk->lost_by_channel().find(name);
      j += ", \"lost_disk\": " + num(it == disk->lost_by_channel().end() ? 0 : it->second);
    }
    j += "}";
    first = false;
  }
  j += first ? "}\n" : "\n  }\n";
  j += "}\n";
  return j;
}

std::string write_sidecar_file(const fs::path& path, const std::string& text) {
  // Padded to at least 4 KiB beyond the text, in whole 4 KiB blocks: room for what a full disk
  // adds (the pause, its losses, channels first seen) when it has to be written in place.
  constexpr size_t kBlock = 4096;
  const size_t reserved = (text.size() / kBlock + 2) * kBlock;
  std::string padded = text;
  padded.resize(reserved - 1, ' ');
  padded += '\n';
  const auto write_all = [](int fd, const std::string& s, off_t at) {
    size_t done = 0;
    while (done < s.size()) {
      const ssize_t n = ::pwrite(fd, s.data() + done, s.size() - done,
                                 at + static_cast<off_t>(done));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) return n == 0 ? ENOSPC : errno;
      done += static_cast<size_t>(n);
    }
    return 0;
  };
  // Replaced whole (a new file, then renamed), so that a reader never sees half of it.
  fs::path tmp = path;
  tmp += ".tmp";
  int err = 0;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    err = errno;
  } else {
    err = write_all(fd, padded, 0);
    if (::close(fd) != 0 && err == 0) err = errno;
    if (err == 0 && std::rename(tmp.c_str(), path.c_str()) != 0) err = errno;
    if (err == 0) return "";
    ::unlink(tmp.c_str());
  }
  // No room for a new file (a full disk): over the old one's bytes, which are already allocated.
  // A reader may see a mix of the old and the new text for that moment.
  const std::string why = "cannot write '" + path.string() + "': " + std::strerror(err);
  const int old = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
  if (old < 0) return why;
  struct stat st {};
  std::string in_place;
  if (::fstat(old, &st) == 0 && static_cast<size_t>(st.st_size) > text.size()) {
    in_place = text;
    in_place.resize(static_cast<size_t>(st.st_size) - 1, ' ');
    in_place += '\n';
  }
  const int in_place_err = in_place.empty() ? EFBIG : write_all(old, in_place, 0);
  ::close(old);
  if (in_place_err == 0) return "";
  return why + (in_place.empty() ? "; the previous one has no room left for it in place"
                                  : "; in place either: " + std::string(std::strerror(in_place_err)));
}

// ---- Recorder ----

Recorder::Recorder(RecorderOptions o)
    : o_(std::move(o)),
      queue_(o_.queue_bytes),
      writer_(o_.session),
      disk_(o_.session.min_free_bytes + o_.resume_margin_bytes, o_.disk_poll_s),
      disk_view_(disk_) {
  preflight(o_.session);
  if (!o_.site.empty()) writer_.set_site(o_.site);
  if (!write_sidecar()) {
    std::lock_guard lock(stats_mutex_);
    throw RecordError(sidecar_error_);
  }
  thread_ = std::thread([this] { writer_loop(); });
}

Recorder::~Recorder() {
  try {
    stop("destroyed");
  } catch (...) {
  }
}

bool Recorder::offer(std::string_view channel, int64_t utime, const void* data, size_t size) {
  Event e;
  e.channel = std::string(channel);
  e.utime = utime;
  const auto* p = static_cast<const uint8_t*>(data);
  e.data.assign(p, p + size);
  return queue_.push(std::move(e));
}

void Recorder::writer_loop() {
  using clock = std::chrono::steady_clock;
  const auto flush_period = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double>(std::max(0.001, o_.flush_interval_s)));
  auto next_flush = clock::now() + flush_period;
  // The sidecar is also refreshed now and then, so that a killed recorder's is not stale; every
  // second while the disk is full (in place then), so that its losses are current.
  constexpr auto kSidecarPeriod = std::chrono::seconds(5);
  constexpr auto kPausedSidecarPeriod = std::chrono::seconds(1);
  auto next_sidecar = clock::now() + kSidecarPeriod;
  const auto site_deadline = clock::now() + std::chrono::duration_cast<clock::duration>(
                                                std::chrono::duration<double>(o_.site_wait_s));
  bool waiting_for_site = !writer_.has_site() && o_.site_wait_s > 0;
  std::vector<Event> batch;
  std::deque<Event> pending;
  // Paused: what is pending is not written (counted per channel), and the queue is emptied.
  const auto lose_pending = [&] {
    for (const auto& e : pending) {
      disk_.lose(e.channel);
      queue_.release(e.footprint());
    }
    pending.clear();
  };
  // A file system that cannot even say how full it is (a device gone) has no room.
  const auto free_space_or_none = [&]() -> uint64_t {
    try {
      return writer_.free_space();
    } catch (const RecordError&) {
      return 0;
    }
  };
  const auto on_disk_full = [&](const DiskFullError& f) {
    disk_.pause(wall_utime_now(), f.reason, f.lost);
    lose_pending();
    write_sidecar();
    next_sidecar = clock::now() + kPausedSidecarPeriod;
  };
  try {
    for (;;) {
      const bool open = queue_.pop_all(batch, std::chrono::milliseconds(20));
      for (auto& e : batch) pending.push_back(std::move(e));
      batch.clear();
      if (waiting_for_site) {
        for (const auto& e : pending) {
          site_t site;
          if (e.channel == o_.session.site_channel &&
              decode_message(site, e.data.data(), e.data.size())) {
            writer_.set_site(e.data);
            waiting_for_site = false;
            break;
          }
        }
        if (waiting_for_site && (!open || clock::now() >= site_deadline)) {
          waiting_for_site = false;
          site_missing_ = true;
        }
      }
      if (disk_.paused()) {
        lose_pending();
        const int64_t now = wall_utime_now();
        // Once per poll period: is there room again? (writing resumes with the next message)
        if (open && disk_.poll_due(now) && disk_.try_resume(now, free_space_or_none())) {
          write_sidecar();
          next_sidecar = clock::now() + kSidecarPeriod;
        }
      }
      if (!waiting_for_site && !disk_.paused()) {
        try {
          while (!pending.empty()) {
            const size_t parts_before = writer_.parts().size();
            writer_.write(pending.front());
            queue_.release(pending.front().footprint());
            pending.pop_front();
            if (writer_.parts().size() != parts_before) write_sidecar();
          }
          if (clock::now() >= next_flush) {
            writer_.flush();
            next_flush = clock::now() + flush_period;
          }
        } catch (const DiskFullError& f) {
          on_disk_full(f);
        }
      }
      {
        std::lock_guard lock(stats_mutex_);
        snapshot_.written = writer_.events();
        snapshot_.parts = writer_.parts().size();
        snapshot_.bytes = 0;
        for (const auto& p : writer_.parts()) snapshot_.bytes += p.bytes;
        disk_view_ = disk_;
      }
      if (clock::now() >= next_sidecar) {
        write_sidecar();
        next_sidecar = clock::now() + (disk_.paused() ? kPausedSidecarPeriod : kSidecarPeriod);
      }
      if (!open && pending.empty()) break;
    }
    try {
      writer_.close();
    } catch (const DiskFullError& f) {
      on_disk_full(f);  // the end of the session, with a full disk
    }
    std::lock_guard lock(stats_mutex_);
    snapshot_.written = writer_.events();
    snapshot_.bytes = 0;
    for (const auto& p : writer_.parts()) snapshot_.bytes += p.bytes;
    disk_view_ = disk_;
  } catch (const std::exception& e) {
    {
      std::lock_guard lock(stats_mutex_);
      error_ = e.what();
    }
    queue_.close();
    try {
      writer_.close();
    } catch (const std::exception&) {
      // The first failure is the one reported.
    }
    // Whatever is still queued will not be written: it counts as dropped.
    for (;;) {
      batch.clear();
      if (!queue_.pop_all(batch, std::chrono::milliseconds(0))) break;
      for (auto& ev : batch) pending.push_back(std::move(ev));
      if (batch.empty()) break;
    }
    std::lock_guard lock(stats_mutex_);
    snapshot_.dropped += static_cast<int64_t>(pending.size());
    for (const auto& ev : pending) ++lost_by_channel_[ev.channel];
    disk_view_ = disk_;
  }
}

void Recorder::set_loss_json(std::string json) {
  std::lock_guard lock(stats_mutex_);
  loss_json_ = std::move(json);
}

SessionInfo Recorder::info_with_loss() const {
  SessionInfo info = o_.info;
  std::lock_guard lock(stats_mutex_);
  info.loss_json = loss_json_;
  return info;
}

bool Recorder::write_sidecar() {
  auto channels = writer_.channels();
  int64_t dropped = queue_.dropped();
  for (const auto& [name, n] : queue_.dropped_by_channel()) channels[name].dropped += n;
  for (const auto& [name, n] : disk_.lost_by_channel()) channels[name];  // listed, if all lost
  {
    std::lock_guard lock(stats_mutex_);
    for (const auto& [name, n] : lost_by_channel_) {
      channels[name].dropped += n;
      dropped += n;
    }
  }
  const std::string text =
      sidecar_json(info_with_loss(), writer_.parts(), channels, dropped, queue_.peak_bytes(), &disk_);
  std::string err = write_sidecar_file(sidecar_path(o_.session.out), text);
  std::lock_guard lock(stats_mutex_);
  sidecar_error_ = std::move(err);
  return sidecar_error_.empty();
}

void Recorder::stop(const std::string& stopped_by) {
  if (stopped_) return;
  stopped_ = true;
  queue_.close();
  if (thread_.joinable()) thread_.join();
  o_.info.end_utime = wall_utime_now();
  const auto err = error();
  o_.info.stopped_by = err ? "error: " + *err : stopped_by;
  if (!write_sidecar()) {
    std::lock_guard lock(stats_mutex_);
    throw RecordError(sidecar_error_);
  }
}

std::optional<std::string> Recorder::error() const {
  std::lock_guard lock(stats_mutex_);
  return error_;
}

RecorderStats Recorder::stats() const {
  RecorderStats s;
  {
    std::lock_guard lock(stats_mutex_);
    s = snapshot_;
    s.paused = disk_view_.paused();
    if (!disk_view_.pauses().empty()) s.pause = disk_view_.pauses().back();
    s.pauses = static_cast<int64_t>(disk_view_.pauses().size());
    s.lost_disk = disk_view_.lost();
    s.sidecar_error = sidecar_error_;
  }
  s.dropped += queue_.dropped();
  s.unwritten_bytes = queue_.unwritten_bytes();
  return s;
}

}  // namespace ips::record
