#pragma once
// Receives an udpm:// LCM bus on the caller's thread (--lcm-receiver direct): a socket joined to
// the URL's multicast group and bound to its port, as liblcm's own, read where the process's
// loop polls it, with LCM's wire format parsed by core/lcm_wire.hpp. liblcm 1.3 reads its socket
// in a thread of its own and hands each message over through a pipe: two more system calls and
// a second wake-up per message, which is most of what a range costs ips-fuse on its way to a
// pose (docs/development.md#the-bus-at-scale). Publishing stays liblcm's.
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/lcm_wire.hpp"

namespace ips {

class LcmUdpmReceiver {
 public:
  // Opens the socket for a udpm URL (its group, port and recv_buf_size). Throws LcmOpenError
  // with one line saying why.
  explicit LcmUdpmReceiver(const std::string& url);
  ~LcmUdpmReceiver();
  LcmUdpmReceiver(const LcmUdpmReceiver&) = delete;
  LcmUdpmReceiver& operator=(const LcmUdpmReceiver&) = delete;

  int fd() const { return fd_; }

  using MessageFn =
      std::function<void(const LcmReassembler::Message& msg, int64_t recv_utime)>;
  using RejectFn = std::function<void(const std::string& why)>;
  // Reads what is waiting (at most one batch of kBatch datagrams, so a flood cannot hold the
  // loop) and calls `on_message` for each whole message, `on_reject` for each datagram that is
  // not LCM's. Returns the datagrams read; -1 when the socket failed (errno set).
  int read_batch(const MessageFn& on_message, const RejectFn& on_reject);

  const LcmWireCounts& counts() const { return wire_.counts(); }

  static constexpr int kBatch = 16;

 private:
  int fd_ = -1;
  LcmReassembler wire_;
  // kBatch datagrams of the largest UDP payload (1 MiB), left uninitialised: a page is resident
  // only once a datagram has been written to it (most are a few hundred bytes).
  std::unique_ptr<uint8_t[]> buffers_;
  std::vector<mmsghdr> headers_;
  std::vector<iovec> iovecs_;
  std::vector<sockaddr_in> senders_;
  std::vector<uint8_t> controls_;  // each datagram's SO_TIMESTAMP
};

}  // namespace ips
