#pragma once
// LCM's UDP multicast wire format, the receiving side (the protocol liblcm 1.3 speaks on udpm://;
// lcm-proj's "UDP Multicast Protocol Description"): a small message is one datagram, "LC02",
// the sender's sequence number, the channel NUL-terminated, the payload; a larger one is split
// into "LC03" fragments (sequence number, payload size, the fragment's offset in the payload,
// its number and the count; fragment 0 carries the channel before its share of the payload).
// Pure: bytes in, whole messages out, every datagram that is not one of these counted by reason.
// Memory: the fragments received of each sender's message in flight, at most kMaxSenders of
// them and kMaxInFlightBytes in all, and the last message assembled.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace ips {

struct LcmWireCounts {
  int64_t datagrams = 0;        // fed in
  int64_t messages = 0;         // whole messages out
  int64_t malformed = 0;        // datagrams that are not LCM's (or break its rules): dropped
  int64_t incomplete = 0;       // fragmented messages given up (a fragment lost or too late)
  int64_t too_large = 0;        // fragmented messages over kMaxMessageBytes: not assembled
};

class LcmReassembler {
 public:
  // liblcm's longest channel name (LCM_MAX_CHANNEL_NAME_LENGTH).
  static constexpr size_t kMaxChannelBytes = 63;
  // The largest fragmented message assembled (a SITE with thousands of zones is a few 100 kB),
  // and all those in flight together.
  static constexpr uint32_t kMaxMessageBytes = 16u << 20;
  static constexpr size_t kMaxInFlightBytes = 64u << 20;
  // The largest UDP payload: a fragment count too small for the size it claims is malformed.
  static constexpr size_t kMaxDatagramBytes = 65507;
  // Senders with a fragmented message in flight at once; the one heard least recently makes room.
  static constexpr size_t kMaxSenders = 16;

  struct Message {
    std::string_view channel;
    const uint8_t* data = nullptr;
    size_t size = 0;
    uint32_t seqno = 0;  // the sender's LCM sequence number (one per message)
  };

  // One datagram from `sender` (any key naming the sending socket: its address and port). True
  // with `out` set when it completes a message; `out` points into `data` (a small message) or
  // into this object (a fragmented one) and stays valid until the next feed(). A
  // datagram that is not LCM's is counted as malformed and `why` (when given) says why.
  bool feed(const uint8_t* data, size_t size, uint64_t sender, Message& out,
            std::string* why = nullptr);

  const LcmWireCounts& counts() const { return counts_; }
  // Fragmented messages still waiting for fragments, and the bytes of theirs held.
  size_t in_flight() const;
  size_t in_flight_bytes() const { return in_flight_bytes_; }

 private:
  struct Partial {
    uint64_t sender = 0;
    bool active = false;
    uint32_t seqno = 0;
    uint32_t size = 0;
    uint16_t fragments = 0;
    uint16_t received = 0;
    uint64_t last_used = 0;
    std::string channel;
    // The fragments' bytes as they came (a header claiming megabytes costs only what arrives),
    // and where each goes: put together when the last one comes.
    struct Piece {
      uint32_t offset;  // in the message's payload
      uint32_t at;      // in `stored`
      uint32_t length;
    };
    std::vector<uint8_t> stored;
    std::vector<Piece> pieces;
    std::vector<bool> have;  // which fragments arrived (a duplicate is not counted twice)
  };
  bool feed_fragment(const uint8_t* data, size_t size, uint64_t sender, Message& out,
                     std::string* why);
  Partial& partial_for(uint64_t sender);
  bool malformed(std::string* why, const char* reason);
  void give_up(Partial& p);

  std::vector<Partial> partials_;
  uint64_t clock_ = 0;
  size_t in_flight_bytes_ = 0;
  std::vector<uint8_t> done_;  // the last assembled message (out.data points here)
  std::string done_channel_;
  LcmWireCounts counts_;
};

}  // namespace ips
