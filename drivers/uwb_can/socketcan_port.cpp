#include "drivers/uwb_can/socketcan_port.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ips::uwb_can {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

std::unique_ptr<SocketCanPort> SocketCanPort::open(const std::string& interface, bool fd,
                                                   CanOpenFailure& failure, std::string& message,
                                                   std::string& warning) {
  failure = CanOpenFailure::kNone;
  message.clear();
  warning.clear();
  const std::string no_such = "no network interface '" + interface +
                              "' (ip -details link show lists them; a virtual bus for tests: "
                              "ip link add dev vcan0 type vcan && ip link set up vcan0)";
  const bool name_fits = !interface.empty() && interface.size() < IFNAMSIZ;
  const bool exists = name_fits && if_nametoindex(interface.c_str()) != 0;
  const int s = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (s < 0) {
    const int err = errno;
    if (err == EAFNOSUPPORT || err == EPROTONOSUPPORT) {
      // The kernel first: without AF_CAN no interface name can help.
      failure = CanOpenFailure::kNoSocketCan;
      message = "this kernel has no SocketCAN support (AF_CAN): " + errno_text(err) +
                (exists ? "" : " (and there is no interface '" + interface + "')") +
                "; load it with 'modprobe can_raw', or replay recorded traffic with "
                "--candump-file FILE or --candump-stdin";
    } else {
      failure = CanOpenFailure::kOther;
      message = "cannot open a CAN_RAW socket: " + errno_text(err);
    }
    return nullptr;
  }
  if (!exists) {
    close(s);
    failure = CanOpenFailure::kNoSuchInterface;
    message = no_such;
    return nullptr;
  }
  std::unique_ptr<SocketCanPort> port(new SocketCanPort(s, interface));
  auto fail = [&](CanOpenFailure f, std::string m) {
    failure = f;
    message = std::move(m);
    return nullptr;
  };

  ifreq ifr{};
  std::memcpy(ifr.ifr_name, interface.c_str(), interface.size() + 1);
  if (ioctl(s, SIOCGIFINDEX, &ifr) < 0) {
    const int err = errno;
    if (err == ENODEV) return fail(CanOpenFailure::kNoSuchInterface, no_such);
    return fail(CanOpenFailure::kOther, "SIOCGIFINDEX " + interface + ": " + errno_text(err));
  }
  const int ifindex = ifr.ifr_ifindex;

  const int on = 1;
  if (fd) {
    if (setsockopt(s, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) < 0)
      return fail(CanOpenFailure::kNoFd,
                  "the kernel refuses CAN FD frames (CAN_RAW_FD_FRAMES): " + errno_text(errno));
    if (ioctl(s, SIOCGIFMTU, &ifr) == 0 && ifr.ifr_mtu != static_cast<int>(CANFD_MTU))
      warning = interface + " is not in CAN FD mode (MTU " + std::to_string(ifr.ifr_mtu) +
                "): only classic frames will arrive (ip link set " + interface +
                " type can ... fd on)";
  }
  // Every error class: bus-off, controller problems (rx overflow), protocol violations...
  const can_err_mask_t err_mask = CAN_ERR_MASK;
  if (setsockopt(s, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) < 0)
    return fail(CanOpenFailure::kOther, "CAN_RAW_ERR_FILTER: " + errno_text(errno));
  // Frames dropped by a full receive queue arrive as a counter with each frame; the kernel's
  // receive time of each frame too.
  if (setsockopt(s, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) < 0)
    return fail(CanOpenFailure::kOther, "SO_RXQ_OVFL: " + errno_text(errno));
  if (setsockopt(s, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) < 0)
    return fail(CanOpenFailure::kOther, "SO_TIMESTAMP: " + errno_text(errno));

  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  if (bind(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    const int err = errno;
    if (err == ENODEV)
      return fail(CanOpenFailure::kNotCan, "'" + interface + "' is not a CAN interface");
    return fail(CanOpenFailure::kOther, "cannot bind to " + interface + ": " + errno_text(err));
  }
  return port;
}

SocketCanPort::~SocketCanPort() {
  if (fd_ >= 0) close(fd_);
}

CanReadResult SocketCanPort::read(CanFrame& frame, utime_t& utime, std::string& error) {
  canfd_frame raw{};
  iovec iov{&raw, sizeof raw};
  sockaddr_can addr{};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(uint32_t))];
  msghdr msg{};
  msg.msg_name = &addr;
  msg.msg_namelen = sizeof addr;
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = recvmsg(fd_, &msg, 0);
  if (n < 0) {
    const int err = errno;
    if (err == EAGAIN || err == EWOULDBLOCK || err == EINTR) return CanReadResult::kNone;
    error = errno_text(err);
    return err == ENETDOWN ? CanReadResult::kDown : CanReadResult::kGone;
  }
  utime = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_TIMESTAMP) {
      timeval tv;
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      utime = static_cast<utime_t>(tv.tv_sec) * 1'000'000 + tv.tv_usec;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::memcpy(&dropped_, CMSG_DATA(c), sizeof dropped_);
    }
  }
  if (!plausible_utime(utime)) utime = wall_utime_now();
  if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU))
    return CanReadResult::kBadSize;
  frame = CanFrame{};
  frame.fd = n == static_cast<ssize_t>(CANFD_MTU);
  frame.error = (raw.can_id & CAN_ERR_FLAG) != 0;
  frame.extended = !frame.error && (raw.can_id & CAN_EFF_FLAG) != 0;
  frame.remote = !frame.error && (raw.can_id & CAN_RTR_FLAG) != 0;
  frame.id = raw.can_id & (frame.extended || frame.error ? CAN_EFF_MASK : CAN_SFF_MASK);
  const uint8_t max = frame.fd ? kMaxFdLen : kMaxClassicLen;
  frame.len = raw.len > max ? max : raw.len;
  if (frame.fd) {
    frame.fd_flags = static_cast<uint8_t>(raw.flags & (CANFD_BRS | CANFD_ESI));
  } else {
    // struct can_frame overlays canfd_frame: its len8_dlc is the byte canfd_frame calls __res1.
    can_frame classic;
    std::memcpy(&classic, &raw, sizeof classic);
    if (classic.len == 8 && classic.len8_dlc > 8 && classic.len8_dlc <= 15)
      frame.len8_dlc = classic.len8_dlc;
  }
  if (!frame.remote) std::memcpy(frame.data.data(), raw.data, frame.len);
  return CanReadResult::kFrame;
}

}  // namespace ips::uwb_can
