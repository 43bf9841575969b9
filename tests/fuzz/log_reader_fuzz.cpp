// libFuzzer target: arbitrary bytes as an LCM log file (core/log_reader.hpp). Checks that every
// byte is counted once (events + garbage + cut tail == input size), that every event returned is
// really in the input where it says (magic word, a channel of 1 to 63 bytes, its data), in order
// and without overlap, and that reading in small pieces from a source of unknown size (a pipe)
// gives exactly what reading the whole input at once does, and so does reading it in place (a
// mapped file).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/log_reader.hpp"

namespace {

struct Seen {
  int64_t eventnum, timestamp_us, offset;
  std::string channel;
  size_t size;
  bool operator==(const Seen&) const = default;
};

void check(bool ok, const char* what) {
  if (!ok) throw std::logic_error(what);
}

std::vector<Seen> read_checked(std::span<const uint8_t> input, size_t chunk, size_t max_read,
                               bool size_known, ips::LogReadStats& stats, bool in_place = false) {
  ips::MemoryLogSource source(input, max_read, size_known, in_place);
  ips::LogReader reader(source, chunk);
  std::vector<Seen> seen;
  int64_t next_free = 0, event_bytes = 0;
  while (const ips::LogEvent* e = reader.next()) {
    const size_t channel_len = e->channel.size();
    check(channel_len <= ips::LogReader::kMaxChannelLength, "channel length");  // 0: legal
    check(e->size <= static_cast<size_t>(ips::LogReader::kMaxDataLength), "data length");
    check(e->offset >= next_free, "events overlap or go backwards");
    const size_t at = static_cast<size_t>(e->offset);
    const size_t total = ips::LogReader::kHeaderBytes + channel_len + e->size;
    check(at + total <= input.size(), "event past the end of the input");
    const uint8_t* p = input.data() + at;
    check(std::memcmp(p, "\xED\xA1\xDA\x01", 4) == 0, "no magic word at the event");
    check(std::memcmp(p + 28, e->channel.data(), channel_len) == 0, "channel bytes");
    check(e->size == 0 || std::memcmp(p + 28 + channel_len, e->data, e->size) == 0, "data bytes");
    next_free = e->offset + static_cast<int64_t>(total);
    event_bytes += static_cast<int64_t>(total);
    seen.push_back({e->eventnum, e->timestamp_us, e->offset, e->channel, e->size});
  }
  check(reader.next() == nullptr, "an event after the end");
  stats = reader.stats();
  const auto n = static_cast<int64_t>(input.size());
  check(stats.events == static_cast<int64_t>(seen.size()), "event count");
  check(stats.event_bytes == event_bytes, "event bytes");
  check(stats.event_bytes + stats.garbage_bytes + stats.truncated_tail_bytes == n,
        "bytes not counted once");
  check(stats.read_up_to == n, "not read to the end");
  check(stats.garbage_bytes >= 0 && stats.truncated_tail_bytes >= 0, "negative count");
  check((stats.garbage_bytes == 0) == (stats.resyncs == 0), "garbage without a resync");
  check(stats.resyncs <= stats.garbage_bytes, "more resyncs than garbage bytes");
  check(!stats.read_error, "read error from memory");
  return seen;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> input(data, size);
  ips::LogReadStats whole{}, pieces{}, in_place{};
  const auto a = read_checked(input, size_t{1} << 20, SIZE_MAX, true, whole);
  const auto b = read_checked(input, 1 + size % 61, 1 + size % 7, false, pieces);
  const auto c =
      size > 0 ? read_checked(input, size_t{1} << 20, SIZE_MAX, true, in_place, true) : a;
  if (size == 0) in_place = whole;
  check(a == b && a == c, "events depend on how the input is read");
  for (const ips::LogReadStats* s : {&pieces, &in_place})
    check(whole.garbage_bytes == s->garbage_bytes && whole.resyncs == s->resyncs &&
              whole.truncated_tail_bytes == s->truncated_tail_bytes,
          "counts depend on how the input is read");
  return 0;
}
