#pragma once
// What the log tools (ips-eval, ips-replay, ips-export) say after reading an LCM log: with liblcm,
// which stops quietly at the first event it cannot read, or with LogReader (core/log_reader.hpp),
// which reads on past damage.
#include <cstdint>
#include <string>

#include "core/log_reader.hpp"

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

// After reading with LogReader, the warnings every tool words the same way, on stderr:
//   "<program>: warning: <path>: read N events, then stopped at byte B of S (the log is cut short
//    there: its last T bytes are an incomplete event); <done>"
//   "<program>: warning: <path>: skipped G damaged bytes in R places and read on after them"
//   "<program>: warning: <path>: read error after byte B; <done>"
// each only when it applies.
void report_log_damage(const std::string& program, const std::string& path,
                       const LogReadStats& stats, const std::string& done);

}  // namespace ips
