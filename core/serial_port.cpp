#include "core/serial_port.hpp"

#include <fcntl.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ips/health_t.hpp>
#include <memory>
#include <thread>

#include "core/node.hpp"

namespace ips {

namespace {

struct BaudCode {
  int baud;
  speed_t code;
};
// The speeds Linux termios defines (asm-generic/termbits.h).
constexpr BaudCode kBauds[] = {
    {50, B50},           {75, B75},           {110, B110},         {134, B134},
    {150, B150},         {200, B200},         {300, B300},         {600, B600},
    {1200, B1200},       {1800, B1800},       {2400, B2400},       {4800, B4800},
    {9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
    {115200, B115200},   {230400, B230400},   {460800, B460800},   {500000, B500000},
    {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
    {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000},
    {3500000, B3500000}, {4000000, B4000000}};

bool baud_code(int baud, speed_t& code) {
  for (const auto& b : kBauds)
    if (b.baud == baud) {
      code = b.code;
      return true;
    }
  return false;
}

std::string errno_text(int err) { return std::strerror(err); }

// "1", "0.2": seconds as a person writes them.
std::string format_seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", s);
  return buf;
}

}  // namespace

bool serial_baud_supported(int baud) {
  speed_t code;
  return baud_code(baud, code);
}

std::string serial_path_problem(const std::string& path) {
  if (path.empty()) return "empty path";
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    // Not there (yet): a device plugged in later, or a /dev/serial/by-id link udev makes then.
    if (errno == ENOENT) return "";
    if (errno == ENOTDIR) return "a parent of it is not a directory";
    return "";  // e.g. EACCES on a parent: the open attempts will say so
  }
  if (S_ISDIR(st.st_mode)) return "is a directory";
  if (S_ISREG(st.st_mode)) return "is a regular file, not a serial device";
  if (S_ISFIFO(st.st_mode)) return "is a FIFO, not a serial device";
  if (S_ISSOCK(st.st_mode)) return "is a socket, not a serial device";
  if (S_ISBLK(st.st_mode)) return "is a block device, not a serial device";
  return "";
}

bool SerialPort::open(const std::string& path, int baud, std::string& error) {
  close();
  open_errno_ = 0;
  speed_t speed;
  if (!baud_code(baud, speed)) {
    open_errno_ = EINVAL;
    error = "unsupported baud rate " + std::to_string(baud);
    return false;
  }
  // O_NOCTTY: a serial device must never become our controlling terminal (a hang-up would
  // then send us SIGHUP).
  const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    open_errno_ = errno;
    error = errno_text(open_errno_);
    return false;
  }
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) {
    open_errno_ = errno;
    error = open_errno_ == ENOTTY ? "not a terminal (serial) device" : errno_text(open_errno_);
    ::close(fd);
    return false;
  }
  // Raw 8N1: no input or output processing, no echo, no signals from bytes, receiver on, modem
  // control lines ignored (USB CDC devices and three-wire UARTs have none), no flow control.
  cfmakeraw(&tio);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CREAD | CLOCAL;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  // VMIN 1, VTIME 0 with O_NONBLOCK: a read with nothing waiting fails with EAGAIN, so a read of
  // 0 bytes means end of file, which a terminal reports only after a hang-up. (With VMIN 0 an
  // empty read also returns 0 and the two could not be told apart.)
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (cfsetispeed(&tio, speed) != 0 || cfsetospeed(&tio, speed) != 0 ||
      tcsetattr(fd, TCSANOW, &tio) != 0) {
    open_errno_ = errno;
    error = "cannot set " + std::to_string(baud) + " 8N1 raw: " + errno_text(open_errno_);
    ::close(fd);
    return false;
  }
  fd_ = fd;
  path_ = path;
  return true;
}

SerialPort::ReadStatus SerialPort::read_some(char* buf, size_t capacity, size_t& n,
                                             std::string& why) {
  n = 0;
  if (fd_ < 0) {
    why = "not open";
    return ReadStatus::kGone;
  }
  for (;;) {
    const ssize_t r = ::read(fd_, buf, capacity);
    if (r > 0) {
      n = static_cast<size_t>(r);
      return ReadStatus::kData;
    }
    if (r == 0) {
      why = "end of file (hang-up)";
      return ReadStatus::kGone;
    }
    if (errno == EINTR) continue;
    if (errno == EAGAIN || errno == EWOULDBLOCK) return ReadStatus::kNothing;
    why = "read: " + errno_text(errno);
    return ReadStatus::kGone;
  }
}

bool SerialPort::write_all(std::string_view bytes, int timeout_ms, std::string& error) {
  if (fd_ < 0) {
    error = "not open";
    return false;
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (!bytes.empty()) {
    const ssize_t w = ::write(fd_, bytes.data(), bytes.size());
    if (w > 0) {
      bytes.remove_prefix(static_cast<size_t>(w));
      continue;
    }
    if (w < 0 && errno == EINTR) continue;
    if (w < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      error = "write: " + errno_text(errno);
      return false;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                          deadline - std::chrono::steady_clock::now())
                          .count();
    if (left <= 0) {
      error = "write: output queue full for " + std::to_string(timeout_ms) + " ms";
      return false;
    }
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, static_cast<int>(left));
  }
  return true;
}

void SerialPort::drain(int timeout_ms) {
  if (fd_ < 0) return;
  // tcdrain can block for ever on a device that stopped reading; poll the output queue instead.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  while (std::chrono::steady_clock::now() < deadline) {
    int queued = 0;
    if (ioctl(fd_, TIOCOUTQ, &queued) != 0 || queued == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

void SerialPort::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

// ---------------------------------------------------------------------------------------------

SerialLink::SerialLink(Node& node, SerialLinkOptions options, Callbacks callbacks)
    : node_(node),
      options_(std::move(options)),
      callbacks_(std::move(callbacks)),
      alive_(std::make_shared<bool>(true)) {
  node_.add_timer(options_.reopen_s, [this, alive = alive_] {
    if (!*alive) return;
    if (port_.is_open()) {
      check_path();
    } else {
      try_open(false);
    }
  });
}

SerialLink::~SerialLink() {
  *alive_ = false;
  if (port_.is_open()) node_.unwatch_fd(port_.fd());
}

bool SerialLink::start(std::string& error) {
  if (try_open(true)) return true;
  if (port_.last_open_errno() == ENOTTY || port_.last_open_errno() == EINVAL) {
    error = options_.path + ": " + last_open_error_;
    return false;
  }
  return true;
}

bool SerialLink::try_open(bool first) {
  std::string error;
  if (!port_.open(options_.path, options_.baud, error)) {
    // Only the first failure and a change of reason are reported: a device that stays
    // unplugged must not fill the log once a second.
    if (error == last_open_error_ && !first) return false;
    last_open_error_ = error;
    if (first && (port_.last_open_errno() == ENOTTY || port_.last_open_errno() == EINVAL))
      return false;  // start() turns it into a start-up error
    if (just_gone_ && port_.last_open_errno() == ENOENT) {
      just_gone_ = false;  // gone() has said so already
      return false;
    }
    just_gone_ = false;
    node_.report_lasting_error(options_.path,
                               "device " + options_.path +
                                   (ever_open_ ? ": cannot reopen (" : " not available (") +
                                   error + "); retrying every " +
                                   format_seconds(options_.reopen_s) + " s");
    return false;
  }
  last_open_error_.clear();
  ever_open_ = true;
  ++opens_;
  spdlog::info("{}: opened {} at {} baud, 8N1 raw", node_.name(), options_.path, options_.baud);
  node_.end_lasting_error(options_.path);
  node_.watch_fd(port_.fd(), POLLIN, [this](short revents) { on_readable(revents); });
  if (callbacks_.on_open) callbacks_.on_open();
  return true;
}

void SerialLink::on_readable(short revents) {
  char buf[4096];
  bool got = false;
  // Bounded: a device streaming faster than we read must not starve the LCM fd and timers.
  for (int i = 0; i < 16 && port_.is_open(); ++i) {
    size_t n = 0;
    std::string why;
    const auto status = port_.read_some(buf, sizeof buf, n, why);
    if (status == SerialPort::ReadStatus::kData) {
      got = true;
      if (callbacks_.on_bytes) callbacks_.on_bytes(std::string_view(buf, n), wall_utime_now());
      if (n < sizeof buf) break;
      continue;
    }
    if (status == SerialPort::ReadStatus::kGone) {
      gone(why);
      return;
    }
    break;
  }
  if (!port_.is_open()) return;
  if ((revents & (POLLHUP | POLLERR | POLLNVAL)) && !got) {
    gone(revents & POLLNVAL ? "poll: invalid fd" : revents & POLLERR ? "poll: error" : "hang-up");
  }
}

void SerialLink::gone(const std::string& why) {
  if (!port_.is_open()) return;
  node_.unwatch_fd(port_.fd());
  port_.close();
  last_open_error_.clear();
  just_gone_ = true;
  node_.report_lasting_error(options_.path, "device " + options_.path + " gone; retrying");
  spdlog::debug("{}: device {} gone ({}); retrying every {} s", node_.name(), options_.path, why,
                format_seconds(options_.reopen_s));
  if (callbacks_.on_close) callbacks_.on_close();
}

void SerialLink::check_path() {
  // A USB device whose node was removed while we still hold its fd (udev was faster than the
  // hang-up): the fd is dead, the next device will be a new node.
  struct stat st {};
  if (stat(options_.path.c_str(), &st) != 0 && errno == ENOENT) gone("path vanished");
}

bool SerialLink::write(std::string_view bytes) {
  std::string error;
  if (!port_.is_open()) {
    // Part of the device being away: it ends when the device is back.
    node_.report_lasting_error(options_.path, "device " + options_.path + ": cannot write, not open");
    return false;
  }
  if (!port_.write_all(bytes, 500, error)) {
    node_.report_error("device " + options_.path + ": " + error);
    return false;
  }
  return true;
}

}  // namespace ips
