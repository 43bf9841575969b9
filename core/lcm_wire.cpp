#include "core/lcm_wire.hpp"

#include <algorithm>
#include <cstring>

namespace ips {

namespace {
constexpr uint32_t kMagicShort = 0x4c433032;  // "LC02"
constexpr uint32_t kMagicLong = 0x4c433033;   // "LC03"
constexpr size_t kShortHeader = 8;
constexpr size_t kLongHeader = 20;

uint32_t be32(const uint8_t* p) {
  return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 | uint32_t{p[3]};
}
uint16_t be16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }

// The NUL-terminated channel at `p` (at most `n` bytes to look at): its length, or -1 when there
// is no NUL within LCM's longest name, or the name is empty.
long channel_length(const uint8_t* p, size_t n) {
  const size_t look = std::min(n, LcmReassembler::kMaxChannelBytes + 1);
  const void* nul = std::memchr(p, 0, look);
  if (!nul) return -1;
  const long len = static_cast<const uint8_t*>(nul) - p;
  return len > 0 ? len : -1;
}
}  // namespace

bool LcmReassembler::malformed(std::string* why, const char* reason) {
  ++counts_.malformed;
  if (why) *why = reason;
  return false;
}

bool LcmReassembler::feed(const uint8_t* data, size_t size, uint64_t sender, Message& out,
                          std::string* why) {
  ++counts_.datagrams;
  if (size < kShortHeader) return malformed(why, "shorter than an LCM header");
  const uint32_t magic = be32(data);
  if (magic == kMagicLong) return feed_fragment(data, size, sender, out, why);
  if (magic != kMagicShort) return malformed(why, "not an LCM datagram (magic)");
  const long chan = channel_length(data + kShortHeader, size - kShortHeader);
  if (chan < 0) return malformed(why, "no channel name of 1 to 63 bytes");
  const size_t at = kShortHeader + static_cast<size_t>(chan) + 1;
  out.channel = std::string_view(reinterpret_cast<const char*>(data + kShortHeader),
                                 static_cast<size_t>(chan));
  out.data = data + at;
  out.size = size - at;
  out.seqno = be32(data + 4);
  ++counts_.messages;
  return true;
}

size_t LcmReassembler::in_flight() const {
  return static_cast<size_t>(
      std::count_if(partials_.begin(), partials_.end(), [](const Partial& p) { return p.active; }));
}

void LcmReassembler::give_up(Partial& p) {
  if (!p.active) return;
  ++counts_.incomplete;
  p.active = false;
  in_flight_bytes_ -= p.stored.size();
  p.stored = std::vector<uint8_t>();
  p.pieces.clear();
}

LcmReassembler::Partial& LcmReassembler::partial_for(uint64_t sender) {
  for (auto& p : partials_)
    if (p.sender == sender) return p;
  if (partials_.size() < kMaxSenders) {
    partials_.emplace_back();
    partials_.back().sender = sender;
    return partials_.back();
  }
  // The sender heard least recently gives its slot (and what it had in flight) up.
  auto oldest = std::min_element(
      partials_.begin(), partials_.end(),
      [](const Partial& a, const Partial& b) { return a.last_used < b.last_used; });
  give_up(*oldest);
  oldest->sender = sender;
  return *oldest;
}

bool LcmReassembler::feed_fragment(const uint8_t* data, size_t size, uint64_t sender,
                                   Message& out, std::string* why) {
  if (size < kLongHeader) return malformed(why, "shorter than an LCM fragment header");
  const uint32_t seqno = be32(data + 4);
  const uint32_t msg_size = be32(data + 8);
  const uint32_t offset = be32(data + 12);
  const uint16_t number = be16(data + 16);
  const uint16_t fragments = be16(data + 18);
  if (fragments == 0 || number >= fragments)
    return malformed(why, "fragment number out of its count");
  if (msg_size > uint64_t{fragments} * kMaxDatagramBytes)
    return malformed(why, "fragment count too small for the message size");
  size_t at = kLongHeader;
  long chan = 0;
  if (number == 0) {
    chan = channel_length(data + at, size - at);
    if (chan < 0) return malformed(why, "first fragment without a channel name of 1 to 63 bytes");
    at += static_cast<size_t>(chan) + 1;
  }
  const size_t len = size - at;
  if (uint64_t{offset} + len > msg_size) return malformed(why, "fragment past the message's end");
  if (msg_size > kMaxMessageBytes) {
    // Counted once per message (at its first fragment), not assembled.
    if (number == 0) ++counts_.too_large;
    if (why) *why = "fragmented message larger than 16 MiB";
    return false;
  }

  Partial& p = partial_for(sender);
  p.last_used = ++clock_;
  if (p.active && (p.seqno != seqno || p.size != msg_size || p.fragments != fragments)) {
    // A new message from this sender while the last one lacks fragments: those are lost (one
    // message in flight per sender, as liblcm keeps it).
    give_up(p);
  }
  if (!p.active) {
    p.active = true;
    p.seqno = seqno;
    p.size = msg_size;
    p.fragments = fragments;
    p.received = 0;
    p.channel.clear();
    p.stored.clear();
    p.pieces.clear();
    p.have.assign(fragments, false);
  }
  if (p.have[number]) return false;  // a duplicate: the kernel or a switch sent it twice
  // Room for it: the senders heard least recently give up what they hold.
  while (in_flight_bytes_ + len > kMaxInFlightBytes) {
    auto oldest = partials_.end();
    for (auto it = partials_.begin(); it != partials_.end(); ++it)
      if (it->active && &*it != &p && !it->stored.empty() &&
          (oldest == partials_.end() || it->last_used < oldest->last_used))
        oldest = it;
    if (oldest == partials_.end()) break;
    give_up(*oldest);
  }
  p.have[number] = true;
  ++p.received;
  if (number == 0)
    p.channel.assign(reinterpret_cast<const char*>(data + kLongHeader), static_cast<size_t>(chan));
  p.pieces.push_back({offset, static_cast<uint32_t>(p.stored.size()), static_cast<uint32_t>(len)});
  p.stored.insert(p.stored.end(), data + at, data + size);
  in_flight_bytes_ += len;
  if (p.received < p.fragments) return false;
  // Every fragment came: they must tile the payload, end to end, from 0 to its size.
  std::sort(p.pieces.begin(), p.pieces.end(),
            [](const Partial::Piece& a, const Partial::Piece& b) { return a.offset < b.offset; });
  uint64_t end = 0;
  for (const auto& piece : p.pieces) {
    if (piece.offset != end) break;
    end += piece.length;
  }
  const bool whole = end == p.size;
  if (whole) {
    done_.resize(p.size);
    for (const auto& piece : p.pieces)
      if (piece.length > 0)
        std::memcpy(done_.data() + piece.offset, p.stored.data() + piece.at, piece.length);
    done_channel_ = p.channel;
  }
  p.active = false;
  in_flight_bytes_ -= p.stored.size();
  p.stored.clear();
  p.pieces.clear();
  if (p.stored.capacity() > (1u << 20)) p.stored = std::vector<uint8_t>();  // a big one: let go
  if (!whole)  // overlapping or short fragments
    return malformed(why, "fragments do not add up to the message size");
  out.channel = done_channel_;
  out.data = done_.data();
  out.size = done_.size();
  out.seqno = seqno;
  ++counts_.messages;
  return true;
}

}  // namespace ips
