#pragma once
// What the log tools (ips-eval, ips-replay, ips-export, through core/log_input.hpp) say after
// reading an LCM log with LogReader (core/log_reader.hpp), which reads on past damage.
#include <cstdint>
#include <string>

#include "core/log_reader.hpp"

namespace ips {

// False, after printing "<program>: error: '<path>' is not an LCM log (no readable event)", when
// the file held bytes but not one readable event.
bool log_had_events(const std::string& program, const std::string& path, int64_t events,
                    uintmax_t file_size);

// After reading with LogReader, the warnings every tool words the same way, on stderr:
//   "<program>: warning: <path>: read N events, then stopped at byte B of S (the log is cut short
//    there: its last T bytes are an incomplete event); <done>"
//   "<program>: warning: <path>: skipped G damaged bytes in R places and read on after them"
//   "<program>: warning: <path>: read error after byte B; <done>"
// each only when it applies.
void report_log_damage(const std::string& program, const std::string& path,
                       const LogReadStats& stats, const std::string& done);

}  // namespace ips
