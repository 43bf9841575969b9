// libFuzzer target: arbitrary bytes as an LCM log replayed by ips-replay (loggers/replay/
// replayer.hpp) four ways: by one host, in one lane, in three lanes on one worker thread and in
// three lanes on three. Every event's bytes are outside bytes: each lane's dispatcher decodes
// them to find the tag, the lanes' estimators and the merging ips-zones decode them again. None
// may crash; one lane must write the bytes one host writes, and three lanes the same bytes on any
// number of threads. Seeds: short simulated lab logs (a site, ranges, receptions, angles, IMU,
// barometers, truth) and damaged copies.
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/cli.hpp"
#include "core/log_reader.hpp"
#include "loggers/replay/replayer.hpp"

namespace {

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

// The sink's calls, as one byte string: channel, timestamp, size, bytes.
std::string replay(std::span<const uint8_t> log, int lanes, int threads) {
  ips::replay::ReplayOptions ro;
  ro.lanes = lanes;
  ro.threads = threads;
  std::string out;
  ips::replay::Replayer r(
      ro, ips::CommonOptions{},
      [&](const std::string& channel, int64_t timestamp, const uint8_t* data, size_t size) {
        out += channel;
        out += '\0';
        out.append(reinterpret_cast<const char*>(&timestamp), sizeof timestamp);
        out.append(reinterpret_cast<const char*>(&size), sizeof size);
        out.append(reinterpret_cast<const char*>(data), size);
      });
  // In place: the events' bytes stay where they are until the end, as from a mapped log.
  ips::MemoryLogSource source(log, log.size(), true, true);
  ips::LogReader reader(source);
  while (const ips::LogEvent* e = reader.next())
    r.process(e->channel, e->timestamp_us, e->data, e->size, true);
  r.finish();
  const auto s = r.stats();
  check(s.events_in >= 0 && s.passed_through + s.dropped_regenerated == s.events_in,
        "every input written or dropped as regenerated");
  return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (size_t{1} << 20)) return 0;
  const std::span<const uint8_t> log(data, size);
  const std::string one_host = replay(log, 0, 1);
  check(replay(log, 1, 1) == one_host, "one lane differs from one host");
  const std::string three = replay(log, 3, 1);
  check(replay(log, 3, 3) == three, "three lanes differ between one thread and three");
  return 0;
}
