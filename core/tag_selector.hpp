#pragma once
// Which tags a process of a partitioned site handles (--tags, --shard; docs/networking.md
// "Splitting a big site"). Several instances of one estimator split the tags between them: each
// takes the tags its --tags patterns name and, with --shard K/N, only those whose shard is K.
//
// The shard of a tag id is stable and documented, so anyone can tell where a tag is handled:
//   shard = FNV-1a 64 (the id's bytes) mod N, plus 1        (1 <= shard <= N)
// FNV-1a 64: h = 14695981039346656037; for each byte b: h ^= b; h *= 1099511628211 (mod 2^64).
// E.g. with N = 3: T1 -> 1, T2 -> 3, T3 -> 2 (tests/core/tag_selector_test.cpp).
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <vector>

namespace ips {

inline constexpr int kMaxShards = 1024;

// FNV-1a, 64 bits, of the bytes of `id`.
uint64_t fnv1a64(std::string_view id);
// The 1-based shard of `id` among `shards` (1 to kMaxShards).
int shard_of(std::string_view id, int shards);
// A glob: `*` any run of bytes (also none), `?` exactly one byte, every other byte itself.
bool glob_matches(std::string_view pattern, std::string_view text);

class TagSelector {
 public:
  // Selects every tag.
  TagSelector() = default;

  // From --tags (a comma list of ids and globs; empty: every tag) and --shard ("K/N"; empty: no
  // sharding). nullopt, with `error` saying which flag and why, for a bad value.
  static std::optional<TagSelector> parse(const std::string& tags, const std::string& shard,
                                          std::string& error);

  // True when the selector lets every tag through (no --tags, no --shard).
  bool selects_all() const { return patterns_.empty() && shards_ == 0; }
  // Whether the tag with this id is handled here. Ids set with set_always_selected() (anchors,
  // reference stations) always are. Each id is decided once and remembered (up to
  // kCachedIds ids; beyond that the decision is made again each time, which is cheap too).
  bool selects(const std::string& id);
  // Ids that are not tags and pass whatever the patterns and shard say.
  void set_always_selected(const std::vector<std::string>& ids);

  int shard() const { return shard_; }    // K, 0 when not sharded
  int shards() const { return shards_; }  // N, 0 when not sharded
  const std::vector<std::string>& patterns() const { return patterns_; }
  // "shard 2/3 of the tags T1*, T2": what the selector takes, for logs and HEALTH.
  std::string describe() const;
  // Distinct ids seen and not selected (as far as remembered).
  int64_t rejected_ids() const { return rejected_ids_; }

  static constexpr size_t kCachedIds = 16384;

 private:
  bool decide(std::string_view id) const;

  std::vector<std::string> patterns_;
  int shard_ = 0;
  int shards_ = 0;
  std::unordered_set<std::string> always_;
  std::unordered_map<std::string, bool> decided_;
  int64_t rejected_ids_ = 0;
};

}  // namespace ips
