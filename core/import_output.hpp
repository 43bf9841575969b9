#pragma once
// Where an import's messages go: an LCM log (--out) or the bus, in time order either way. A file
// is read whole first and its messages sorted by utime (stable, so equal times keep file order):
// several per-anchor files merge into one stream, and what comes out depends only on the files,
// never on the reading or playback speed. On the bus they go out as fast as possible, or paced
// by their own times with a speed factor (--speed).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/node.hpp"

namespace ips {

class ImportOutput {
 public:
  // Encodes and keeps one message for `channel`, stamped with its own utime.
  template <class Msg>
  void add(const std::string& channel, const Msg& msg) {
    Held h;
    h.utime = msg.utime;
    h.channel = channel_index(channel);
    h.bytes.resize(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(h.bytes.data(), 0, static_cast<int>(h.bytes.size()));
    held_.push_back(std::move(h));
  }
  // Keeps an already encoded message (an event of an existing log, to merge into) at `utime`.
  void add_encoded(const std::string& channel, int64_t utime, const uint8_t* data, size_t size) {
    Held h;
    h.utime = utime;
    h.channel = channel_index(channel);
    h.bytes.assign(data, data + size);
    held_.push_back(std::move(h));
  }
  int64_t size() const { return static_cast<int64_t>(held_.size()); }
  // First and last utime held (0 when none).
  int64_t first_utime() const;
  int64_t last_utime() const;

  // Writes every message into a new LCM log at `path`, in time order. Empty, or the error line
  // ("cannot write 'x.lcm': Permission denied", "write to 'x.lcm' failed (disk full?)").
  std::string write_log(const std::string& path);
  // Publishes every message through `node` in time order, paced by speed (<= 0: as fast as
  // possible). False when the node was asked to stop (SIGINT) before the end.
  bool publish(Node& node, double speed);
  // The messages in time order (for tests and for callers that want to look at them).
  void for_each(const std::function<void(const std::string& channel, int64_t utime,
                                         const std::vector<uint8_t>& bytes)>& fn);

 private:
  struct Held {
    int64_t utime = 0;
    uint32_t channel = 0;
    std::vector<uint8_t> bytes;
  };
  uint32_t channel_index(const std::string& channel);
  void sort();

  std::vector<std::string> channels_;
  std::vector<Held> held_;
};

// "2025-03-17T22:02:20Z": the UTC second of a utime, for import summaries.
std::string utc_text(int64_t utime);

// What a driver's file import read, for its node's counters when it is published.
struct ImportCounts {
  int64_t lines = 0, parse_errors = 0, drops = 0;
};

// The end of a driver's file import: `output` into the new LCM log `out_path` (when it cannot be
// written: the error line "--out: <why>", status 1), or, with no out_path, published through a
// Node paced by `speed` (<= 0: as fast as possible) with `counts` in its counters and HEALTH once
// at the end. `on_bus(node)` runs before publishing; `done()` after the whole output was written
// or published (not when SIGINT/SIGTERM stopped it). Returns the exit status.
int write_or_publish(const std::string& program, ImportOutput& output, const std::string& out_path,
                     const CommonOptions& opts, double speed, const ImportCounts& counts,
                     const std::function<void(Node&)>& on_bus = {},
                     const std::function<void()>& done = {});

}  // namespace ips
