#include "core/import_output.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <lcm/lcm-cpp.hpp>

#include "core/text_escape.hpp"
#include "core/paced_release.hpp"

namespace ips {

uint32_t ImportOutput::channel_index(const std::string& channel) {
  for (size_t i = 0; i < channels_.size(); ++i)
    if (channels_[i] == channel) return static_cast<uint32_t>(i);
  channels_.push_back(channel);
  return static_cast<uint32_t>(channels_.size() - 1);
}

void ImportOutput::sort() {
  std::stable_sort(held_.begin(), held_.end(),
                   [](const Held& a, const Held& b) { return a.utime < b.utime; });
}

int64_t ImportOutput::first_utime() const {
  int64_t t = 0;
  for (size_t i = 0; i < held_.size(); ++i)
    if (i == 0 || held_[i].utime < t) t = held_[i].utime;
  return t;
}

int64_t ImportOutput::last_utime() const {
  int64_t t = 0;
  for (size_t i = 0; i < held_.size(); ++i)
    if (i == 0 || held_[i].utime > t) t = held_[i].utime;
  return t;
}

void ImportOutput::for_each(const std::function<void(const std::string&, int64_t,
                                                     const std::vector<uint8_t>&)>& fn) {
  sort();
  for (const Held& h : held_) fn(channels_[h.channel], h.utime, h.bytes);
}

std::string ImportOutput::write_log(const std::string& path) {
  sort();
  errno = 0;
  lcm::LogFile log(path, "w");
  if (!log.good())
    return "cannot write '" + printable(path) + "': " +
           (errno ? std::strerror(errno) : "cannot open");
  int64_t eventnum = 0;
  for (Held& h : held_) {
    lcm::LogEvent le;
    le.eventnum = eventnum++;
    le.timestamp = h.utime;
    le.channel = channels_[h.channel];
    le.datalen = static_cast<int32_t>(h.bytes.size());
    le.data = h.bytes.data();
    if (log.writeEvent(&le) != 0) return "write to '" + printable(path) + "' failed (disk full?)";
  }
  if (std::fflush(log.getFilePtr()) != 0 || std::ferror(log.getFilePtr()))
    return "write to '" + printable(path) + "' failed (disk full?)";
  return "";
}

bool ImportOutput::publish(Node& node, double speed) {
  sort();
  PacedRelease pace(node, speed);
  for (const Held& h : held_) {
    if (!pace.wait(h.utime)) return false;
    node.publish_raw(channels_[h.channel], h.bytes.data(), h.bytes.size());
  }
  return true;
}

std::string utc_text(int64_t utime) {
  const std::time_t s = static_cast<std::time_t>(utime / 1'000'000);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

int write_or_publish(const std::string& program, ImportOutput& output, const std::string& out_path,
                     const CommonOptions& opts, double speed, const ImportCounts& counts,
                     const std::function<void(Node&)>& on_bus, const std::function<void()>& done) {
  if (!out_path.empty()) {
    if (const std::string error = output.write_log(out_path); !error.empty()) {
      print_fatal(program, "--out: " + error);
      return 1;
    }
    if (done) done();
    return 0;
  }
  return run_reporting_errors(program, [&] {
    Node node(program, opts);
    node.counters().msgs_in += counts.lines;
    node.counters().parse_errors += counts.parse_errors;
    node.counters().drops += counts.drops;
    if (on_bus) on_bus(node);
    if (!output.publish(node, speed)) return 0;  // SIGINT/SIGTERM
    node.publish_health();
    if (done) done();
    return 0;
  });
}

}  // namespace ips
