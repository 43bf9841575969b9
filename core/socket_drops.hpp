#pragma once
// What the kernel knows of this process's UDP sockets: the datagrams it dropped on each (receive
// buffer full; the last column, `drops`, of /proc/net/udp), and which descriptor is bound to a
// port (liblcm's receive socket, whose granted SO_RCVBUF we report). docs/networking.md#loss
#include <cstdint>
#include <map>
#include <string_view>
#include <vector>

namespace ips {

struct UdpSocketRow {
  uint16_t local_port = 0;
  int64_t rx_queue_bytes = 0;
  int64_t drops = 0;
};

// Parses /proc/net/udp or /proc/net/udp6 text into rows by socket inode. Lines that do not parse
// (the header, anything unexpected) are skipped.
std::map<uint64_t, UdpSocketRow> parse_proc_net_udp(std::string_view text);

// This process's open sockets: (descriptor, inode), from /proc/self/fd.
std::vector<std::pair<int, uint64_t>> own_socket_inodes();

// The UDP sockets of this process (IPv4 and IPv6) by inode; empty where /proc is not readable.
std::map<uint64_t, UdpSocketRow> own_udp_sockets();

// A descriptor of this process bound to UDP `port`, or -1.
int own_udp_socket_bound_to(uint16_t port);

// Drops summed over this process's UDP sockets since the counter was made, including sockets
// closed meanwhile (a driver reconnecting): never goes down.
class KernelDropCounter {
 public:
  int64_t update();  // reads /proc; returns the total
  // The same from rows already read (for tests).
  int64_t update(const std::map<uint64_t, UdpSocketRow>& sockets);
  int64_t total() const { return retired_ + current_; }

 private:
  std::map<uint64_t, int64_t> last_;  // inode -> drops when last seen
  int64_t retired_ = 0;               // drops of sockets gone
  int64_t current_ = 0;
};

}  // namespace ips
