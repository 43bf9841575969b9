// LCM's UDP multicast wire format as liblcm 1.3.1 sends it. The datagrams below are built the
// way lcm-logplayer was seen to send a 150 000-byte message (captured on a loopback group):
// three LC03 fragments of 65 507, 65 507 and 19 054 bytes, msg_size the payload's size,
// fragment_offset the payload's offset (0, 65 479, 130 966), the channel in fragment 0 only.
#include "core/lcm_wire.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace ips {
namespace {

using Bytes = std::vector<uint8_t>;

void put32(Bytes& b, uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<uint8_t>(v >> s));
}
void put16(Bytes& b, uint16_t v) {
  b.push_back(static_cast<uint8_t>(v >> 8));
  b.push_back(static_cast<uint8_t>(v));
}

Bytes small(uint32_t seq, const std::string& channel, const Bytes& payload) {
  Bytes b;
  put32(b, 0x4c433032);
  put32(b, seq);
  b.insert(b.end(), channel.begin(), channel.end());
  b.push_back(0);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

Bytes payload_of(size_t n) {
  Bytes p(n);
  for (size_t i = 0; i < n; ++i) p[i] = static_cast<uint8_t>((i * 7 + 3) % 251);
  return p;
}

// liblcm's fragmentation: each datagram at most 65 507 bytes (20 of header), the channel and
// its NUL taking room in the first.
std::vector<Bytes> fragments(uint32_t seq, const std::string& channel, const Bytes& payload) {
  constexpr size_t kMax = 65507 - 20;
  std::vector<Bytes> out;
  size_t offset = 0;
  const size_t first = kMax - channel.size() - 1;
  const size_t n = 1 + (payload.size() > first ? (payload.size() - first + kMax - 1) / kMax : 0);
  for (size_t k = 0; k < n; ++k) {
    const size_t len = std::min(payload.size() - offset, k == 0 ? first : kMax);
    Bytes b;
    put32(b, 0x4c433033);
    put32(b, seq);
    put32(b, static_cast<uint32_t>(payload.size()));
    put32(b, static_cast<uint32_t>(offset));
    put16(b, static_cast<uint16_t>(k));
    put16(b, static_cast<uint16_t>(n));
    if (k == 0) {
      b.insert(b.end(), channel.begin(), channel.end());
      b.push_back(0);
    }
    b.insert(b.end(), payload.begin() + static_cast<long>(offset),
             payload.begin() + static_cast<long>(offset + len));
    offset += len;
    out.push_back(std::move(b));
  }
  return out;
}

bool feed(LcmReassembler& r, const Bytes& d, uint64_t sender, LcmReassembler::Message& m,
          std::string* why = nullptr) {
  return r.feed(d.data(), d.size(), sender, m, why);
}

Bytes bytes_of(const LcmReassembler::Message& m) { return Bytes(m.data, m.data + m.size); }

TEST(LcmWire, ASmallMessageIsItsChannelAndPayloadInPlace) {
  LcmReassembler r;
  const Bytes d = small(42, "UWB_RANGE", {1, 2, 3, 4, 5});
  LcmReassembler::Message m;
  ASSERT_TRUE(feed(r, d, 1, m));
  EXPECT_EQ(m.channel, "UWB_RANGE");
  EXPECT_EQ(m.seqno, 42u);
  EXPECT_EQ(bytes_of(m), (Bytes{1, 2, 3, 4, 5}));
  EXPECT_EQ(m.data, d.data() + 18);  // no copy
  EXPECT_EQ(r.counts().messages, 1);
}

TEST(LcmWire, AnEmptyPayloadAndTheLongestChannelAreMessages) {
  LcmReassembler r;
  LcmReassembler::Message m;
  const Bytes empty = small(1, "S", {});
  ASSERT_TRUE(feed(r, empty, 1, m));
  EXPECT_EQ(m.size, 0u);
  const std::string longest(63, 'C');
  const Bytes named = small(2, longest, {9});  // m points into it
  ASSERT_TRUE(feed(r, named, 1, m));
  EXPECT_EQ(m.channel, longest);
  std::string why;
  EXPECT_FALSE(feed(r, small(3, longest + "C", {9}), 1, m, &why));
  EXPECT_EQ(why, "no channel name of 1 to 63 bytes");
  EXPECT_FALSE(feed(r, small(4, "", {9}), 1, m, &why));
  EXPECT_EQ(r.counts().malformed, 2);
}

TEST(LcmWire, FragmentsAsLiblcmSendsThemMakeTheWholeMessage) {
  const Bytes payload = payload_of(150000);
  const auto frags = fragments(7, "BIGCHAN", payload);
  ASSERT_EQ(frags.size(), 3u);
  EXPECT_EQ(frags[0].size(), 65507u);
  EXPECT_EQ(frags[1].size(), 65507u);
  EXPECT_EQ(frags[2].size(), 19054u);
  LcmReassembler r;
  LcmReassembler::Message m;
  EXPECT_FALSE(feed(r, frags[0], 5, m));
  EXPECT_FALSE(feed(r, frags[1], 5, m));
  EXPECT_EQ(r.in_flight(), 1u);
  ASSERT_TRUE(feed(r, frags[2], 5, m));
  EXPECT_EQ(m.channel, "BIGCHAN");
  EXPECT_EQ(m.seqno, 7u);
  EXPECT_EQ(bytes_of(m), payload);
  EXPECT_EQ(r.in_flight(), 0u);
  EXPECT_EQ(r.counts().malformed + r.counts().incomplete, 0);
}

TEST(LcmWire, ReorderedAndDuplicatedFragmentsStillMakeOneMessage) {
  const Bytes payload = payload_of(200000);
  const auto f = fragments(9, "SITE", payload);
  ASSERT_EQ(f.size(), 4u);
  LcmReassembler r;
  LcmReassembler::Message m;
  int whole = 0;
  for (const Bytes* d : {&f[2], &f[2], &f[0], &f[3], &f[0], &f[1], &f[1]}) {
    if (feed(r, *d, 3, m)) {
      ++whole;
      EXPECT_EQ(m.channel, "SITE");
      EXPECT_EQ(bytes_of(m), payload);
    }
  }
  EXPECT_EQ(whole, 1);
  EXPECT_EQ(r.counts().messages, 1);
}

TEST(LcmWire, SendersAreAssembledApartAndALostFragmentIsCounted) {
  const Bytes pa = payload_of(100000), pb = payload_of(90000);
  const auto a = fragments(1, "A", pa), b = fragments(1, "B", pb);
  LcmReassembler r;
  LcmReassembler::Message m;
  EXPECT_FALSE(feed(r, a[0], 100, m));
  EXPECT_FALSE(feed(r, b[0], 200, m));
  ASSERT_TRUE(feed(r, b[1], 200, m));
  EXPECT_EQ(m.channel, "B");
  EXPECT_EQ(bytes_of(m), pb);
  // Sender 100's second fragment never comes; its next message gives the first up.
  const auto a2 = fragments(2, "A", pa);
  EXPECT_FALSE(feed(r, a2[0], 100, m));
  EXPECT_EQ(r.counts().incomplete, 1);
  ASSERT_TRUE(feed(r, a2[1], 100, m));
  EXPECT_EQ(bytes_of(m), pa);
}

TEST(LcmWire, BrokenHeadersAreMalformedWithAReason) {
  LcmReassembler r;
  LcmReassembler::Message m;
  std::string why;
  EXPECT_FALSE(feed(r, Bytes{'L', 'C', '0'}, 1, m, &why));
  EXPECT_EQ(why, "shorter than an LCM header");
  EXPECT_FALSE(feed(r, Bytes{'X', 'C', '0', '2', 0, 0, 0, 1, 'A', 0}, 1, m, &why));
  EXPECT_EQ(why, "not an LCM datagram (magic)");
  Bytes cut = fragments(1, "A", payload_of(100000))[0];
  cut.resize(19);
  EXPECT_FALSE(feed(r, cut, 1, m, &why));
  EXPECT_EQ(why, "shorter than an LCM fragment header");

  auto f = fragments(1, "A", payload_of(100000));
  Bytes bad = f[1];
  bad[17] = 2;  // fragment 2 of 2
  EXPECT_FALSE(feed(r, bad, 1, m, &why));
  EXPECT_EQ(why, "fragment number out of its count");
  bad = f[1];
  bad[12] = 0x7f;  // an offset past the end
  EXPECT_FALSE(feed(r, bad, 1, m, &why));
  EXPECT_EQ(why, "fragment past the message's end");
  bad = f[0];
  bad[8] = 0x7f;  // 2 GB claimed by 2 fragments
  EXPECT_FALSE(feed(r, bad, 1, m, &why));
  EXPECT_EQ(why, "fragment count too small for the message size");
  EXPECT_EQ(r.counts().malformed, 6);
  EXPECT_EQ(r.in_flight(), 0u);
}

TEST(LcmWire, FragmentsThatDoNotAddUpAreNotAMessage) {
  // Two fragments that both say offset 0: all came, and 20 bytes of the message never did.
  const Bytes payload = payload_of(100);
  Bytes f0, f1;
  for (Bytes* b : {&f0, &f1}) {
    put32(*b, 0x4c433033);
    put32(*b, 5);
    put32(*b, 100);
    put32(*b, 0);
    put16(*b, b == &f0 ? 0 : 1);
    put16(*b, 2);
  }
  f0.push_back('A');
  f0.push_back(0);
  f0.insert(f0.end(), payload.begin(), payload.begin() + 40);
  f1.insert(f1.end(), payload.begin(), payload.begin() + 40);
  LcmReassembler r;
  LcmReassembler::Message m;
  std::string why;
  EXPECT_FALSE(feed(r, f0, 1, m, &why));
  EXPECT_FALSE(feed(r, f1, 1, m, &why));
  EXPECT_EQ(why, "fragments do not add up to the message size");
  EXPECT_EQ(r.counts().messages, 0);
}

TEST(LcmWire, MemoryStaysBoundedWhateverFragmentsClaim) {
  // 40 senders each claim a 16 MiB message and send 1000 bytes of it: what is held is what came
  // (16 senders' worth at most), and every message pushed out is counted.
  LcmReassembler r;
  LcmReassembler::Message m;
  const uint32_t size = LcmReassembler::kMaxMessageBytes;
  for (uint64_t sender = 0; sender < 40; ++sender) {
    Bytes b;
    put32(b, 0x4c433033);
    put32(b, 1);
    put32(b, size);
    put32(b, 0);
    put16(b, 0);
    put16(b, 300);
    b.push_back('Z');
    b.push_back(0);
    b.resize(b.size() + 1000, 0xAB);
    EXPECT_FALSE(feed(r, b, sender, m));
  }
  EXPECT_EQ(r.in_flight(), LcmReassembler::kMaxSenders);
  EXPECT_EQ(r.in_flight_bytes(), 1000 * LcmReassembler::kMaxSenders);
  EXPECT_EQ(r.counts().incomplete, 40 - static_cast<int64_t>(LcmReassembler::kMaxSenders));
  // Larger than 16 MiB: counted, not assembled.
  Bytes huge;
  put32(huge, 0x4c433033);
  put32(huge, 2);
  put32(huge, size + 1);
  put32(huge, 0);
  put16(huge, 0);
  put16(huge, 300);
  huge.push_back('Z');
  huge.push_back(0);
  EXPECT_FALSE(feed(r, huge, 99, m));
  EXPECT_EQ(r.counts().too_large, 1);
}

TEST(LcmWire, FragmentsHeldBeyondTheBoundPushOutTheOldestSendersMessage) {
  // Five senders each send 15 MB of a 16 MiB message (230 fragments of 65 487 bytes): 75 MB
  // would be held; the first sender's message is given up to keep within 64 MiB.
  LcmReassembler r;
  LcmReassembler::Message m;
  const uint32_t size = LcmReassembler::kMaxMessageBytes;
  const Bytes chunk(65487, 0x5A);
  for (uint64_t sender = 1; sender <= 5; ++sender) {
    for (uint16_t k = 1; k <= 230; ++k) {
      Bytes b;
      put32(b, 0x4c433033);
      put32(b, 7);
      put32(b, size);
      put32(b, static_cast<uint32_t>(k) * 65487u);
      put16(b, k);
      put16(b, 257);
      b.insert(b.end(), chunk.begin(), chunk.end());
      EXPECT_FALSE(feed(r, b, sender, m));
    }
    EXPECT_LE(r.in_flight_bytes(), LcmReassembler::kMaxInFlightBytes);
  }
  EXPECT_EQ(r.counts().incomplete, 1);
  EXPECT_EQ(r.in_flight(), 4u);
  EXPECT_EQ(r.counts().malformed, 0);
}

}  // namespace
}  // namespace ips
