#pragma once
// --tags and --shard on a live process: messages of tags this instance does not handle are
// skipped before its estimator sees them, counted, and said in HEALTH's note once a second
// ("shard 2/3: 5120 messages of 7 other tags skipped"). Messages that belong to no tag pass:
// main.cpp asks only for a message's tag, and the site's anchors and reference barometers
// (anchor-to-anchor ranges, a reference station's BARO) always pass.
#include <cstdint>
#include <string>
#include <vector>

#include "core/node.hpp"
#include "core/site.hpp"
#include "core/tag_selector.hpp"

namespace ips {

// The site's anchors and reference stations: senders that are no tag, always passed (also by
// ips-replay's hosted estimators).
std::vector<std::string> site_non_tag_ids(const Site& site);

class TagFilter {
 public:
  // From the options parse_command_line checked (opts.tags, opts.shard). When they select every
  // tag, pass() is always true and nothing is said.
  TagFilter(Node& node, const CommonOptions& opts);

  // Whether a message of the tag `id` is for this instance; false counts it as skipped.
  bool pass(const std::string& id) {
    if (selector_.selects_all() || selector_.selects(id)) return true;
    ++skipped_;
    return false;
  }
  // The site's anchors and reference stations: not tags, always passed.
  void set_site(const Site& site);

  const TagSelector& selector() const { return selector_; }
  int64_t skipped() const { return skipped_; }
  // The HEALTH note: "shard 2/3: 5120 messages of 7 other tags skipped".
  std::string note() const;

 private:
  TagSelector selector_;
  int64_t skipped_ = 0;
};

}  // namespace ips
