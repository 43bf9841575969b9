#include "core/log_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ips {

namespace {
constexpr size_t kBufferBytes = size_t{1} << 20;

void put(std::vector<uint8_t>& out, uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}
}  // namespace

void append_log_event(std::vector<uint8_t>& out, std::string_view channel, int64_t eventnum,
                      int64_t utime, const void* data, size_t size) {
  put(out, 0xEDA1DA01u, 4);
  put(out, static_cast<uint64_t>(eventnum), 8);
  put(out, static_cast<uint64_t>(utime), 8);
  put(out, channel.size(), 4);
  put(out, size, 4);
  out.insert(out.end(), channel.begin(), channel.end());
  const auto* p = static_cast<const uint8_t*>(data);
  if (size > 0) out.insert(out.end(), p, p + size);
}

LogWriter::LogWriter(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) error_ = "cannot write log '" + path + "': " + std::strerror(errno);
  buf_.reserve(kBufferBytes + 4096);
}

LogWriter::~LogWriter() { close(); }

bool LogWriter::add(std::string_view channel, int64_t utime, const void* data, size_t size) {
  if (!ok()) return false;
  append_log_event(buf_, channel, events_++, utime, data, size);
  return buf_.size() < kBufferBytes || write_out();
}

bool LogWriter::write_out() {
  size_t done = 0;
  while (done < buf_.size()) {
    const ssize_t n = ::write(fd_, buf_.data() + done, buf_.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      error_ = "write to '" + path_ + "' failed: " + std::strerror(n == 0 ? ENOSPC : errno);
      buf_.clear();
      return false;
    }
    done += static_cast<size_t>(n);
  }
  buf_.clear();
  return true;
}

bool LogWriter::close() {
  if (fd_ < 0) return ok();
  if (ok()) write_out();
  if (::close(fd_) != 0 && ok())
    error_ = "write to '" + path_ + "' failed: " + std::strerror(errno);
  fd_ = -1;
  return ok();
}

}  // namespace ips
