// libFuzzer target: the loss counters' inputs. The bytes as /proc/net/udp text
// (core/socket_drops.hpp: rows parsed never carry negative drops; the drop total never goes down
// over successive readings), and as a stream of (key, seq) pairs off the bus through
// core/seq_loss.hpp (counts never negative; every numbered message counted once as received or
// unknown).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>

#include "core/seq_loss.hpp"
#include "core/socket_drops.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto rows = ips::parse_proc_net_udp(text);
  ips::KernelDropCounter drops;
  int64_t before = 0;
  for (size_t cut = 0; cut <= size; cut += size / 4 + 1) {
    const int64_t total = drops.update(ips::parse_proc_net_udp(text.substr(0, cut)));
    if (total < before) throw std::logic_error("kernel drop total went down");
    before = total;
  }
  for (const auto& [inode, row] : rows)
    if (row.drops < 0) throw std::logic_error("negative drops parsed");

  // 5-byte records: a key byte (8 senders) and a big-endian int32 sequence number.
  ips::SeqLossCounter seq;
  int64_t fed = 0;
  for (size_t i = 0; i + 5 <= size; i += 5) {
    uint32_t u = 0;
    std::memcpy(&u, data + i + 1, 4);
    const int32_t s = static_cast<int32_t>(__builtin_bswap32(u));
    seq.observe(std::string(1, static_cast<char>('a' + (data[i] & 7))), s < 0 ? -1 : s);
    ++fed;
  }
  const auto& c = seq.counts();
  if (c.lost < 0 || c.late < 0 || c.restarts < 0 || c.received + c.unknown != fed)
    throw std::logic_error("sequence counts inconsistent");
  return 0;
}
