#include "drivers/uwb_tdoa_anchors/wire_ids.hpp"

#include <cstdio>

#include "core/text_escape.hpp"
#include "drivers/uwb_tdoa_anchors/anchor_report_parser.hpp"

namespace ips::uwb_tdoa_anchors {

bool valid_published_id(std::string_view name) {
  if (name.empty() || name.size() > 32) return false;
  for (char c : name)
    if (!((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
          c == '.' || c == ':' || c == '-'))
      return false;
  return true;
}

std::string WireIds::key(std::string_view hex) {
  std::string k(hex);
  for (char& c : k)
    if (c >= 'A' && c <= 'F') c = static_cast<char>(c - 'A' + 'a');
  return k;
}

std::string WireIds::add(std::string_view spec) {
  const size_t eq = spec.find('=');
  if (eq == std::string_view::npos) return "expected HEX=NAME, e.g. 0006=A6";
  const std::string_view hex = spec.substr(0, eq), name = spec.substr(eq + 1);
  if (!is_wire_id(hex)) return "'" + printable(hex) + "' is not a 4-hex-digit wire id";
  if (!valid_published_id(name)) return "'" + printable(name) + "' is not 1 to 32 of A-Za-z0-9_.:-";
  const std::string k = key(hex), n(name);
  if (names_.count(k) > 0) return "wire id " + std::string(hex) + " is named twice";
  if (wire_.count(n) > 0) return "name '" + n + "' is given to two wire ids";
  // A name that is another wire id would be published like that id.
  if (is_wire_id(n) && key(n) != k)
    return "name '" + n + "' is itself another wire id; use a name that is not 4 hex digits";
  names_[k] = n;
  wire_[n] = std::string(hex);
  return "";
}

const std::string& WireIds::name_for(const std::string& wire_id) const {
  if (names_.empty()) return wire_id;
  const auto it = names_.find(key(wire_id));
  return it == names_.end() ? wire_id : it->second;
}

std::string WireIds::wire_id_for(const std::string& name) const {
  if (const auto it = wire_.find(name); it != wire_.end()) return it->second;
  // A hex id that was given a name stands for that name only.
  if (is_wire_id(name) && names_.count(key(name)) == 0) return name;
  return "";
}

std::vector<std::string> WireIds::assign_missing(const std::set<std::string>& anchors,
                                                 const std::set<std::string>& tags,
                                                 std::string& error) {
  std::vector<std::string> added;
  std::set<std::string> taken;
  for (const auto& [k, n] : names_) taken.insert(k);
  for (const auto* names : {&anchors, &tags})
    for (const std::string& n : *names)
      if (wire_.count(n) == 0 && is_wire_id(n)) taken.insert(key(n));
  unsigned next_anchor = 0x0001, next_tag = 0x1001;  // lowest not yet tried
  auto assign = [&](const std::string& name, unsigned& next) {
    if (!wire_id_for(name).empty()) return true;
    const unsigned last = (next & 0xf000u) | 0xfffu;
    for (; next <= last; ++next) {
      const unsigned v = next;
      char hex[8];
      std::snprintf(hex, sizeof hex, "%04x", v);
      if (taken.count(hex) > 0) continue;
      taken.insert(hex);
      const std::string spec = std::string(hex) + "=" + name;
      if (const std::string why = add(spec); !why.empty()) {
        error = why;
        return false;
      }
      added.push_back(spec);
      return true;
    }
    error = "no free wire id for '" + printable(name) + "'";
    return false;
  };
  for (const std::string& a : anchors)
    if (!assign(a, next_anchor)) return added;
  for (const std::string& t : tags)
    if (anchors.count(t) == 0 && !assign(t, next_tag)) return added;
  return added;
}

}  // namespace ips::uwb_tdoa_anchors
