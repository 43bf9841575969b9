#pragma once
// An LCM log opened by one of the log tools (ips-eval, ips-replay, ips-export): the checks and
// error lines at opening, the resynchronising reader (core/log_reader.hpp), the progress line on
// a terminal (core/progress.hpp), and the same report of what was skipped at the end.
#include <cstdio>
#include <memory>
#include <string>

#include "core/log_reader.hpp"
#include "core/progress.hpp"

namespace ips {

class LogInput {
 public:
  // nullptr, after one line "<program>: error: cannot read log '<path>': <why>", when the path
  // does not exist, is not a regular file or cannot be opened. map: read the file mapped into
  // memory, in place (MappedFileLogSource: for a file that does not grow while it is read; the
  // events' bytes then stay valid as long as this LogInput), else through stdio.
  static std::unique_ptr<LogInput> open(const std::string& program, const std::string& path,
                                        bool map = false);
  ~LogInput();
  LogInput(const LogInput&) = delete;
  LogInput& operator=(const LogInput&) = delete;

  // The next event in file order (valid until the next call), or nullptr at the end. Events on an
  // empty channel (legal in LCM, but nothing reads them by channel) are skipped, and counted in
  // stats().empty_channel_events.
  const LogEvent* next();
  const LogReadStats& stats() const { return reader_->stats(); }
  // No progress line (several logs read at once, each on its own thread).
  void hide_progress() { show_progress_ = false; }
  int64_t size() const { return size_; }

  // After the last event: ends the progress line, then says on stderr, each only when it applies:
  //   "<program>: <path>: N events on an empty channel, skipped (legal in LCM; no channel to read
  //    them by)"
  //   "<program>: warning: <path>: read N events, then stopped at byte B of S (the log is cut
  //    short there: its last T bytes are an incomplete event); <done>"
  //   "<program>: warning: <path>: skipped G damaged bytes in R places and read on after them"
  //   "<program>: warning: <path>: read error after byte B; <done>"
  // (<done> e.g. "scoring what was read"). False, after the error line "'<path>' is not an LCM
  // log (no readable event)", when the file held bytes but no event.
  bool finish(const std::string& done);

 private:
  LogInput(std::string program, std::string path, std::FILE* file, int64_t size, bool map);

  std::string program_, path_;
  std::FILE* file_;
  int64_t size_;
  std::unique_ptr<LogByteSource> source_;
  std::unique_ptr<LogReader> reader_;
  ProgressLine progress_;
  bool show_progress_ = true;
};

}  // namespace ips
