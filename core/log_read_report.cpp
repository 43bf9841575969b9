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

void warn_if_log_cut(const std::string& program, const std::string& path, int64_t events,
                     long read_up_to, uintmax_t file_size, const std::string& done) {
  if (read_up_to < 0 || static_cast<uintmax_t>(read_up_to) >= file_size) return;
  std::fprintf(stderr,
               "%s: warning: %s: read %lld events, then stopped at byte %ld of %ju (the log is "
               "cut short or damaged there); %s\n",
               program.c_str(), path.c_str(), static_cast<long long>(events), read_up_to,
               file_size, done.c_str());
}

}  // namespace ips
