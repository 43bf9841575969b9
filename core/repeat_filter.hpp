#pragma once
// A message delivered twice. A LAN copies datagrams now and then (a switch's flood during a
// topology change, a bridge loop, a Wi-Fi retransmission whose acknowledgement was lost), and a
// driver that retries may send one reading again: the soak's switch repeats 0.5 % of them. A
// filter that takes the copy fuses one measurement twice, as if it were twice as sure of it.
//
// RecentRepeats keeps the keys of a sender's last few messages (a copy follows its original
// closely) and says whether a key is among them. The key is what makes a reading that reading:
// its time stamp, the device's sequence number, the other end (an anchor) and its value, so that
// two different readings stamped in the same microsecond (a driver that stamps a batch of lines
// with one read's time) are both kept. Pure, fixed size, no allocation.
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace ips {

// A 64-bit key of a reading from its parts (splitmix64 over each).
inline uint64_t repeat_key(int64_t utime, int64_t seq, int64_t peer, double value) {
  auto mix = [](uint64_t h, uint64_t v) {
    uint64_t z = h + v + 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  };
  uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof bits);
  uint64_t h = mix(0, static_cast<uint64_t>(utime));
  h = mix(h, static_cast<uint64_t>(seq));
  h = mix(h, static_cast<uint64_t>(peer));
  return mix(h, bits);
}

class RecentRepeats {
 public:
  static constexpr size_t kSize = 16;  // a tag's last 16 ranges: 0.2 s of 8 anchors at 10 Hz

  // True when `key` was among the last kSize keys given (the message is a copy); otherwise it
  // is remembered, the oldest forgotten, and false returned.
  bool repeated(uint64_t key) {
    for (size_t i = 0; i < count_; ++i)
      if (keys_[i] == key) return true;
    keys_[next_] = key;
    next_ = (next_ + 1) % kSize;
    if (count_ < kSize) ++count_;
    return false;
  }

 private:
  std::array<uint64_t, kSize> keys_{};
  size_t next_ = 0;
  size_t count_ = 0;
};

}  // namespace ips
