#include "core/tag_selector.hpp"

#include <charconv>

#include "core/text_escape.hpp"

namespace ips {

uint64_t fnv1a64(std::string_view id) {
  uint64_t h = 14695981039346656037ull;
  for (const char c : id) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;
  }
  return h;
}

int shard_of(std::string_view id, int shards) {
  return static_cast<int>(fnv1a64(id) % static_cast<uint64_t>(shards)) + 1;
}

// The greedy matcher with one back-track point: on a mismatch after a `*`, that `*` takes one
// byte more. O(pattern x text) at worst, no recursion.
bool glob_matches(std::string_view pattern, std::string_view text) {
  size_t p = 0, t = 0;
  size_t star = std::string_view::npos, star_t = 0;
  while (t < text.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[t])) {
      ++p;
      ++t;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      star_t = t;
    } else if (star != std::string_view::npos) {
      p = star + 1;
      t = ++star_t;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

namespace {

bool parse_int(std::string_view s, int& out) {
  if (s.empty() || s.size() > 6) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

}  // namespace

std::optional<TagSelector> TagSelector::parse(const std::string& tags, const std::string& shard,
                                              std::string& error) {
  TagSelector sel;
  if (!tags.empty()) {
    size_t start = 0;
    while (true) {
      const size_t comma = tags.find(',', start);
      const std::string item =
          tags.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      if (item.empty()) {
        error = "--tags: an empty item in '" + printable(tags) +
                "' (expected ids and globs separated by commas, e.g. T1,T2 or 'T1*')";
        return std::nullopt;
      }
      for (const char c : item) {
        if (static_cast<unsigned char>(c) < 0x20 || c == ' ') {
          error = "--tags: '" + printable(item) + "' has a space or control character";
          return std::nullopt;
        }
      }
      sel.patterns_.push_back(item);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  if (!shard.empty()) {
    const std::string expected =
        "--shard: expected K/N with 1 <= K <= N <= " + std::to_string(kMaxShards) +
        " (e.g. 2/3), got '" + printable(shard) + "'";
    const size_t slash = shard.find('/');
    int k = 0, n = 0;
    if (slash == std::string::npos || !parse_int(std::string_view(shard).substr(0, slash), k) ||
        !parse_int(std::string_view(shard).substr(slash + 1), n) || k < 1 || n < 1 ||
        n > kMaxShards || k > n) {
      error = expected;
      return std::nullopt;
    }
    sel.shard_ = k;
    sel.shards_ = n;
  }
  return sel;
}

bool TagSelector::decide(std::string_view id) const {
  if (shards_ != 0 && shard_of(id, shards_) != shard_) return false;
  if (patterns_.empty()) return true;
  for (const auto& p : patterns_)
    if (glob_matches(p, id)) return true;
  return false;
}

bool TagSelector::selects(const std::string& id) {
  if (selects_all()) return true;
  if (const auto it = decided_.find(id); it != decided_.end()) return it->second;
  const bool yes = always_.count(id) != 0 || decide(id);
  if (decided_.size() < kCachedIds) {
    decided_.emplace(id, yes);
    if (!yes) ++rejected_ids_;
  }
  return yes;
}

void TagSelector::set_always_selected(const std::vector<std::string>& ids) {
  always_ = std::unordered_set<std::string>(ids.begin(), ids.end());
  decided_.clear();
  rejected_ids_ = 0;
}

std::string TagSelector::describe() const {
  if (selects_all()) return "every tag";
  std::string text;
  if (shards_ != 0) text = "shard " + std::to_string(shard_) + "/" + std::to_string(shards_);
  if (!patterns_.empty()) {
    text += text.empty() ? "the tags " : " of the tags ";
    for (size_t i = 0; i < patterns_.size(); ++i) text += (i ? ", " : "") + printable(patterns_[i]);
  }
  return text;
}

}  // namespace ips
