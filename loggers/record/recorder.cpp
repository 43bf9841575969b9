#include "loggers/record/recorder.hpp"

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <ips/site_t.hpp>
#include <lcm/lcm-cpp.hpp>

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

// EINVAL: the file cannot be synced (a device such as /dev/null), which is not a failure.
bool synced(std::FILE* f) { return ::fdatasync(fileno(f)) == 0 || errno == EINVAL; }

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

// ---- SessionWriter ----

SessionWriter::SessionWriter(SessionOptions o) : o_(std::move(o)) {}
SessionWriter::~SessionWriter() = default;

void SessionWriter::set_site(std::vector<uint8_t> site) { site_ = std::move(site); }

void SessionWriter::check_free_space() const {
  if (o_.min_free_bytes == 0) return;
  const fs::path dir = directory_of(o_.out);
  const uint64_t avail = free_bytes(dir);
  if (avail < o_.min_free_bytes)
    throw RecordError("disk nearly full: " + mb(avail) + " free on '" + dir.string() +
                      "' (below --min-free-mb " + mb(o_.min_free_bytes) + "); recording stopped");
}

void SessionWriter::open_part(int64_t first_utime) {
  close();
  check_free_space();
  const fs::path path = part_path(o_, static_cast<int>(parts_.size()));
  if (!o_.force && !parts_.empty() && fs::exists(path))
    throw RecordError("'" + path.string() + "' exists; not overwriting it");
  log_ = std::make_unique<lcm::LogFile>(path.string(), "w");
  if (!log_->good()) {
    const int err = errno;
    log_.reset();
    throw RecordError("cannot create '" + path.string() + "': " + std::strerror(err));
  }
  PartInfo part;
  part.path = path.string();
  part.first_utime = first_utime;
  parts_.push_back(part);
  if (!site_.empty()) {
    // The head carries the part's first receive time, so that time never runs backwards.
    append(o_.site_channel, first_utime, site_.data(), site_.size());
    parts_.back().site_head = true;
  }
}

void SessionWriter::append(std::string_view channel, int64_t utime, const void* data,
                           size_t size) {
  lcm::LogEvent le;
  le.eventnum = 0;  // liblcm numbers the events of each file
  le.timestamp = utime;
  le.channel = std::string(channel);
  le.datalen = static_cast<int32_t>(size);
  le.data = const_cast<void*>(data);
  if (log_->writeEvent(&le) != 0)
    throw RecordError("write to '" + parts_.back().path + "' failed: " + std::strerror(errno));
  PartInfo& part = parts_.back();
  ++part.events;
  // lcm_eventlog's record: magic, eventnum, timestamp, channel and data lengths, then the bytes.
  part.bytes += 4 + 8 + 8 + 4 + 4 + static_cast<int64_t>(channel.size() + size);
  part.last_utime = utime;
  ChannelCount& c = channels_[le.channel];
  ++c.events;
  c.bytes += static_cast<int64_t>(size);
  ++events_;
}

void SessionWriter::write(const Event& e) {
  if (e.data.size() > static_cast<size_t>(INT32_MAX)) return;  // LCM cannot carry it anyway
  const auto record = static_cast<int64_t>(28 + e.channel.size() + e.data.size());
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
  std::FILE* f = log_->getFilePtr();
  // To the disk, as lcm-logger does: a crash of the machine loses at most one flush interval.
  if (std::fflush(f) != 0 || std::ferror(f) || !synced(f))
    throw RecordError("write to '" + parts_.back().path + "' failed: " + std::strerror(errno));
  check_free_space();
}

void SessionWriter::close() {
  if (!log_) return;
  std::FILE* f = log_->getFilePtr();
  const bool ok = std::fflush(f) == 0 && !std::ferror(f) && synced(f);
  const int err = errno;
  log_.reset();
  if (!ok)
    throw RecordError("write to '" + parts_.back().path + "' failed: " + std::strerror(err));
}

// ---- sidecar ----

namespace {

std::string iso_time(int64_t utime) {
  if (utime <= 0) return "null";
  const time_t secs = static_cast<time_t>(utime / 1000000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  char buf[64];
  std::snprintf(buf, sizeof buf, "\"%04d-%02d-%02dT%02d:%02d:%02d.%06" PRId64 "Z\"",
                tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                utime % 1000000);
  return buf;
}

std::string num(int64_t v) { return std::to_string(v); }

}  // namespace

std::string sidecar_json(const SessionInfo& info, const std::vector<PartInfo>& parts,
                         const std::map<std::string, ChannelCount>& channels, int64_t dropped,
                         size_t queue_peak_bytes) {
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
  j += "  \"recording\": " + std::string(info.end_utime > 0 ? "false" : "true") + ",\n";
  j += "  \"stopped_by\": " + (info.stopped_by.empty() ? "null" : json_quote(info.stopped_by)) +
       ",\n";
  j += "  \"events\": " + num(events) + ",\n";
  j += "  \"bytes\": " + num(bytes) + ",\n";
  j += "  \"dropped\": " + num(dropped) + ",\n";
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
         ", \"dropped\": " + num(c.dropped) + "}";
    first = false;
  }
  j += first ? "}\n" : "\n  }\n";
  j += "}\n";
  return j;
}

// ---- Recorder ----

Recorder::Recorder(RecorderOptions o)
    : o_(std::move(o)), queue_(o_.queue_bytes), writer_(o_.session) {
  preflight(o_.session);
  if (!o_.site.empty()) writer_.set_site(o_.site);
  write_sidecar();
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
  // The sidecar is also refreshed now and then, so that a killed recorder's is not stale.
  constexpr auto kSidecarPeriod = std::chrono::seconds(5);
  auto next_sidecar = clock::now() + kSidecarPeriod;
  const auto site_deadline = clock::now() + std::chrono::duration_cast<clock::duration>(
                                                std::chrono::duration<double>(o_.site_wait_s));
  bool waiting_for_site = !writer_.has_site() && o_.site_wait_s > 0;
  std::vector<Event> batch;
  std::deque<Event> pending;
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
      if (!waiting_for_site) {
        while (!pending.empty()) {
          const size_t parts_before = writer_.parts().size();
          writer_.write(pending.front());
          queue_.release(pending.front().footprint());
          pending.pop_front();
          if (writer_.parts().size() != parts_before) write_sidecar();
        }
      }
      {
        std::lock_guard lock(stats_mutex_);
        snapshot_.written = writer_.events();
        snapshot_.parts = writer_.parts().size();
        snapshot_.bytes = 0;
        for (const auto& p : writer_.parts()) snapshot_.bytes += p.bytes;
      }
      if (clock::now() >= next_flush) {
        writer_.flush();
        next_flush = clock::now() + flush_period;
      }
      if (clock::now() >= next_sidecar) {
        write_sidecar();
        next_sidecar = clock::now() + kSidecarPeriod;
      }
      if (!open && pending.empty()) break;
    }
    writer_.close();
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

void Recorder::write_sidecar() {
  auto channels = writer_.channels();
  int64_t dropped = queue_.dropped();
  for (const auto& [name, n] : queue_.dropped_by_channel()) channels[name].dropped += n;
  {
    std::lock_guard lock(stats_mutex_);
    for (const auto& [name, n] : lost_by_channel_) {
      channels[name].dropped += n;
      dropped += n;
    }
  }
  const std::string text =
      sidecar_json(info_with_loss(), writer_.parts(), channels, dropped, queue_.peak_bytes());
  // Replace it whole (write, then rename), so that a reader never sees half a sidecar.
  const fs::path path = sidecar_path(o_.session.out);
  fs::path tmp = path;
  tmp += ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) throw RecordError("cannot write '" + tmp.string() + "': " + std::strerror(errno));
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const bool closed = std::fclose(f) == 0;
  if (!ok || !closed || std::rename(tmp.c_str(), path.c_str()) != 0)
    throw RecordError("cannot write '" + path.string() + "': " + std::strerror(errno));
}

void Recorder::stop(const std::string& stopped_by) {
  if (stopped_) return;
  stopped_ = true;
  queue_.close();
  if (thread_.joinable()) thread_.join();
  o_.info.end_utime = wall_utime_now();
  const auto err = error();
  o_.info.stopped_by = err ? "error: " + *err : stopped_by;
  write_sidecar();
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
  }
  s.dropped += queue_.dropped();
  s.unwritten_bytes = queue_.unwritten_bytes();
  return s;
}

}  // namespace ips::record
