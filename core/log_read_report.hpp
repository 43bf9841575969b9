#pragma once
// What the log tools (ips-eval, ips-replay, ips-export) say after reading an LCM log with liblcm,
// which stops quietly at the first event it cannot read.
#include <cstdint>
#include <string>

namespace ips {

// False, after printing "<program>: error: '<path>' is not an LCM log (no readable event)", when
// the file held bytes but not one readable event.
bool log_had_events(const std::string& program, const std::string& path, int64_t events,
                    uintmax_t file_size);

// Warns when reading stopped at read_up_to before the end of the file (a log cut short by a
// killed recorder, or damaged). `done` says what the tool did with the rest, e.g. "scoring what
// was read".
void warn_if_log_cut(const std::string& program, const std::string& path, int64_t events,
                     long read_up_to, uintmax_t file_size, const std::string& done);

}  // namespace ips
