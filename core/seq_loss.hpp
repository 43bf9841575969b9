#pragma once
// Loss read from senders' sequence numbers: per sender key (a tag-anchor pair, an anchor, ...), a
// forward gap in the sequence is messages that never arrived. Pure: keys and numbers in, counts
// out; the node feeds it what it receives (docs/networking.md#loss).
#include <cstdint>
#include <string>
#include <unordered_map>

namespace ips {

struct SeqLossCounts {
  int64_t lost = 0;      // messages missing inside forward gaps (and across a counter's wrap)
  int64_t received = 0;  // numbered messages seen (seq >= 0)
  int64_t unknown = 0;   // messages with seq -1 (the sender does not number them)
  int64_t late = 0;      // a number at or a little behind the last one: a duplicate or reordered
  int64_t restarts = 0;  // a big jump back or forward: the sender restarted; no loss counted
};

class SeqLossCounter {
 public:
  // A jump back by more than this is a restart (or a wrap); less is a late or repeated message.
  static constexpr int64_t kLateWindow = 64;
  // A jump forward by more than this is a restart (a sender renumbered), not that many losses.
  static constexpr int64_t kMaxGap = 100000;
  // Keys kept at most (a flood of made-up ids must not grow memory without bound): beyond it new
  // keys are not followed (their messages count as unknown).
  static constexpr size_t kMaxKeys = 100000;

  // One message of sender `key` numbered `seq` (-1: unknown).
  void observe(const std::string& key, int64_t seq);
  const SeqLossCounts& counts() const { return counts_; }

 private:
  std::unordered_map<std::string, int64_t> last_;
  SeqLossCounts counts_;
};

}  // namespace ips
