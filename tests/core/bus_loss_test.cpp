// Loss on the way in: senders' sequence gaps (core/seq_loss), the kernel's per-socket drops
// (core/socket_drops), the URL's receive buffer (core/lcm_url) and the node's LCM queue drops.
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <ips/ble_aoa_t.hpp>
#include <ips/uwb_range_t.hpp>

#include "core/lcm_url.hpp"
#include "core/node.hpp"
#include "core/seq_loss.hpp"
#include "core/socket_drops.hpp"

namespace ips {
namespace {

TEST(SeqLoss, ConsecutiveNumbersLoseNothing) {
  SeqLossCounter c;
  for (int i = 0; i < 100; ++i) c.observe("a", i);
  EXPECT_EQ(c.counts().lost, 0);
  EXPECT_EQ(c.counts().received, 100);
  EXPECT_EQ(c.counts().restarts, 0);
}

TEST(SeqLoss, ForwardGapIsLossPerSender) {
  SeqLossCounter c;
  for (int i : {0, 1, 2, 5, 6, 10}) c.observe("a", i);  // 3, 4 and 7..9 missing: 5
  for (int i : {7, 8, 9, 11}) c.observe("b", i);        // 10 missing: 1
  EXPECT_EQ(c.counts().lost, 6);
  EXPECT_EQ(c.counts().received, 10);
}

TEST(SeqLoss, UnknownNumbersAreCountedApart) {
  SeqLossCounter c;
  c.observe("a", -1);
  c.observe("a", 4);
  c.observe("a", -1);
  c.observe("a", 5);
  EXPECT_EQ(c.counts().unknown, 2);
  EXPECT_EQ(c.counts().lost, 0);
}

TEST(SeqLoss, WrapOfAByteCounterCountsTheNumbersInBetween) {
  SeqLossCounter c;
  for (int i = 250; i < 256; ++i) c.observe("can", i);
  c.observe("can", 0);  // 255 -> 0: nothing lost
  EXPECT_EQ(c.counts().lost, 0);
  c.observe("can", 1);
  for (int i = 250; i < 254; ++i) c.observe("x", i);
  c.observe("x", 2);  // 254, 255, 0, 1 lost across the wrap
  EXPECT_EQ(c.counts().lost, 4);
  EXPECT_EQ(c.counts().restarts, 0);
}

TEST(SeqLoss, WrapOfA31BitCounter) {
  SeqLossCounter c;
  c.observe("a", INT32_MAX - 1);
  c.observe("a", INT32_MAX);
  c.observe("a", 0);
  c.observe("a", 2);
  EXPECT_EQ(c.counts().lost, 1);
  EXPECT_EQ(c.counts().restarts, 0);
}

TEST(SeqLoss, BigJumpBackIsARestartNotLoss) {
  SeqLossCounter c;
  for (int i = 1000; i < 1010; ++i) c.observe("a", i);
  c.observe("a", 0);  // the device rebooted
  c.observe("a", 1);
  c.observe("a", 3);
  EXPECT_EQ(c.counts().restarts, 1);
  EXPECT_EQ(c.counts().lost, 1);
}

TEST(SeqLoss, HugeJumpForwardIsARestartNotLoss) {
  SeqLossCounter c;
  c.observe("a", 5);
  c.observe("a", 5 + SeqLossCounter::kMaxGap + 2);
  EXPECT_EQ(c.counts().restarts, 1);
  EXPECT_EQ(c.counts().lost, 0);
}

TEST(SeqLoss, RepeatsAndLateMessagesAreNotLoss) {
  SeqLossCounter c;
  for (int i : {10, 11, 11, 12, 9, 13}) c.observe("a", i);
  EXPECT_EQ(c.counts().late, 2);
  EXPECT_EQ(c.counts().lost, 0);
  EXPECT_EQ(c.counts().restarts, 0);
}

// Two lines of a real /proc/net/udp (Linux 6.1), the second with 114 drops.
constexpr const char* kProcNetUdp =
    "   sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout "
    "inode ref pointer drops\n"
    "  512: 434CFFEF:1DF3 00000000:0000 07 00000000:00000000 00:00000000 00000000     0        0 "
    "48213 2 ffff8880049e1a00 0\n"
    "  860: 0100007F:8ACF 00000000:0000 07 00000000:0003A980 00:00000000 00000000  1000        0 "
    "48219 2 ffff8880049e2200 114\n"
    "garbage line\n";

TEST(SocketDrops, ParsesPortQueueAndDrops) {
  const auto rows = parse_proc_net_udp(kProcNetUdp);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows.at(48213).local_port, 7667);
  EXPECT_EQ(rows.at(48213).drops, 0);
  EXPECT_EQ(rows.at(48219).local_port, 0x8ACF);
  EXPECT_EQ(rows.at(48219).rx_queue_bytes, 0x3A980);
  EXPECT_EQ(rows.at(48219).drops, 114);
  EXPECT_TRUE(parse_proc_net_udp("").empty());
}

TEST(SocketDrops, ClosedSocketsKeepTheirDropsInTheTotal) {
  KernelDropCounter c;
  std::map<uint64_t, UdpSocketRow> s{{1, {7667, 0, 10}}, {2, {5555, 0, 3}}};
  EXPECT_EQ(c.update(s), 13);
  s.erase(2);  // closed: its 3 stay
  s[1].drops = 12;
  EXPECT_EQ(c.update(s), 15);
  s[3] = {5555, 0, 1};  // reopened
  EXPECT_EQ(c.update(s), 16);
  s[1].drops = 2;  // inode 1 reused by a new socket: the old one's 12 stay
  EXPECT_EQ(c.update(s), 18);  // 3 + 12 retired, 2 + 1 now
}

TEST(SocketDrops, FindsThisProcesssOwnUdpSocket) {
  const int fd = socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len), 0);
  EXPECT_EQ(own_udp_socket_bound_to(ntohs(a.sin_port)), fd);
  const auto own = own_udp_sockets();
  EXPECT_FALSE(own.empty());
  close(fd);
}

TEST(LcmUrlRecvBuf, DefaultAddedUnlessTheUrlSaysOrIsNotUdpm) {
  EXPECT_EQ(lcm_url_with_recv_buf("udpm://239.255.76.67:7667?ttl=0", 4194304),
            "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=4194304");
  EXPECT_EQ(lcm_url_with_recv_buf("udpm://239.255.76.67:7667", 1000),
            "udpm://239.255.76.67:7667?recv_buf_size=1000");
  EXPECT_EQ(lcm_url_with_recv_buf("udpm://239.1.1.1:7000?recv_buf_size=65536&ttl=1", 4194304),
            "udpm://239.1.1.1:7000?recv_buf_size=65536&ttl=1");
  EXPECT_EQ(lcm_url_with_recv_buf("memq://", 4194304), "memq://");
  EXPECT_EQ(lcm_url_with_recv_buf("udpm://239.1.1.1:7000", 0), "udpm://239.1.1.1:7000");
  EXPECT_EQ(lcm_url_recv_buf("udpm://239.1.1.1:7000?ttl=0&recv_buf_size=65536"), 65536);
  EXPECT_EQ(lcm_url_recv_buf("udpm://239.1.1.1:7000?ttl=0"), 0);
  EXPECT_EQ(lcm_url_udpm_port("udpm://239.1.1.1:7000?ttl=0"), 7000);
  EXPECT_EQ(lcm_url_udpm_port("udpm://239.1.1.1?ttl=0"), 7667);
  EXPECT_EQ(lcm_url_udpm_port("memq://"), 0);
}

CommonOptions memq(int queue) {
  CommonOptions o;
  o.lcm_url = "memq://";
  o.lcm_queue = queue;
  return o;
}

// liblcm's memq provider keeps every message whatever the queue's size (its udpm provider is the
// one that drops; tests/integration/bus_loss_netns.sh): nothing is lost, nothing is miscounted.
TEST(NodeLoss, NothingLostCountsNothing) {
  Node node("test", memq(5));
  int got = 0;
  node.subscribe<uwb_range_t>("R", [&](const uwb_range_t&, const std::string&) { ++got; });
  uwb_range_t m{};
  m.source = "s";
  m.tag_id = "t";
  m.anchor_id = "a";
  for (int i = 0; i < 12; ++i) {
    m.seq = i;
    node.publish("R", m);
  }
  while (got < 12 && node.spin_once(100)) {
  }
  const BusLoss l = node.loss();
  EXPECT_EQ(got, 12);
  EXPECT_EQ(l.queue_drops, 0);
  EXPECT_EQ(l.seq.received, 12);
  EXPECT_EQ(l.seq.lost, 0);
  EXPECT_EQ(l.kernel_drops, 0);
  EXPECT_EQ(l.recv_buf_bytes, -1);  // memq: no socket
  EXPECT_EQ(l.lcm_queue, 5);
}

TEST(NodeLoss, SequenceGapsOfAnySubscriptionAreCounted) {
  Node node("test", memq(kDefaultLcmQueue));
  int raw = 0;
  node.subscribe_raw("B.*", [&](const lcm::ReceiveBuffer*, const std::string&) { ++raw; });
  ble_aoa_t b{};
  b.source = "drv";
  b.anchor_id = "A1";
  for (int seq : {0, 1, 4, 5}) {  // 2 and 3 lost
    b.seq = seq;
    node.publish("BLE_AOA", b);
  }
  while (raw < 4 && node.spin_once(100)) {
  }
  ASSERT_EQ(raw, 4);
  EXPECT_EQ(node.loss().seq.lost, 2);
  EXPECT_EQ(node.loss().queue_drops, 0);
}

}  // namespace
}  // namespace ips
