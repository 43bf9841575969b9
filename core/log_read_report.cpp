#include "core/log_read_report.hpp"

#include <cstdio>

#include "core/cli.hpp"

namespace ips {

bool log_had_events(const std::string& program, const std::string& path, int64_t events,
                    uintmax_t file_size) {
  if (file_size == 0 || events > 0) return true;
  print_fatal(program, "'" + path + "' is not an LCM log (no readable event)");
  return false;
}

void report_log_damage(const std::string& program, const std::string& path,
                       const LogReadStats& stats, const std::string& done) {
  const auto ll = [](int64_t v) { return static_cast<long long>(v); };
  if (stats.truncated_tail_bytes > 0)
    std::fprintf(stderr,
                 "%s: warning: %s: read %lld events, then stopped at byte %lld of %lld (the log is "
                 "cut short there: its last %lld bytes are an incomplete event); %s\n",
                 program.c_str(), path.c_str(), ll(stats.events),
                 ll(stats.read_up_to - stats.truncated_tail_bytes), ll(stats.read_up_to),
                 ll(stats.truncated_tail_bytes), done.c_str());
  if (stats.garbage_bytes > 0)
    std::fprintf(stderr,
                 "%s: warning: %s: skipped %lld damaged bytes in %lld places and read on after "
                 "them\n",
                 program.c_str(), path.c_str(), ll(stats.garbage_bytes), ll(stats.resyncs));
  if (stats.read_error)
    std::fprintf(stderr, "%s: warning: %s: read error after byte %lld; %s\n", program.c_str(),
                 path.c_str(), ll(stats.read_up_to), done.c_str());
}

}  // namespace ips
