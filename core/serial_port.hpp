#pragma once
// Serial devices (USB CDC-ACM, USB-UART bridges, on-board UARTs, pseudo-terminals) for the
// drivers. Two layers:
//  - SerialPort: the termios transport. Opens a path as a raw 8N1 line at a given speed, with no
//    flow control and a non-blocking fd for Node::watch_fd; reads, writes, closes. No policy.
//  - SerialLink: keeps one device open on a Node's loop. It watches the fd, hands bytes over with
//    their host reception time, notices when the device goes away (USB unplugged: read gives EIO
//    or end of file, poll gives POLLHUP/POLLERR, or the path vanishes), says so in health_t
//    (state degraded, last_error "device PATH gone; retrying") and reopens it every reopen_s
//    until it is back. A device missing at start is retried the same way.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "core/time.hpp"

namespace ips {

class Node;

// True for the speeds termios can set (50 ... 4000000 baud, the standard B* constants).
bool serial_baud_supported(int baud);

// Why `path` can never be a serial port, e.g. "is a directory"; empty when it may be one (a
// character device, or nothing there yet: a device that is plugged in later).
std::string serial_path_problem(const std::string& path);

class SerialPort {
 public:
  SerialPort() = default;
  ~SerialPort() { close(); }
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;

  // Opens `path` as a raw 8N1 line at `baud` (no echo, no line editing, no CR/LF translation, no
  // flow control, modem lines ignored), non-blocking and close-on-exec. False with the reason in
  // `error` (and errno in last_open_errno(); ENOTTY for a device that is not a terminal).
  bool open(const std::string& path, int baud, std::string& error);
  int last_open_errno() const { return open_errno_; }
  bool is_open() const { return fd_ >= 0; }
  int fd() const { return fd_; }
  const std::string& path() const { return path_; }

  enum class ReadStatus { kData, kNothing, kGone };
  // Reads what is waiting, at most `capacity` bytes, into `buf` (`n` bytes read). kNothing when
  // nothing is waiting; kGone when the device went away (EIO, ENXIO, ENODEV, or end of file,
  // which a terminal only reports after a hang-up), with the reason in `why`.
  ReadStatus read_some(char* buf, size_t capacity, size_t& n, std::string& why);

  // Writes all of `bytes`, waiting at most `timeout_ms` in total for room in the output queue.
  bool write_all(std::string_view bytes, int timeout_ms, std::string& error);
  // Waits until everything written has been sent (tcdrain), at most about `timeout_ms`.
  void drain(int timeout_ms);
  void close();

 private:
  int fd_ = -1;
  int open_errno_ = 0;
  std::string path_;
};

struct SerialLinkOptions {
  std::string path;
  int baud = 115200;
  double reopen_s = 1.0;  // retry period while the device is missing or gone, s
};

class SerialLink {
 public:
  struct Callbacks {
    std::function<void()> on_open;  // the device is open (first time or again)
    // Bytes read, with the host wall-clock time they were read (us since the epoch).
    std::function<void(std::string_view bytes, utime_t utime)> on_bytes;
    std::function<void()> on_close;  // the device went away; its fd is closed
  };
  // Arms the reopen timer on `node`; call start() to make the first attempt. The link must
  // outlive node.run() and be destroyed before the node.
  SerialLink(Node& node, SerialLinkOptions options, Callbacks callbacks);
  ~SerialLink();
  SerialLink(const SerialLink&) = delete;
  SerialLink& operator=(const SerialLink&) = delete;

  // First attempt to open. Returns false only for a device that can never work here (not a
  // terminal, e.g. /dev/null), with the reason in `error`; a missing device is retried.
  bool start(std::string& error);
  bool is_open() const { return port_.is_open(); }
  // Writes to the device; false (reported in health_t) when it is not open or the write failed.
  bool write(std::string_view bytes);
  SerialPort& port() { return port_; }
  int64_t opens() const { return opens_; }

 private:
  bool try_open(bool first);
  void on_readable(short revents);
  void gone(const std::string& why);
  void check_path();

  Node& node_;
  SerialLinkOptions options_;
  Callbacks callbacks_;
  SerialPort port_;
  std::string last_open_error_;
  bool ever_open_ = false;
  bool just_gone_ = false;
  int64_t opens_ = 0;
  std::shared_ptr<bool> alive_;  // the node's timer outlives us
};

}  // namespace ips
