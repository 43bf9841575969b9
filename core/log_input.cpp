#include "core/log_input.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/cli.hpp"

namespace ips {

std::unique_ptr<LogInput> LogInput::open(const std::string& program, const std::string& path,
                                         bool map) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto status = fs::status(path, ec);
  const std::string what = "cannot read log '" + path + "': ";
  if (!fs::exists(status)) {
    print_fatal(program, what + "no such file");
    return nullptr;
  }
  if (!fs::is_regular_file(status)) {
    print_fatal(program, what + "not a regular file");
    return nullptr;
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    print_fatal(program, what + std::strerror(errno));
    return nullptr;
  }
  const auto size = fs::file_size(path, ec);
  return std::unique_ptr<LogInput>(
      new LogInput(program, path, f, ec ? -1 : static_cast<int64_t>(size), map));
}

namespace {
// The file mapped when asked for and possible (an empty or unmappable file is read through stdio).
std::unique_ptr<LogByteSource> log_source(const std::string& path, std::FILE* file, bool map) {
  if (map) {
    auto mapped = std::make_unique<MappedFileLogSource>(path);
    if (!mapped->failed()) return mapped;
  }
  return std::make_unique<FileLogSource>(file);
}
}  // namespace

LogInput::LogInput(std::string program, std::string path, std::FILE* file, int64_t size, bool map)
    : program_(std::move(program)),
      path_(std::move(path)),
      file_(file),
      size_(size),
      source_(log_source(path_, file, map)),
      reader_(std::make_unique<LogReader>(*source_)),
      progress_(program_) {}

LogInput::~LogInput() {
  reader_.reset();
  source_.reset();
  std::fclose(file_);
}

const LogEvent* LogInput::next() {
  const LogEvent* e = reader_->next();
  while (e && e->channel.empty()) e = reader_->next();
  if (e && show_progress_ && progress_.enabled() && size_ > 0)
    progress_.update(static_cast<double>(reader_->stats().read_up_to) / static_cast<double>(size_),
                     reader_->stats().events);
  return e;
}

bool LogInput::finish(const std::string& done) {
  progress_.finish();
  const LogReadStats& s = reader_->stats();
  if (size_ > 0 && s.events == 0) {
    print_fatal(program_, "'" + path_ + "' is not an LCM log (no readable event)");
    return false;
  }
  // The warnings every log tool words the same way, each only when it applies.
  const auto ll = [](int64_t v) { return static_cast<long long>(v); };
  const char* prog = program_.c_str();
  const char* path = path_.c_str();
  if (s.empty_channel_events > 0)
    std::fprintf(stderr,
                 "%s: %s: %lld event%s on an empty channel, skipped (legal in LCM; no channel to "
                 "read %s by)\n",
                 prog, path, ll(s.empty_channel_events), s.empty_channel_events == 1 ? "" : "s",
                 s.empty_channel_events == 1 ? "it" : "them");
  if (s.truncated_tail_bytes > 0)
    std::fprintf(stderr,
                 "%s: warning: %s: read %lld events, then stopped at byte %lld of %lld (the log is "
                 "cut short there: its last %lld bytes are an incomplete event); %s\n",
                 prog, path, ll(s.events), ll(s.read_up_to - s.truncated_tail_bytes),
                 ll(s.read_up_to), ll(s.truncated_tail_bytes), done.c_str());
  if (s.garbage_bytes > 0)
    std::fprintf(stderr,
                 "%s: warning: %s: skipped %lld damaged bytes in %lld places and read on after "
                 "them\n",
                 prog, path, ll(s.garbage_bytes), ll(s.resyncs));
  if (s.read_error)
    std::fprintf(stderr, "%s: warning: %s: read error after byte %lld; %s\n", prog, path,
                 ll(s.read_up_to), done.c_str());
  return true;
}

}  // namespace ips
