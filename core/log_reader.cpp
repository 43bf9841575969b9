#include "core/log_reader.hpp"

#include <lcm/lcm.h>
#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

namespace ips {

static_assert(LogReader::kMaxChannelLength == LCM_MAX_CHANNEL_NAME_LENGTH);
static_assert(LogReader::kMaxDataLength == LCM_MAX_MESSAGE_SIZE);

namespace {

constexpr uint8_t kMagicBytes[4] = {0xED, 0xA1, 0xDA, 0x01};

uint32_t be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}

uint64_t be64(const uint8_t* p) { return (uint64_t{be32(p)} << 32) | be32(p + 4); }

}  // namespace

FileLogSource::FileLogSource(std::FILE* file) : file_(file) {
  struct stat st {};
  if (fstat(fileno(file_), &st) == 0 && S_ISREG(st.st_mode)) {
    const off_t at = ftello(file_);
    size_ = at >= 0 && at <= st.st_size ? static_cast<int64_t>(st.st_size - at) : -1;
  }
}

size_t FileLogSource::read(uint8_t* out, size_t capacity) {
  const size_t got = std::fread(out, 1, capacity, file_);
  if (got == 0 && std::ferror(file_)) failed_ = true;
  return got;
}

MappedFileLogSource::MappedFileLogSource(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return;
  struct stat st {};
  if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
    void* p = ::mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
    if (p != MAP_FAILED) {
      data_ = static_cast<const uint8_t*>(p);
      size_ = static_cast<size_t>(st.st_size);
      ::madvise(p, size_, MADV_SEQUENTIAL);
    }
  }
  ::close(fd);
}

MappedFileLogSource::~MappedFileLogSource() {
  if (data_) ::munmap(const_cast<uint8_t*>(data_), size_);
}

size_t MappedFileLogSource::read(uint8_t* out, size_t capacity) {
  const size_t n = std::min(capacity, size_ - pos_);
  if (n > 0) std::memcpy(out, data_ + pos_, n);
  pos_ += n;
  return n;
}

size_t MemoryLogSource::read(uint8_t* out, size_t capacity) {
  const size_t n = std::min({capacity, max_read_, bytes_.size() - pos_});
  if (n > 0) std::memcpy(out, bytes_.data() + pos_, n);
  pos_ += n;
  return n;
}

LogReader::LogReader(LogByteSource& source, size_t chunk_bytes)
    : source_(source), chunk_(std::max<size_t>(chunk_bytes, 1)) {
  stats_.input_size = source_.size();
  const std::span<const uint8_t> whole = source_.whole();
  if (whole.data() != nullptr) {  // read in place: nothing to fill, the end is known
    base_ = whole.data();
    end_ = whole.size();
    eof_ = true;
  }
}

// Makes at least n unconsumed bytes available unless the input ends first. The buffer grows at
// most to twice its size per step, so it never outgrows the bytes really read by more than that.
bool LogReader::fill(size_t n) {
  while (avail() < n && !eof_) {
    const size_t missing = n - avail();
    if (begin_ > 0 && buf_.size() - end_ < std::max(missing, chunk_ / 2)) {
      std::memmove(buf_.data(), buf_.data() + begin_, avail());
      end_ -= begin_;
      begin_ = 0;
    }
    if (buf_.size() == end_ || (buf_.size() < n && buf_.size() - end_ < chunk_ / 2)) {
      size_t want = std::max({chunk_, std::min(n, 2 * buf_.size()), end_ + 1});
      // No chunk larger than what is left of an input of known size (small logs, fuzzing); the
      // slack lets a file that grew since it was opened be read on at a fair pace.
      if (stats_.input_size >= 0) {
        const int64_t unread =
            stats_.input_size - stats_.read_up_to - static_cast<int64_t>(avail());
        want = std::min(want, end_ + static_cast<size_t>(std::max<int64_t>(unread, 0)) + 4096);
      }
      buf_.resize(std::max(want, end_ + 1));
      base_ = buf_.data();
    }
    const size_t got = source_.read(buf_.data() + end_, buf_.size() - end_);
    if (got == 0) {
      eof_ = true;
      stats_.read_error = source_.failed();
    }
    end_ += got;
  }
  return avail() >= n;
}

void LogReader::consume(size_t n) {
  begin_ += n;
  stats_.read_up_to += static_cast<int64_t>(n);
}

bool LogReader::magic_at(size_t i) const {
  return be32(base_ + i) == LogReader::kMagic;
}

size_t LogReader::find_magic(size_t from, size_t to) const {
  const uint8_t* base = base_;
  for (size_t i = from; i < to;) {
    const void* hit = std::memchr(base + i, kMagicBytes[0], to - i);
    if (!hit) break;
    i = static_cast<size_t>(static_cast<const uint8_t*>(hit) - base);
    if (magic_at(i)) return i;
    ++i;
  }
  return to;
}

// Consumes skip_first bytes, then everything up to the next magic word. At the end of the input
// without one, up to 3 bytes are left unconsumed (a magic word cut short, perhaps).
LogReader::Scan LogReader::scan_to_magic(size_t skip_first) {
  Scan s{static_cast<int64_t>(skip_first), false};
  consume(skip_first);
  for (;;) {
    if (avail() >= 4) {
      const size_t last = end_ - 3;
      const size_t at = find_magic(begin_, last);
      s.skipped += static_cast<int64_t>(at - begin_);
      consume(at - begin_);
      if (at != last) {
        s.found = true;
        return s;
      }
    }
    if (!fill(avail() + 1)) return s;
  }
}

void LogReader::add_garbage(int64_t start, int64_t n) {
  if (n <= 0) return;
  if (start != last_garbage_end_) ++stats_.resyncs;
  stats_.garbage_bytes += n;
  last_garbage_end_ = start + n;
}

// The last 0..3 bytes, after no magic word was found: the start of a magic word is an event cut
// short, anything else garbage.
void LogReader::finish() {
  const size_t n = avail();
  const int64_t start = stats_.read_up_to;
  if (n > 0 && std::memcmp(base_ + begin_, kMagicBytes, n) == 0)
    stats_.truncated_tail_bytes += static_cast<int64_t>(n);
  else
    add_garbage(start, static_cast<int64_t>(n));
  consume(n);
  done_ = true;
}

const LogEvent* LogReader::next() {
  while (!done_) {
    const int64_t start = stats_.read_up_to;
    if (!fill(4)) {
      finish();
      break;
    }
    if (!magic_at(begin_)) {
      const Scan s = scan_to_magic(0);
      add_garbage(start, s.skipped);
      if (!s.found) finish();
      continue;
    }
    if (!fill(kHeaderBytes)) {  // a header cut short
      stats_.truncated_tail_bytes += static_cast<int64_t>(avail());
      consume(avail());
      done_ = true;
      break;
    }
    const uint8_t* h = base_ + begin_;
    const auto channel_len = static_cast<int32_t>(be32(h + 20));
    const auto data_len = static_cast<int32_t>(be32(h + 24));
    if (channel_len < 0 || channel_len > kMaxChannelLength || data_len < 0 ||
        data_len > kMaxDataLength) {
      const Scan s = scan_to_magic(1);
      add_garbage(start, s.skipped);
      if (!s.found) finish();
      continue;
    }
    const size_t size =
        kHeaderBytes + static_cast<size_t>(channel_len) + static_cast<size_t>(data_len);
    // Past the end of the input: known from its size without reading (and buffering) that far,
    // or found by reading.
    const bool past_end =
        (stats_.input_size >= 0 && start + static_cast<int64_t>(size) > stats_.input_size) ||
        (!fill(size + 4) && avail() < size);
    if (past_end) {
      const Scan s = scan_to_magic(1);
      if (s.found) {
        add_garbage(start, s.skipped);
      } else {
        stats_.truncated_tail_bytes += s.skipped + static_cast<int64_t>(avail());
        consume(avail());
        done_ = true;
      }
      continue;
    }
    // An event is followed by the next one's magic word, or by the end of the input (a magic
    // word cut short counts). Anything else means damage began inside it: its bytes or its
    // length are not what was recorded.
    const size_t follow = std::min<size_t>(avail() - size, 4);
    const bool followed = follow == 4 ? magic_at(begin_ + size)
                                      : std::memcmp(base_ + begin_ + size, kMagicBytes, follow) == 0;
    if (!followed) {
      const Scan s = scan_to_magic(1);
      add_garbage(start, s.skipped);
      if (!s.found) finish();
      continue;
    }
    h = base_ + begin_;
    event_.eventnum = static_cast<int64_t>(be64(h + 4));
    event_.timestamp_us = static_cast<int64_t>(be64(h + 12));
    event_.channel.assign(reinterpret_cast<const char*>(h + kHeaderBytes),
                          static_cast<size_t>(channel_len));
    event_.data = h + kHeaderBytes + channel_len;
    event_.size = static_cast<size_t>(data_len);
    event_.offset = start;
    consume(size);
    ++stats_.events;
    if (channel_len == 0) ++stats_.empty_channel_events;
    stats_.event_bytes += static_cast<int64_t>(size);
    return &event_;
  }
  return nullptr;
}

std::optional<LogSpan> read_log_span(std::FILE* file, int64_t tail_bytes) {
  struct stat st {};
  if (fstat(fileno(file), &st) != 0 || fseeko(file, 0, SEEK_SET) != 0) return std::nullopt;
  LogSpan span;
  {
    FileLogSource head(file);
    LogReader reader(head, size_t{1} << 16);
    const LogEvent* e = reader.next();
    if (!e) return std::nullopt;
    span.first_us = span.last_us = e->timestamp_us;
  }
  for (int64_t window = std::max<int64_t>(tail_bytes, 1);; window *= 4) {
    const int64_t start = std::max<int64_t>(0, st.st_size - window);
    if (fseeko(file, static_cast<off_t>(start), SEEK_SET) != 0) return std::nullopt;
    FileLogSource tail(file);
    LogReader reader(tail, size_t{1} << 16);
    bool any = false;
    while (const LogEvent* e = reader.next()) {
      span.last_us = std::max(span.last_us, e->timestamp_us);
      any = true;
    }
    if (any || start == 0) return span;
  }
}

}  // namespace ips
