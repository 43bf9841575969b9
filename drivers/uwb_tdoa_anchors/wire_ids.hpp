#pragma once
// Names for the 4-hex wire ids of anchors and tags (--id HEX=NAME). Without a name an id is
// published as sent ("0006"); with one (e.g. --id 0006=A6, the site's anchor id) the name is
// published, and --to-records writes the hex id for the name. Hex ids compare case-insensitively.
// Pure: no I/O.
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace ips::uwb_tdoa_anchors {

class WireIds {
 public:
  // Adds "HEX=NAME"; an empty string, or the reason it cannot be added (bad syntax, a hex id or
  // a name given twice).
  std::string add(std::string_view spec);

  // The published id for a wire id: its name, or the id as sent.
  const std::string& name_for(const std::string& wire_id) const;
  // The wire id for a published id: the hex id named so, the id itself when it is 4 hex digits
  // and not a name given to another id, else empty.
  std::string wire_id_for(const std::string& name) const;

  // For --to-records: gives every id among `anchors` and `tags` that has no wire id one, the
  // lowest free 0xxx for an anchor, 1xxx for a tag (SEWIO: leading 0 anchor, 1 tag), in the
  // order given. Returns the "HEX=NAME" added (to pass to the driver as --id), or, in `error`,
  // why it cannot (no free id left).
  std::vector<std::string> assign_missing(const std::set<std::string>& anchors,
                                          const std::set<std::string>& tags, std::string& error);

  bool empty() const { return names_.empty(); }

 private:
  static std::string key(std::string_view hex);  // lower case
  std::map<std::string, std::string> names_;     // key(hex) -> name
  std::map<std::string, std::string> wire_;      // name -> hex as given
};

// 1 to 32 of A-Za-z0-9_.:- (what the other drivers accept as an id).
bool valid_published_id(std::string_view name);

}  // namespace ips::uwb_tdoa_anchors
