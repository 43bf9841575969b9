#include "core/lcm_udpm_receiver.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/lcm_url.hpp"
#include "core/time.hpp"

namespace ips {

namespace {
constexpr size_t kDatagramBytes = LcmReassembler::kMaxDatagramBytes + 1;  // +1: a cut one shows
constexpr size_t kControlBytes = CMSG_SPACE(sizeof(timeval));
}  // namespace

LcmUdpmReceiver::LcmUdpmReceiver(const std::string& url) {
  const std::string group = lcm_url_udpm_group(url);
  const uint16_t port = lcm_url_udpm_port(url);
  auto fail = [&](const std::string& what) {
    const std::string text = "cannot receive LCM on '" + url + "': " + what + ": " +
                             std::strerror(errno) + " (docs/networking.md)";
    if (fd_ >= 0) close(fd_);
    fd_ = -1;
    throw LcmOpenError(text);
  };
  in_addr group_addr{};
  if (port == 0 || inet_pton(AF_INET, group.c_str(), &group_addr) != 1 ||
      !IN_MULTICAST(ntohl(group_addr.s_addr))) {
    errno = EINVAL;
    fail("'" + group + "' is not an IPv4 multicast group");
  }
  fd_ = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail("socket");
  // Every LCM process on the host binds the same port (liblcm does the same).
  const int one = 1;
  if (setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0) fail("SO_REUSEADDR");
  // The socket's buffer is the only one between the wire and this loop (liblcm's thread has a
  // queue behind its own): as root (CAP_NET_ADMIN) the size asked for is granted beyond
  // net.core.rmem_max; otherwise it is capped there, and Node warns of it.
  if (const int want = lcm_url_recv_buf(url); want > 0 &&
      setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &want, sizeof want) != 0)
    setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &want, sizeof want);
  // The kernel's reception time of each datagram (what liblcm hands its subscribers).
  setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_ANY);
  if (bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0)
    fail("bind to port " + std::to_string(port));
  ip_mreq mreq{};
  mreq.imr_multiaddr = group_addr;
  mreq.imr_interface.s_addr = htonl(INADDR_ANY);
  if (setsockopt(fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mreq, sizeof mreq) != 0)
    fail("joining " + group + " (no multicast route? as root: ip link set lo multicast on && ip "
         "route add 224.0.0.0/4 dev lo)");

  buffers_ = std::make_unique_for_overwrite<uint8_t[]>(kBatch * kDatagramBytes);
  headers_.resize(kBatch);
  iovecs_.resize(kBatch);
  senders_.resize(kBatch);
  controls_.resize(kBatch * kControlBytes);
  // Where each datagram goes is set once; read_batch resets only what recvmmsg writes back.
  for (size_t k = 0; k < kBatch; ++k) {
    iovecs_[k] = {buffers_.get() + k * kDatagramBytes, kDatagramBytes};
    msghdr& h = headers_[k].msg_hdr;
    h = {};
    h.msg_name = &senders_[k];
    h.msg_iov = &iovecs_[k];
    h.msg_iovlen = 1;
    h.msg_control = controls_.data() + k * kControlBytes;
  }
}

LcmUdpmReceiver::~LcmUdpmReceiver() {
  if (fd_ >= 0) close(fd_);
}

int LcmUdpmReceiver::read_batch(const MessageFn& on_message, const RejectFn& on_reject) {
  for (mmsghdr& m : headers_) {
    m.msg_hdr.msg_namelen = sizeof(sockaddr_in);
    m.msg_hdr.msg_controllen = kControlBytes;
    m.msg_hdr.msg_flags = 0;
    m.msg_len = 0;
  }
  const int n = recvmmsg(fd_, headers_.data(), kBatch, MSG_DONTWAIT, nullptr);
  if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR ? 0 : -1;
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<size_t>(i);
    const msghdr& h = headers_[k].msg_hdr;
    int64_t utime = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(const_cast<msghdr*>(&h)); c;
         c = CMSG_NXTHDR(const_cast<msghdr*>(&h), c)) {
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMP) {
        timeval tv;
        std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
        utime = int64_t{tv.tv_sec} * 1000000 + tv.tv_usec;
      }
    }
    if (utime == 0) utime = wall_utime_now();
    const size_t size = headers_[k].msg_len;
    if ((h.msg_flags & MSG_TRUNC) || size > LcmReassembler::kMaxDatagramBytes) {
      if (on_reject) on_reject("a datagram longer than UDP allows");
      continue;
    }
    const uint64_t sender =
        uint64_t{ntohl(senders_[k].sin_addr.s_addr)} << 16 | ntohs(senders_[k].sin_port);
    LcmReassembler::Message msg;
    std::string why;
    if (wire_.feed(buffers_.get() + k * kDatagramBytes, size, sender, msg, &why)) {
      on_message(msg, utime);
    } else if (!why.empty() && on_reject) {
      on_reject(why);
    }
  }
  return n;
}

}  // namespace ips
