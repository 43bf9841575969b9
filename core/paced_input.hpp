#pragma once
// Reading a file or a pipe to its end inside a node's loop, its items handed on at the pace of
// their time stamps (ReplayPacer): ips-uwb-can's candump text (--candump-file, --candump-stdin) and
// ips-uwb-tdoa-anchors' records (--file at --rate). While items wait for their time the input is
// read at most `read_ahead` items ahead, so a writer into a pipe (cat, candump) waits too; the
// node serves HEALTH, timers and signals meanwhile. (core/paced_release.hpp puts messages already
// in memory on the bus at their recorded pace.)
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/cli.hpp"
#include "core/node.hpp"
#include "core/replay_pacer.hpp"
#include "core/time.hpp"

namespace ips {

template <class Item>
class PacedInput {
 public:
  // The time stamp an item is paced by; nullopt: handed on at once.
  using UtimeOf = std::function<std::optional<utime_t>(const Item&)>;
  // Hands the item on (parses it, publishes).
  using HandOn = std::function<void(const Item&)>;

  // speed <= 0: items handed on as they are read.
  PacedInput(Node& node, double speed, size_t read_ahead, UtimeOf utime_of, HandOn hand_on)
      : node_(node),
        pacer_(speed),
        read_ahead_(std::max<size_t>(read_ahead, 1)),
        utime_of_(std::move(utime_of)),
        hand_on_(std::move(hand_on)) {}

  void push(Item item) { pending_.push_back(std::move(item)); }

  // Reads `fd` to its end and hands every item on, or stops when the node does. `feed` splits
  // the bytes read into items and push()es them; `finish`, at the end of the input, pushes the
  // last item without its end, if any. Returns 0, or 1 after a read error (printed:
  // "<program>: error: reading <name>: <why>").
  int run(int fd, const std::string& program, const std::string& name,
          const std::function<void(std::string_view bytes)>& feed,
          const std::function<void()>& finish) {
    std::vector<char> buf(1 << 16);
    bool readable = false;
    int status = 0;
    node_.publish_health();
    while (!node_.stopping()) {
      int wait_ms = 1000;
      while (!pending_.empty()) {
        if (const std::optional<utime_t> t = utime_of_(pending_.front())) {
          const int64_t w = pacer_.wait_ms(*t, ReplayPacer::Clock::now());
          if (w > 0) {
            wait_ms = static_cast<int>(std::min<int64_t>(w, 1000));
            break;
          }
        }
        hand_on_(pending_.front());
        pending_.pop_front();
      }
      if (pending_.empty() && eof_) break;
      readable = false;
      if (!eof_ && pending_.size() < read_ahead_)
        node_.watch_fd(fd, POLLIN, [&readable](short) { readable = true; });
      else
        node_.unwatch_fd(fd);
      if (!node_.spin_once(wait_ms)) break;
      if (!readable) continue;
      const ssize_t n = read(fd, buf.data(), buf.size());
      if (n > 0) {
        feed(std::string_view(buf.data(), static_cast<size_t>(n)));
      } else if (n == 0) {
        eof_ = true;
        node_.unwatch_fd(fd);
        finish();
      } else if (errno != EAGAIN && errno != EINTR) {
        print_fatal(program, "reading " + name + ": " + std::strerror(errno));
        status = 1;
        break;
      }
    }
    node_.unwatch_fd(fd);
    node_.publish_health();
    return status;
  }

  // The input was read to its end (though the node may have stopped before all was handed on).
  bool eof() const { return eof_; }

 private:
  Node& node_;
  ReplayPacer pacer_;
  size_t read_ahead_;
  UtimeOf utime_of_;
  HandOn hand_on_;
  std::deque<Item> pending_;
  bool eof_ = false;
};

}  // namespace ips
