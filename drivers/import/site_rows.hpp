#pragma once
// Sites for imported logs: the anchors that range rows carry (their mean positions) as a site
// file, and the times a SITE message goes into a log (at its head and every S s), so a log made
// from files is self-contained. Pure.
#include <cstdint>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "drivers/import/range_rows.hpp"

namespace ips::import {

// A site file (YAML) with the anchors seen (kind uwb, mean positions, in order of first
// appearance) and the tags. When no anchor has a z, the anchors are at z 0 and the tags get
// height_m 0 (a planar site: trackers solve in 2D). Parses back with parse_site_text.
std::string site_yaml_from_anchors(const std::string& name, const std::vector<AnchorSeen>& anchors,
                                   const std::vector<std::string>& tags,
                                   const std::vector<std::string>& header);

// Anchors seen in several files merged: the same id from two files averages by rows.
void merge_anchors(std::vector<AnchorSeen>& into, const std::vector<AnchorSeen>& more);

// first, first + every, ... up to last (every_s > 0). At least {first}.
std::vector<int64_t> site_times(int64_t first_utime, int64_t last_utime, double every_s);

}  // namespace ips::import
