// soak-switch: the LAN of scripts/soak, a multicast switch in user space with netem's faults.
//
// This machine's kernel has no sch_netem (`tc qdisc add ... netem` answers "Specified qdisc kind
// is unknown"), so the soak's links cannot be spoiled by tc. This program stands where the bridge
// would: in the switch's network namespace, one port per host (the far ends of the hosts' veth
// pairs). A UDP datagram to the LCM group that comes in on one port goes out of every other port,
// each copy on its own: lost with the egress port's probability, duplicated, delayed by a fixed
// delay plus a normal jitter, or sent at once ahead of the queue (netem's "reorder"). The jitter
// keeps each port's order (as netem with a rate or a FIFO child does): a sender that was not
// scheduled for a moment sends a burst spanning a few hundred milliseconds of its messages at
// once, and jitter that reordered within it would move messages by that much, which no switch
// does; only the "reorder" probability takes a copy out of turn. Seeded, so a run's faults are the same for the same traffic.
// Delays count from the kernel's receive time of each datagram (SO_TIMESTAMPNS), not from when
// this process got to read it: a switch that was not scheduled for a while (a loaded machine)
// then sends its backlog late but in the order and spacing it came, where jitter from the time
// of reading would have shuffled a burst spanning hundreds of milliseconds.
//
//   soak-switch --group 239.255.76.67:7667 --port NAME[,loss=P][,dup=P][,delay_ms=D]
//               [,jitter_ms=J][,reorder=P] [--port ...] [--seed S] [--stats FILE]
//
// Every second, and on SIGINT/SIGTERM (then it exits 0), FILE gets the counts per port as JSON
// (rewritten whole: a temporary file renamed over it): datagrams in, out, lost on purpose,
// duplicated, reordered, and dropped for a full queue or a failed send (which are not faults on
// purpose, and the soak reports them apart).
#include <arpa/inet.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <ctime>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <queue>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

volatile std::sig_atomic_t g_stop = 0;
void on_signal(int) { g_stop = 1; }

struct Faults {
  double loss = 0.0, dup = 0.0, delay_ms = 0.0, jitter_ms = 0.0, reorder = 0.0;
};

struct Port {
  std::string name;
  unsigned index = 0;
  Faults faults;  // of what leaves through this port
  int rx = -1, tx = -1;
  // Counts: in (received on this port), out (sent through it), and what became of the copies
  // meant for it.
  int64_t in = 0, out = 0, lost = 0, duplicated = 0, reordered = 0, queue_full = 0,
          send_failed = 0;
  int64_t last_due_ns = 0;  // of the last copy queued in turn: the next is not due before it
};

struct Pending {
  int64_t due_ns;
  uint64_t order;  // ties: first in, first out
  size_t port;
  std::shared_ptr<const std::vector<uint8_t>> data;
  bool operator>(const Pending& o) const {
    return due_ns != o.due_ns ? due_ns > o.due_ns : order > o.order;
  }
};

// CLOCK_REALTIME, the clock of the kernel's receive time stamps.
int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// One datagram from `fd` into `buf`, with the kernel's receive time (now when it gives none);
// -1 when none is waiting.
ssize_t receive(int fd, std::vector<uint8_t>& buf, int64_t& rx_ns) {
  iovec iov{buf.data(), buf.size()};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof control;
  const ssize_t n = recvmsg(fd, &msg, 0);
  if (n < 0) return n;
  rx_ns = now_ns();
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
      rx_ns = static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
    }
  }
  return n;
}

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "soak-switch: %s\n", what.c_str());
  std::exit(2);
}

double number(const std::string& key, const std::string& text, double lo, double hi) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !(v >= lo && v <= hi))
    die("--port: " + key + "=" + text + " is not a number in [" + std::to_string(lo) + ", " +
        std::to_string(hi) + "]");
  return v;
}

Port parse_port(const std::string& spec) {
  Port p;
  size_t at = spec.find(',');
  p.name = spec.substr(0, at);
  if (p.name.empty() || p.name.size() >= IFNAMSIZ) die("--port: bad interface name in '" + spec + "'");
  while (at != std::string::npos) {
    const size_t next = spec.find(',', at + 1);
    const std::string kv = spec.substr(at + 1, next == std::string::npos ? std::string::npos
                                                                         : next - at - 1);
    const size_t eq = kv.find('=');
    if (eq == std::string::npos) die("--port: '" + kv + "' is not KEY=VALUE");
    const std::string k = kv.substr(0, eq), v = kv.substr(eq + 1);
    if (k == "loss") p.faults.loss = number(k, v, 0, 1);
    else if (k == "dup") p.faults.dup = number(k, v, 0, 1);
    else if (k == "reorder") p.faults.reorder = number(k, v, 0, 1);
    else if (k == "delay_ms") p.faults.delay_ms = number(k, v, 0, 10000);
    else if (k == "jitter_ms") p.faults.jitter_ms = number(k, v, 0, 10000);
    else die("--port: unknown key '" + k + "' (loss, dup, reorder, delay_ms, jitter_ms)");
    at = next;
  }
  p.index = if_nametoindex(p.name.c_str());
  if (p.index == 0) die("--port: no interface '" + p.name + "' here: " + std::strerror(errno));
  return p;
}

void check(int rc, const std::string& what) {
  if (rc < 0) die(what + ": " + std::strerror(errno));
}

void open_port(Port& p, in_addr group, uint16_t port) {
  const int one = 1, zero = 0, ttl = 1, buf = 8 << 20;
  p.rx = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  check(p.rx, "socket");
  check(setsockopt(p.rx, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one), "SO_REUSEADDR");
  check(setsockopt(p.rx, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one), "SO_TIMESTAMPNS");
  check(setsockopt(p.rx, SOL_SOCKET, SO_BINDTODEVICE, p.name.c_str(),
                   static_cast<socklen_t>(p.name.size())),
        "SO_BINDTODEVICE " + p.name);
  if (setsockopt(p.rx, SOL_SOCKET, SO_RCVBUFFORCE, &buf, sizeof buf) < 0)
    setsockopt(p.rx, SOL_SOCKET, SO_RCVBUF, &buf, sizeof buf);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_ANY);
  check(bind(p.rx, reinterpret_cast<sockaddr*>(&a), sizeof a), "bind " + p.name);
  ip_mreqn m{};
  m.imr_multiaddr = group;
  m.imr_ifindex = static_cast<int>(p.index);
  check(setsockopt(p.rx, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof m), "join on " + p.name);

  p.tx = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  check(p.tx, "socket");
  check(setsockopt(p.tx, SOL_SOCKET, SO_BINDTODEVICE, p.name.c_str(),
                   static_cast<socklen_t>(p.name.size())),
        "SO_BINDTODEVICE " + p.name);
  ip_mreqn out{};
  out.imr_ifindex = static_cast<int>(p.index);
  check(setsockopt(p.tx, IPPROTO_IP, IP_MULTICAST_IF, &out, sizeof out), "IP_MULTICAST_IF");
  check(setsockopt(p.tx, IPPROTO_IP, IP_MULTICAST_LOOP, &zero, sizeof zero), "IP_MULTICAST_LOOP");
  check(setsockopt(p.tx, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof ttl), "IP_MULTICAST_TTL");
  if (setsockopt(p.tx, SOL_SOCKET, SO_SNDBUFFORCE, &buf, sizeof buf) < 0)
    setsockopt(p.tx, SOL_SOCKET, SO_SNDBUF, &buf, sizeof buf);
}

void write_stats(const std::string& path, const std::vector<Port>& ports, int64_t queued) {
  if (path.empty()) return;
  const std::string tmp = path + ".tmp";
  FILE* f = std::fopen(tmp.c_str(), "w");
  if (f == nullptr) return;
  std::fprintf(f, "{\"queued\": %lld, \"ports\": {", static_cast<long long>(queued));
  for (size_t i = 0; i < ports.size(); ++i) {
    const Port& p = ports[i];
    std::fprintf(f,
                 "%s\"%s\": {\"in\": %lld, \"out\": %lld, \"lost\": %lld, \"duplicated\": %lld, "
                 "\"reordered\": %lld, \"queue_full\": %lld, \"send_failed\": %lld}",
                 i ? ", " : "", p.name.c_str(), static_cast<long long>(p.in),
                 static_cast<long long>(p.out), static_cast<long long>(p.lost),
                 static_cast<long long>(p.duplicated), static_cast<long long>(p.reordered),
                 static_cast<long long>(p.queue_full), static_cast<long long>(p.send_failed));
  }
  std::fprintf(f, "}}\n");
  std::fclose(f);
  std::rename(tmp.c_str(), path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string group_text = "239.255.76.67:7667", stats;
  uint64_t seed = 1;
  std::vector<Port> ports;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::puts(
          "usage: soak-switch --port NAME[,loss=P][,dup=P][,delay_ms=D][,jitter_ms=J][,reorder=P]\n"
          "                   [--port ...] [--group ADDR:PORT] [--seed S] [--stats FILE]\n"
          "A multicast switch in user space with netem's faults, for scripts/soak: a datagram to\n"
          "the group in on one port goes out of every other, each copy lost, duplicated, delayed\n"
          "(delay + normal jitter) or sent ahead of the queue with the egress port's probabilities.\n"
          "Counts per port go to FILE as JSON every second and at SIGINT/SIGTERM.");
      return 0;
    }
    if (i + 1 >= argc) die(a + " needs a value (see --help)");
    const std::string v = argv[++i];
    if (a == "--port") ports.push_back(parse_port(v));
    else if (a == "--group") group_text = v;
    else if (a == "--seed") seed = std::strtoull(v.c_str(), nullptr, 10);
    else if (a == "--stats") stats = v;
    else die("unknown option '" + a + "' (see --help)");
  }
  if (ports.size() < 2) die("give at least two --port");
  const size_t colon = group_text.rfind(':');
  in_addr group{};
  if (colon == std::string::npos || inet_pton(AF_INET, group_text.substr(0, colon).c_str(), &group) != 1)
    die("--group: expected ADDR:PORT, got '" + group_text + "'");
  const int udp_port = std::atoi(group_text.c_str() + colon + 1);
  if (udp_port <= 0 || udp_port > 65535) die("--group: bad port in '" + group_text + "'");
  sockaddr_in dest{};
  dest.sin_family = AF_INET;
  dest.sin_port = htons(static_cast<uint16_t>(udp_port));
  dest.sin_addr = group;
  for (Port& p : ports) open_port(p, group, static_cast<uint16_t>(udp_port));
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::priority_queue<Pending, std::vector<Pending>, std::greater<>> queue;
  constexpr int64_t kMaxQueuedBytes = 64ll << 20;  // past this, a copy is dropped and counted
  int64_t queued_bytes = 0;
  uint64_t order = 0;
  std::vector<pollfd> fds;
  for (const Port& p : ports) fds.push_back({p.rx, POLLIN, 0});
  std::vector<uint8_t> buf(65536);
  int64_t next_stats = now_ns();
  std::fprintf(stderr, "soak-switch: %zu ports, group %s, seed %llu\n", ports.size(),
               group_text.c_str(), static_cast<unsigned long long>(seed));

  while (!g_stop) {
    int64_t now = now_ns();
    // Send what is due.
    while (!queue.empty() && queue.top().due_ns <= now) {
      const Pending& top = queue.top();
      Port& p = ports[top.port];
      const ssize_t n = sendto(p.tx, top.data->data(), top.data->size(), 0,
                               reinterpret_cast<const sockaddr*>(&dest), sizeof dest);
      if (n < 0) ++p.send_failed;
      else ++p.out;
      queued_bytes -= static_cast<int64_t>(top.data->size());
      queue.pop();
    }
    if (now >= next_stats) {
      write_stats(stats, ports, static_cast<int64_t>(queue.size()));
      next_stats = now + 1'000'000'000;
    }
    int64_t wait_ns = next_stats - now;
    if (!queue.empty()) wait_ns = std::min(wait_ns, queue.top().due_ns - now);
    const int wait_ms = static_cast<int>(std::max<int64_t>(0, (wait_ns + 999'999) / 1'000'000));
    if (poll(fds.data(), fds.size(), wait_ms) < 0) {
      if (errno == EINTR) continue;
      die(std::string("poll: ") + std::strerror(errno));
    }
    for (size_t i = 0; i < ports.size(); ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      for (int burst = 0; burst < 256; ++burst) {
        int64_t rx_ns = 0;
        const ssize_t n = receive(ports[i].rx, buf, rx_ns);
        if (n < 0) break;
        ++ports[i].in;
        auto data = std::make_shared<const std::vector<uint8_t>>(buf.begin(), buf.begin() + n);
        for (size_t j = 0; j < ports.size(); ++j) {
          if (j == i) continue;
          Port& e = ports[j];
          if (uniform(rng) < e.faults.loss) {
            ++e.lost;
            continue;
          }
          const int copies = uniform(rng) < e.faults.dup ? 2 : 1;
          if (copies == 2) ++e.duplicated;
          for (int c = 0; c < copies; ++c) {
            int64_t delay_ns = 0;
            if (uniform(rng) < e.faults.reorder) {
              ++e.reordered;  // at once, ahead of what waits
            } else {
              const double ms = e.faults.delay_ms + e.faults.jitter_ms * normal(rng);
              delay_ns = static_cast<int64_t>(std::max(0.0, ms) * 1e6);
              delay_ns = std::max(delay_ns, e.last_due_ns - rx_ns);  // in turn
              e.last_due_ns = rx_ns + delay_ns;
            }
            if (queued_bytes + n > kMaxQueuedBytes) {
              ++e.queue_full;
              continue;
            }
            queued_bytes += n;
            queue.push(Pending{rx_ns + delay_ns, order++, j, data});
          }
        }
      }
    }
  }
  write_stats(stats, ports, static_cast<int64_t>(queue.size()));
  std::fprintf(stderr, "soak-switch: stopped\n");
  return 0;
}
