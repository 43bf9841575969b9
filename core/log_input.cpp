#include "core/log_input.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/cli.hpp"
#include "core/log_read_report.hpp"

namespace ips {

std::unique_ptr<LogInput> LogInput::open(const std::string& program, const std::string& path) {
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
      new LogInput(program, path, f, ec ? -1 : static_cast<int64_t>(size)));
}

LogInput::LogInput(std::string program, std::string path, std::FILE* file, int64_t size)
    : program_(std::move(program)),
      path_(std::move(path)),
      file_(file),
      size_(size),
      source_(std::make_unique<FileLogSource>(file)),
      reader_(std::make_unique<LogReader>(*source_)),
      progress_(program_) {}

LogInput::~LogInput() {
  reader_.reset();
  source_.reset();
  std::fclose(file_);
}

const LogEvent* LogInput::next() {
  const LogEvent* e = reader_->next();
  if (e && progress_.enabled() && size_ > 0)
    progress_.update(static_cast<double>(reader_->stats().read_up_to) / static_cast<double>(size_),
                     reader_->stats().events);
  return e;
}

bool LogInput::finish(const std::string& done) {
  progress_.finish();
  const auto& s = reader_->stats();
  if (!log_had_events(program_, path_, s.events, static_cast<uintmax_t>(std::max<int64_t>(0, size_))))
    return false;
  report_log_damage(program_, path_, s, done);
  return true;
}

}  // namespace ips
