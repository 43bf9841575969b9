#pragma once
// From the numbers on the bus to the ids the rest of the system uses, and back: anchor number
// N publishes as anchor id "<anchor prefix>N" (default "A": anchor 3 is "A3") and tag number N as
// "<tag prefix>N" (default "T"), unless a mapping "N=ID" names it (--anchor-id, --tag-id). The
// reverse (ids in an LCM log to numbers, for --to-candump and firmware tests) accepts exactly the
// names the forward direction produces, so a round trip gives back the same ids. Pure.
#include <cstdint>
#include <ips/uwb_range_t.hpp>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "core/time.hpp"
#include "drivers/uwb_can/can_range_frame.hpp"

namespace ips::uwb_can {

class IdNumbering {
 public:
  // `what` names the kind in messages ("anchor", "tag"); numbers run 0..max_number.
  IdNumbering(std::string what, std::string prefix, uint32_t max_number);

  // Adds a mapping "N=ID" (N decimal). Returns why it is refused, or empty.
  std::string add(std::string_view mapping);
  // Empty, or why the mappings and the prefix together are ambiguous (a mapped id that is also
  // the default name of another number would not round-trip).
  std::string check() const;

  std::string name(uint32_t number) const;
  // The number whose name is `id`; nullopt when no number has that name.
  std::optional<uint32_t> number(std::string_view id) const;
  uint32_t max_number() const { return max_; }
  const std::string& what() const { return what_; }

 private:
  std::optional<uint32_t> default_number(std::string_view id) const;

  std::string what_, prefix_;
  uint32_t max_;
  std::map<uint32_t, std::string> names_;
  std::map<std::string, uint32_t, std::less<>> numbers_;
};

struct RangeIds {
  IdNumbering tags{"tag", "T", 0xFFFF};
  IdNumbering anchors{"anchor", "A", 127};
};

// The message for a decoded range frame (rx/first-path power are not in the frame: NaN).
uwb_range_t range_message(const RangeRecord& record, const RangeIds& ids, utime_t utime,
                          const std::string& source);

struct RangeRecordResult {
  bool ok = false;
  RangeRecord record;
  std::string reason;
};

// The frame contents for a message: ids to numbers, range to whole millimetres (rounded), quality
// 0..1 to percent (NaN: 255), seq modulo 256 (-1, unknown, becomes 255).
RangeRecordResult range_record(const uwb_range_t& msg, const RangeIds& ids);

}  // namespace ips::uwb_can
