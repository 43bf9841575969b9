#pragma once
// A SocketCAN CAN_RAW socket bound to one CAN interface (Linux Documentation/networking/can.rst):
// receives every data frame on the bus, CAN FD frames too when asked (CAN_RAW_FD_FRAMES), all
// error frames the controller driver generates (CAN_RAW_ERR_FILTER = CAN_ERR_MASK), the kernel's
// receive time of each frame (SO_TIMESTAMP) and the count of frames the socket's queue dropped
// (SO_RXQ_OVFL). Non-blocking: the node's poll loop watches fd().
#include <cstdint>
#include <memory>
#include <string>

#include "core/time.hpp"
#include "drivers/uwb_can/can_frame.hpp"

namespace ips::uwb_can {

enum class CanOpenFailure {
  kNone,
  kNoSuchInterface,  // no network interface of that name (if_nametoindex, SIOCGIFINDEX)
  kNoSocketCan,      // socket(PF_CAN, SOCK_RAW, CAN_RAW) fails: no AF_CAN in this kernel
  kNotCan,           // the interface exists but is not a CAN interface (bind: ENODEV)
  kNoFd,             // CAN FD asked for but the kernel refuses CAN_RAW_FD_FRAMES
  kOther,
};

enum class CanReadResult {
  kFrame,    // `frame` and `utime` filled in
  kNone,     // nothing queued (EAGAIN)
  kDown,     // the interface is down (ENETDOWN): frames resume when it comes up
  kGone,     // the socket failed (the device went away): close and open again
  kBadSize,  // a read of neither CAN_MTU nor CANFD_MTU bytes
};

class SocketCanPort {
 public:
  // Opens and binds the socket. nullptr on failure, with `failure` and a one-line `message`
  // (what failed, the system's reason, what to do). `warning` is set (port still opened) when
  // CAN FD was asked for on an interface whose MTU is not CANFD_MTU.
  static std::unique_ptr<SocketCanPort> open(const std::string& interface, bool fd,
                                             CanOpenFailure& failure, std::string& message,
                                             std::string& warning);
  ~SocketCanPort();
  SocketCanPort(const SocketCanPort&) = delete;
  SocketCanPort& operator=(const SocketCanPort&) = delete;

  int fd() const { return fd_; }
  const std::string& interface() const { return interface_; }

  // Reads the next queued frame. `error` is the system's reason for kGone/kDown.
  CanReadResult read(CanFrame& frame, utime_t& utime, std::string& error);
  // Frames the kernel dropped because this socket's receive queue was full, since opening.
  uint32_t dropped_total() const { return dropped_; }

 private:
  SocketCanPort(int fd, std::string interface) : fd_(fd), interface_(std::move(interface)) {}
  int fd_;
  std::string interface_;
  uint32_t dropped_ = 0;
};

}  // namespace ips::uwb_can
