#pragma once
// Writes an LCM log (the format of core/log_reader.hpp, as liblcm's lcm_eventlog writes it) through
// one buffer and few write(2) calls: liblcm's LogFile makes seven stdio calls per event, a tenth of
// a replay's time.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ips {

// Appends one event in the LCM log format to `out`: magic, event number, time stamp (us), channel
// length, data length (big-endian), channel, data.
void append_log_event(std::vector<uint8_t>& out, std::string_view channel, int64_t eventnum,
                      int64_t utime, const void* data, size_t size);

class LogWriter {
 public:
  // Creates `path`, or empties it. ok() false, error() saying why, when it cannot.
  explicit LogWriter(const std::string& path);
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  bool ok() const { return error_.empty(); }
  // "write to 'out.lcm' failed: No space left on device"; "" while all is well.
  const std::string& error() const { return error_; }
  // Events are numbered from 0, as liblcm's LogFile numbers them. False once a write failed.
  bool add(std::string_view channel, int64_t utime, const void* data, size_t size);
  // Writes what is buffered and closes the file; false when a write or the close failed.
  bool close();
  int64_t events() const { return events_; }

 private:
  bool write_out();

  std::string path_;
  int fd_ = -1;
  std::vector<uint8_t> buf_;
  int64_t events_ = 0;
  std::string error_;
};

}  // namespace ips
