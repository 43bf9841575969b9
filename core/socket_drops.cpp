#include "core/socket_drops.hpp"

#include <dirent.h>
#include <unistd.h>

#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

namespace ips {

namespace {

std::string read_file_text(const char* path) {
  std::ifstream in(path);
  if (!in) return {};
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Splits a line on spaces into at most `max` fields.
std::vector<std::string_view> fields_of(std::string_view line, size_t max) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size() && out.size() < max) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t') ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

template <class T>
bool parse_number(std::string_view s, T& v, int base = 10) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v, base);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

}  // namespace

std::map<uint64_t, UdpSocketRow> parse_proc_net_udp(std::string_view text) {
  // "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout
  //  inode ref pointer drops": fields 0 sl, 1 local, 2 remote, 3 st, 4 tx:rx, 5 tr:when,
  // 6 retrnsmt, 7 uid, 8 timeout, 9 inode, 10 ref, 11 pointer, 12 drops.
  std::map<uint64_t, UdpSocketRow> rows;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    const auto f = fields_of(line, 14);
    if (f.size() != 13) continue;
    UdpSocketRow row;
    const size_t colon = f[1].rfind(':');
    const size_t qcolon = f[4].find(':');
    uint64_t inode = 0;
    if (colon == std::string_view::npos || qcolon == std::string_view::npos ||
        !parse_number(f[1].substr(colon + 1), row.local_port, 16) ||
        !parse_number(f[4].substr(qcolon + 1), row.rx_queue_bytes, 16) ||
        !parse_number(f[9], inode) || !parse_number(f[12], row.drops) || row.drops < 0)
      continue;
    rows[inode] = row;
  }
  return rows;
}

std::vector<std::pair<int, uint64_t>> own_socket_inodes() {
  std::vector<std::pair<int, uint64_t>> out;
  DIR* dir = opendir("/proc/self/fd");
  if (!dir) return out;
  const int dir_fd = dirfd(dir);
  while (const dirent* e = readdir(dir)) {
    int fd = 0;
    if (!parse_number(std::string_view(e->d_name), fd) || fd == dir_fd) continue;
    char target[64];
    const std::string path = std::string("/proc/self/fd/") + e->d_name;
    const ssize_t n = readlink(path.c_str(), target, sizeof target - 1);
    if (n <= 0) continue;
    const std::string_view t(target, static_cast<size_t>(n));
    constexpr std::string_view kPrefix = "socket:[";
    if (t.substr(0, kPrefix.size()) != kPrefix || t.back() != ']') continue;
    uint64_t inode = 0;
    if (parse_number(t.substr(kPrefix.size(), t.size() - kPrefix.size() - 1), inode))
      out.emplace_back(fd, inode);
  }
  closedir(dir);
  return out;
}

std::map<uint64_t, UdpSocketRow> own_udp_sockets() {
  const auto own = own_socket_inodes();
  std::map<uint64_t, UdpSocketRow> out;
  if (own.empty()) return out;
  for (const char* file : {"/proc/self/net/udp", "/proc/self/net/udp6"}) {
    const auto rows = parse_proc_net_udp(read_file_text(file));
    for (const auto& [fd, inode] : own) {
      (void)fd;
      if (auto it = rows.find(inode); it != rows.end()) out[inode] = it->second;
    }
  }
  return out;
}

int own_udp_socket_bound_to(uint16_t port) {
  const auto own = own_socket_inodes();
  const auto rows = parse_proc_net_udp(read_file_text("/proc/self/net/udp"));
  for (const auto& [fd, inode] : own) {
    if (auto it = rows.find(inode); it != rows.end() && it->second.local_port == port) return fd;
  }
  return -1;
}

int64_t KernelDropCounter::update() { return update(own_udp_sockets()); }

int64_t KernelDropCounter::update(const std::map<uint64_t, UdpSocketRow>& sockets) {
  // A socket no longer listed was closed: its last count stays in the total.
  for (auto it = last_.begin(); it != last_.end();) {
    if (!sockets.count(it->first)) {
      retired_ += it->second;
      it = last_.erase(it);
    } else {
      ++it;
    }
  }
  current_ = 0;
  for (const auto& [inode, row] : sockets) {
    // A count that went down is a new socket under a reused inode: the old one's count stays.
    if (auto it = last_.find(inode); it != last_.end() && row.drops < it->second)
      retired_ += it->second;
    last_[inode] = row.drops;
    current_ += row.drops;
  }
  return total();
}

}  // namespace ips
