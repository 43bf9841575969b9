// core/serial_port on real pseudo-terminals (openpty): raw 8N1 settings, bytes through unchanged,
// not-a-terminal and missing devices, and SerialLink on a node: a device missing at start, bytes
// with their reception time, hang-up reported in health_t, reopen when the device returns.
// (Lives with its first user, ips-uwb-serial; belongs in tests/core/ once a second driver uses it.)
#include "core/serial_port.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <ips/health_t.hpp>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include "core/node.hpp"

namespace ips {
namespace {

namespace fs = std::filesystem;

// One pseudo-terminal: the test holds the master (the "device"), the code under test opens the
// slave by path.
struct Pty {
  int master = -1;
  int slave = -1;  // kept open so that the master never reads EIO while nobody has the slave
  std::string path;
  Pty() {
    char name[256];
    if (openpty(&master, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty");
    path = name;
  }
  ~Pty() { unplug(); }
  void unplug() {
    if (master >= 0) close(master);
    if (slave >= 0) close(slave);
    master = slave = -1;
  }
  void send(const std::string& s) const {
    ASSERT_EQ(write(master, s.data(), s.size()), static_cast<ssize_t>(s.size()));
  }
  // What the port wrote: `size` bytes, or what came within 30 s.
  std::string receive(size_t size) const {
    std::string got;
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    pollfd p{master, POLLIN, 0};
    while (got.size() < size && std::chrono::steady_clock::now() < end &&
           poll(&p, 1, 100) >= 0) {
      if (!(p.revents & POLLIN)) {
        if (p.revents != 0) break;  // hung up or failed: nothing more will come
        continue;
      }
      char buf[256];
      const ssize_t n = read(master, buf, sizeof buf);
      if (n <= 0) break;
      got.append(buf, static_cast<size_t>(n));
    }
    return got;
  }
};

struct TempDir {
  fs::path path;
  TempDir() {
    char tmpl[] = "/tmp/ips-serial-test-XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() { fs::remove_all(path); }
};

TEST(SerialPort, OpensAPseudoTerminalAsRaw8N1AndPassesBytesUnchanged) {
  Pty pty;
  SerialPort port;
  std::string error;
  ASSERT_TRUE(port.open(pty.path, 115200, error)) << error;
  termios tio{};
  ASSERT_EQ(tcgetattr(port.fd(), &tio), 0);
  EXPECT_EQ(cfgetospeed(&tio), static_cast<speed_t>(B115200));
  EXPECT_EQ(cfgetispeed(&tio), static_cast<speed_t>(B115200));
  EXPECT_EQ(tio.c_cflag & CSIZE, static_cast<tcflag_t>(CS8));
  EXPECT_EQ(tio.c_cflag & (PARENB | CSTOPB | CRTSCTS), 0u);
  EXPECT_NE(tio.c_cflag & CLOCAL, 0u);
  EXPECT_EQ(tio.c_lflag & (ECHO | ICANON | ISIG), 0u);
  EXPECT_EQ(tio.c_oflag & OPOST, 0u);
  EXPECT_EQ(tio.c_iflag & (ICRNL | IXON), 0u);
  EXPECT_NE(fcntl(port.fd(), F_GETFL) & O_NONBLOCK, 0);

  // Nothing waiting: kNothing at once, not a block.
  char buf[64];
  size_t n = 99;
  std::string why;
  EXPECT_EQ(port.read_some(buf, sizeof buf, n, why), SerialPort::ReadStatus::kNothing);
  EXPECT_EQ(n, 0u);

  // Carriage returns and binary bytes both ways, untranslated.
  ASSERT_TRUE(port.write_all(std::string("\r\rlec\r\x01\xff", 8), 500, error)) << error;
  EXPECT_EQ(pty.receive(8), std::string("\r\rlec\r\x01\xff", 8));
  pty.send("DIST,0\r\nx\r");
  // The pty hands the bytes over asynchronously: wait until the port is readable.
  pollfd readable{port.fd(), POLLIN, 0};
  ASSERT_EQ(poll(&readable, 1, 30000), 1);
  ASSERT_EQ(port.read_some(buf, sizeof buf, n, why), SerialPort::ReadStatus::kData);
  EXPECT_EQ(std::string(buf, n), "DIST,0\r\nx\r");
}

TEST(SerialPort, SaysWhyItCannotOpen) {
  SerialPort port;
  std::string error;
  EXPECT_FALSE(port.open("/dev/null", 115200, error));
  EXPECT_EQ(port.last_open_errno(), ENOTTY);
  EXPECT_EQ(error, "not a terminal (serial) device");
  EXPECT_FALSE(port.open("/nonexistent/ttyUSB9", 115200, error));
  EXPECT_EQ(port.last_open_errno(), ENOENT);
  EXPECT_EQ(error, "No such file or directory");
  Pty pty;
  EXPECT_FALSE(port.open(pty.path, 12345, error));
  EXPECT_EQ(error, "unsupported baud rate 12345");
  EXPECT_FALSE(port.is_open());
}

TEST(SerialPort, PathProblemsAndBaudRates) {
  TempDir dir;
  EXPECT_EQ(serial_path_problem(dir.path.string()), "is a directory");
  const std::string file = (dir.path / "f").string();
  { std::ofstream(file) << "x"; }
  EXPECT_EQ(serial_path_problem(file), "is a regular file, not a serial device");
  EXPECT_EQ(serial_path_problem(file + "/tty"), "a parent of it is not a directory");
  EXPECT_EQ(serial_path_problem((dir.path / "ttyACM0").string()), "");  // plugged in later
  EXPECT_EQ(serial_path_problem("/dev/null"), "");  // a character device; open() decides
  EXPECT_EQ(serial_path_problem(""), "empty path");
  for (int b : {9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600, 1000000, 3000000})
    EXPECT_TRUE(serial_baud_supported(b)) << b;
  for (int b : {0, -115200, 12345, 115201, 5000000}) EXPECT_FALSE(serial_baud_supported(b)) << b;
}

CommonOptions memq() {
  CommonOptions o;
  o.lcm_url = "memq://";
  return o;
}

// Spins `node` until `done()` or `timeout_s` (generous: a loaded machine can take a while).
template <class Done>
bool spin_until(Node& node, Done done, double timeout_s = 30.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    node.spin_once(10);
  }
  return true;
}

TEST(SerialLink, MissingAtStartHangUpReportedReopenedWhenBack) {
  TempDir dir;
  const std::string link_path = (dir.path / "ttyUWB").string();
  Node node("serial-link-test", memq());
  health_t health{};
  int healths = 0;
  node.subscribe<health_t>("HEALTH", [&](const health_t& h, const std::string&) {
    health = h;
    ++healths;
  });
  auto latest_health = [&] {
    const int before = healths;
    node.publish_health();
    spin_until(node, [&] { return healths > before; });
    return health;
  };
  int opens = 0, closes = 0;
  std::string bytes;
  utime_t last_utime = 0;
  SerialLink link(node, {link_path, 115200, 0.05},
                  {[&] { ++opens; },
                   [&](std::string_view b, utime_t t) {
                     bytes.append(b);
                     last_utime = t;
                   },
                   [&] { ++closes; }});
  std::string error;
  ASSERT_TRUE(link.start(error)) << error;  // missing is not fatal
  EXPECT_FALSE(link.is_open());
  auto h = latest_health();
  EXPECT_EQ(h.state, health_t::STATE_DEGRADED);
  EXPECT_EQ(h.last_error, "device " + link_path +
                              " not available (No such file or directory); retrying every 0.05 s");

  // Plugged in: opened on the next retry, state back to OK.
  auto pty = std::make_unique<Pty>();
  fs::create_symlink(pty->path, link_path);
  ASSERT_TRUE(spin_until(node, [&] { return opens == 1; }));
  EXPECT_EQ(latest_health().state, health_t::STATE_OK);
  const utime_t before = wall_utime_now();
  pty->send("RANGE T1 A1 1.0\n");
  ASSERT_TRUE(spin_until(node, [&] { return bytes.size() == 16; }));
  EXPECT_EQ(bytes, "RANGE T1 A1 1.0\n");
  EXPECT_GE(last_utime, before);
  EXPECT_LE(last_utime, wall_utime_now());
  ASSERT_TRUE(link.write("lec\r"));
  EXPECT_EQ(pty->receive(4), "lec\r");

  // Unplugged: the hang-up closes the port and health_t says so.
  pty->unplug();
  fs::remove(link_path);
  ASSERT_TRUE(spin_until(node, [&] { return closes == 1; }));
  EXPECT_FALSE(link.is_open());
  h = latest_health();
  EXPECT_EQ(h.state, health_t::STATE_DEGRADED);
  EXPECT_EQ(h.last_error, "device " + link_path + " gone; retrying");
  EXPECT_FALSE(link.write("x"));
  // Retries while it stays away change nothing and report nothing new.
  node.spin_once(200);
  EXPECT_EQ(latest_health().last_error, "device " + link_path + ": cannot write, not open");

  // Back (a new pty at the same link): reopened, bytes flow again.
  pty = std::make_unique<Pty>();
  fs::create_symlink(pty->path, link_path);
  ASSERT_TRUE(spin_until(node, [&] { return opens == 2; }));
  pty->send("again\n");
  ASSERT_TRUE(spin_until(node, [&] { return bytes.size() == 22; }));
  EXPECT_EQ(bytes.substr(16), "again\n");
  EXPECT_EQ(latest_health().state, health_t::STATE_OK);
  EXPECT_EQ(link.opens(), 2);
}

TEST(SerialLink, PathVanishingWhileOpenIsGone) {
  TempDir dir;
  const std::string link_path = (dir.path / "ttyUWB").string();
  Pty pty;
  fs::create_symlink(pty.path, link_path);
  Node node("serial-link-test", memq());
  int closes = 0;
  SerialLink link(node, {link_path, 115200, 0.05}, {nullptr, nullptr, [&] { ++closes; }});
  std::string error;
  ASSERT_TRUE(link.start(error)) << error;
  ASSERT_TRUE(link.is_open());
  fs::remove(link_path);  // udev removed the node; the fd itself still works
  ASSERT_TRUE(spin_until(node, [&] { return closes == 1; }));
  EXPECT_FALSE(link.is_open());
}

TEST(SerialLink, NotATerminalIsAStartUpError) {
  Node node("serial-link-test", memq());
  SerialLink link(node, {"/dev/null", 115200, 1.0}, {});
  std::string error;
  EXPECT_FALSE(link.start(error));
  EXPECT_EQ(error, "/dev/null: not a terminal (serial) device");
}

}  // namespace
}  // namespace ips
