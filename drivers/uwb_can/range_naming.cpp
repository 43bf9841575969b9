#include "drivers/uwb_can/range_naming.hpp"

#include <cmath>
#include <limits>

namespace ips::uwb_can {

namespace {

constexpr size_t kMaxIdLength = 63;

// Decimal digits without a sign or leading zeros ("0" itself is fine), at most max.
std::optional<uint32_t> canonical_decimal(std::string_view s, uint32_t max) {
  if (s.empty() || s.size() > 10 || (s.size() > 1 && s[0] == '0')) return std::nullopt;
  uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    v = v * 10 + static_cast<uint64_t>(c - '0');
  }
  if (v > max) return std::nullopt;
  return static_cast<uint32_t>(v);
}

bool printable_id(std::string_view s) {
  if (s.empty() || s.size() > kMaxIdLength) return false;
  for (char c : s)
    if (c < 0x21 || c > 0x7E) return false;
  return true;
}

}  // namespace

IdNumbering::IdNumbering(std::string what, std::string prefix, uint32_t max_number)
    : what_(std::move(what)), prefix_(std::move(prefix)), max_(max_number) {}

std::string IdNumbering::add(std::string_view mapping) {
  const auto eq = mapping.find('=');
  if (eq == std::string_view::npos) return "expected N=ID, got '" + std::string(mapping) + "'";
  const auto n = canonical_decimal(mapping.substr(0, eq), max_);
  if (!n)
    return "'" + std::string(mapping.substr(0, eq)) + "' is not " +
           (what_[0] == 'a' ? "an " : "a ") + what_ + " number (0.." + std::to_string(max_) + ")";
  const std::string_view id = mapping.substr(eq + 1);
  if (!printable_id(id))
    return "id '" + std::string(id) + "' must be 1 to 63 printable characters without spaces";
  if (names_.count(*n)) return what_ + " " + std::to_string(*n) + " is mapped twice";
  if (numbers_.count(id)) return "id '" + std::string(id) + "' is given to two " + what_ + "s";
  names_[*n] = std::string(id);
  numbers_.emplace(std::string(id), *n);
  return {};
}

std::string IdNumbering::check() const {
  if (prefix_.size() > kMaxIdLength - 10) return what_ + " prefix is too long";
  for (char c : prefix_)
    if (c < 0x21 || c > 0x7E)
      return what_ + " prefix '" + prefix_ + "' must be printable characters without spaces";
  for (const auto& [id, n] : numbers_) {
    const auto d = default_number(id);
    if (d && *d != n && !names_.count(*d))
      return "id '" + id + "' (" + what_ + " " + std::to_string(n) +
             ") is also the default name of " + what_ + " " + std::to_string(*d) + "; map " +
             std::to_string(*d) + " too or use another prefix";
  }
  return {};
}

std::string IdNumbering::name(uint32_t number) const {
  auto it = names_.find(number);
  if (it != names_.end()) return it->second;
  return prefix_ + std::to_string(number);
}

std::optional<uint32_t> IdNumbering::default_number(std::string_view id) const {
  if (id.size() <= prefix_.size() || id.substr(0, prefix_.size()) != prefix_) return std::nullopt;
  return canonical_decimal(id.substr(prefix_.size()), max_);
}

std::optional<uint32_t> IdNumbering::number(std::string_view id) const {
  auto it = numbers_.find(id);
  if (it != numbers_.end()) return it->second;
  const auto d = default_number(id);
  if (d && names_.count(*d)) return std::nullopt;  // that number goes by its mapped id
  return d;
}

uwb_range_t range_message(const RangeRecord& r, const RangeIds& ids, utime_t utime,
                          const std::string& source) {
  uwb_range_t m;
  m.utime = utime;
  m.source = source;
  m.tag_id = ids.tags.name(r.tag_number);
  m.anchor_id = ids.anchors.name(r.anchor_number);
  m.range_m = static_cast<double>(r.range_mm) * 1e-3;
  m.rx_power_dbm = m.fp_power_dbm = std::numeric_limits<float>::quiet_NaN();
  m.quality = r.quality == kQualityUnknown ? std::numeric_limits<float>::quiet_NaN()
                                           : static_cast<float>(r.quality) / 100.0f;
  m.seq = r.seq;
  return m;
}

RangeRecordResult range_record(const uwb_range_t& m, const RangeIds& ids) {
  RangeRecordResult out;
  const auto tag = ids.tags.number(m.tag_id);
  if (!tag) {
    out.reason = "tag id '" + m.tag_id + "' has no tag number (use --tag-id N=" + m.tag_id + ")";
    return out;
  }
  const auto anchor = ids.anchors.number(m.anchor_id);
  if (!anchor) {
    out.reason = "anchor id '" + m.anchor_id + "' has no anchor number 0.." +
                 std::to_string(ids.anchors.max_number()) + " (use --anchor-id N=" + m.anchor_id +
                 ")";
    return out;
  }
  constexpr double kMaxRangeMm = 4294967295.0;  // u32
  const double mm = std::round(m.range_m * 1e3);
  if (!(mm >= 0 && mm <= kMaxRangeMm)) {
    out.reason = "range " + std::to_string(m.range_m) + " m is outside 0..4294967.295 m";
    return out;
  }
  uint8_t quality = kQualityUnknown;
  if (!std::isnan(m.quality)) {
    if (!(m.quality >= 0.0f && m.quality <= 1.0f)) {
      out.reason = "quality " + std::to_string(m.quality) + " is outside 0..1";
      return out;
    }
    quality = static_cast<uint8_t>(std::lround(m.quality * 100.0f));
  }
  out.record.tag_number = static_cast<uint16_t>(*tag);
  out.record.anchor_number = static_cast<uint16_t>(*anchor);
  out.record.range_mm = static_cast<uint32_t>(mm);
  out.record.quality = quality;
  out.record.seq = static_cast<uint8_t>(static_cast<uint32_t>(m.seq) & 0xFFu);
  out.ok = true;
  return out;
}

}  // namespace ips::uwb_can
