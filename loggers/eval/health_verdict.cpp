#include "loggers/eval/health_verdict.hpp"

#include <algorithm>
#include <cstdio>

#include "core/text_escape.hpp"

namespace ips::eval {

const char* ProcessHealth::verdict() const {
  if (error > 0) return "ERROR";
  if (degraded > 0) return "DEGRADED";
  if (ok == 0) return "STARTING";
  return "OK";
}

void HealthVerdicts::add(const health_t& h, utime_t log_utime) {
  auto it = std::find_if(processes_.begin(), processes_.end(), [&](const ProcessHealth& p) {
    return p.source == h.source && p.host == h.host && p.pid == h.pid;
  });
  if (it == processes_.end()) {
    ProcessHealth p;
    p.source = h.source;
    p.host = h.host;
    p.pid = h.pid;
    p.first_utime = log_utime;
    processes_.push_back(std::move(p));
    it = std::prev(processes_.end());
  }
  ProcessHealth& p = *it;
  ++p.messages;
  p.last_utime = log_utime;
  p.last_state = h.state;
  p.version = h.version;
  p.lost = h.kernel_drops + h.queue_drops + h.seq_lost;
  if (!h.note.empty()) p.note = h.note;
  switch (h.state) {
    case health_t::STATE_OK: ++p.ok; break;
    case health_t::STATE_STARTING: ++p.starting; break;
    case health_t::STATE_DEGRADED:
    case health_t::STATE_ERROR:
    default:
      if (h.state == health_t::STATE_ERROR) ++p.error; else ++p.degraded;
      if (p.degraded + p.error == 1) {
        p.first_problem_utime = log_utime;
        p.first_problem = h.last_error;
      }
      p.last_problem = h.last_error;
      break;
  }
}

bool HealthVerdicts::all_ok() const {
  return !processes_.empty() &&
         std::all_of(processes_.begin(), processes_.end(),
                     [](const ProcessHealth& p) { return std::string(p.verdict()) == "OK"; });
}

namespace {

std::string cut(const std::string& text, size_t max_text) {
  std::string s = printable(text);
  if (s.size() > max_text) s = s.substr(0, max_text > 3 ? max_text - 3 : 0) + "...";
  return s;
}

}  // namespace

std::string verdict_line(const ProcessHealth& p, utime_t log_start, size_t max_text) {
  char head[96];
  std::snprintf(head, sizeof head, "%-20s %-9s ", cut(p.source, 20).c_str(), p.verdict());
  std::string line = head;
  char buf[160];
  const std::string v = p.verdict();
  if (v == "OK") {
    std::snprintf(buf, sizeof buf, "%lld HEALTH, all OK", static_cast<long long>(p.messages));
    line += buf;
    if (p.starting > 0) {
      std::snprintf(buf, sizeof buf, " after %lld starting", static_cast<long long>(p.starting));
      line += buf;
    }
    if (!p.note.empty()) line += "; note: " + cut(p.note, max_text);
  } else if (v == "STARTING") {
    std::snprintf(buf, sizeof buf, "%lld HEALTH, never past starting",
                  static_cast<long long>(p.messages));
    line += buf;
    if (!p.note.empty()) line += "; note: " + cut(p.note, max_text);
  } else {
    std::snprintf(buf, sizeof buf, "%lld of %lld HEALTH %s from %.1f s",
                  static_cast<long long>(p.degraded + p.error), static_cast<long long>(p.messages),
                  p.error > 0 ? "degraded or in error" : "degraded",
                  utime_to_s(p.first_problem_utime - log_start));
    line += buf;
    line += ": " + cut(p.first_problem.empty() ? p.last_problem : p.first_problem, max_text);
    if (p.last_state == health_t::STATE_OK) line += " (OK again at the end)";
  }
  return line;
}

}  // namespace ips::eval
