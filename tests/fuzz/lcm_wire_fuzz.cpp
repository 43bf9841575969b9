// libFuzzer target: LCM's UDP multicast wire format (core/lcm_wire.hpp), the bytes any host on
// the group may send to a process reading it directly (--lcm-receiver direct). The input is a
// stream of datagrams, each a sender byte (8 senders), a big-endian u16 length and that many
// bytes. Invariants: a message is only ever handed out whole (every byte of its payload
// readable, its channel 1 to 63 bytes without a NUL); messages and malformed datagrams never
// outnumber the datagrams; no more messages in flight than senders allowed.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "core/lcm_wire.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ips::LcmReassembler r;
  size_t i = 0;
  while (i + 3 <= size) {
    const uint64_t sender = data[i] % 8;
    size_t len = size_t{data[i + 1]} << 8 | data[i + 2];
    i += 3;
    if (len > size - i) len = size - i;
    ips::LcmReassembler::Message m;
    std::string why;
    const bool whole = r.feed(data + i, len, sender, m, &why);
    if (whole) {
      if (m.channel.empty() || m.channel.size() > ips::LcmReassembler::kMaxChannelBytes ||
          m.channel.find('\0') != std::string::npos)
        throw std::logic_error("a message with a bad channel");
      if (m.size > ips::LcmReassembler::kMaxMessageBytes)
        throw std::logic_error("a message larger than the bound");
      // Every byte handed out is readable (the sanitizers see a read past a buffer).
      volatile uint8_t sum = 0;
      for (size_t k = 0; k < m.size; ++k) sum = static_cast<uint8_t>(sum + m.data[k]);
      if (!why.empty()) throw std::logic_error("a message with a reason for rejection");
    }
    if (r.in_flight() > ips::LcmReassembler::kMaxSenders)
      throw std::logic_error("more messages in flight than senders allowed");
    i += len;
  }
  const auto& c = r.counts();
  if (c.messages < 0 || c.malformed < 0 || c.incomplete < 0 ||
      c.messages + c.malformed > c.datagrams)
    throw std::logic_error("counts do not add up");
  return 0;
}
