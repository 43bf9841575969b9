// bench-lcm-read LOG: LCM's own log reader (liblcm's lcm_eventlog_read_next_event: every
// event read, nothing decoded) over a whole log, timed: the bare reading rate that
// scripts/bench-replay compares ips-replay with. Prints "events N bytes B seconds S span_s T
// syscall_ns C" (T: from the first event's time stamp to the last's; C: what one system call,
// lseek(fd, 0, SEEK_CUR), costs on this machine, the best of 5 rounds of 100 000). liblcm 1.3.x
// asks the file's position (ftello, one lseek) for every event it reads, so its rate follows the
// machine's system-call cost, which differs several times between virtual machines of one class
// (docs/development.md).
#include <lcm/eventlog.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string_view>

int main(int argc, char** argv) {
  if (argc != 2 || argv[1][0] == '-') {
    std::fprintf(stderr, "usage: bench-lcm-read LOG\n(liblcm's log reader over LOG, timed)\n");
    return argc == 2 && (argv[1] == std::string_view("--help") || argv[1] == std::string_view("-h"))
               ? 0
               : 2;
  }
  const auto t0 = std::chrono::steady_clock::now();
  lcm_eventlog_t* log = lcm_eventlog_create(argv[1], "r");
  if (!log) {
    std::fprintf(stderr, "bench-lcm-read: cannot read '%s'\n", argv[1]);
    return 2;
  }
  long long events = 0, bytes = 0;
  int64_t first = 0, last = 0;
  while (lcm_eventlog_event_t* e = lcm_eventlog_read_next_event(log)) {
    if (events == 0) first = e->timestamp;
    last = e->timestamp;
    ++events;
    bytes += e->datalen + e->channellen + 28;
    lcm_eventlog_free_event(e);
  }
  lcm_eventlog_destroy(log);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // One system call's cost here, on the same file.
  double syscall_ns = 0;
  if (const int fd = ::open(argv[1], O_RDONLY); fd >= 0) {
    constexpr int kCalls = 100000;
    for (int round = 0; round < 5; ++round) {
      const auto c0 = std::chrono::steady_clock::now();
      for (int i = 0; i < kCalls; ++i) (void)::lseek(fd, 0, SEEK_CUR);
      const double ns =
          std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - c0).count() /
          kCalls;
      syscall_ns = round == 0 ? ns : std::min(syscall_ns, ns);
    }
    ::close(fd);
  }
  std::printf("events %lld bytes %lld seconds %.6f span_s %.3f syscall_ns %.0f\n", events, bytes, s,
              1e-6 * static_cast<double>(last - first), syscall_ns);
  return 0;
}
