#pragma once
// A one-line verdict per process from the HEALTH messages of a log (ips-eval --health): did each
// process stay OK for the whole run, and if not, when and why. A process is one (source, host,
// pid): a restarted process is a new line.
#include <cstdint>
#include <ips/health_t.hpp>
#include <string>
#include <vector>

#include "core/time.hpp"

namespace ips::eval {

struct ProcessHealth {
  std::string source;
  std::string host;
  int32_t pid = 0;
  std::string version;
  int64_t messages = 0;
  int64_t starting = 0, ok = 0, degraded = 0, error = 0;
  utime_t first_utime = 0, last_utime = 0;          // log times of its first and last HEALTH
  utime_t first_problem_utime = 0;                  // its first DEGRADED or ERROR HEALTH
  std::string first_problem;                        // last_error of that message
  std::string last_problem;                         // last_error of its last DEGRADED/ERROR
  std::string note;                                 // its last note (why it publishes nothing)
  int8_t last_state = health_t::STATE_STARTING;
  int64_t lost = 0;  // kernel + queue drops + sequence gaps, as in its last HEALTH

  // OK: no DEGRADED or ERROR message (STARTING only at the start); else the worst state seen.
  const char* verdict() const;
};

class HealthVerdicts {
 public:
  // `log_utime`: the event's time in the log (the HEALTH's own utime is the sender's clock).
  void add(const health_t& h, utime_t log_utime);
  // In order of first appearance.
  const std::vector<ProcessHealth>& processes() const { return processes_; }
  bool all_ok() const;

 private:
  std::vector<ProcessHealth> processes_;
};

// "ips-uwb-twr      OK        58 HEALTH, all OK" or
// "ips-fuse         DEGRADED  12 of 58 HEALTH degraded from 3.2 s: <text>"; `log_start` for the
// times, seconds from the log's first event. Text is made printable and cut to `max_text` chars.
std::string verdict_line(const ProcessHealth& p, utime_t log_start, size_t max_text = 160);

}  // namespace ips::eval
