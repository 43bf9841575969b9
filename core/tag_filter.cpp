#include "core/tag_filter.hpp"

#include <stdexcept>

namespace ips {

TagFilter::TagFilter(Node& node, const CommonOptions& opts) {
  std::string error;
  auto sel = TagSelector::parse(opts.tags, opts.shard, error);
  // parse_command_line has refused bad values already; a program that skipped it is wrong.
  if (!sel) throw std::invalid_argument(error);
  selector_ = std::move(*sel);
  if (selector_.selects_all()) return;
  node.report_note("tags", note());
  node.add_timer(1.0, [this, &node] { node.report_note("tags", note()); });
}

std::vector<std::string> site_non_tag_ids(const Site& site) {
  std::vector<std::string> ids;
  for (const auto& a : site.anchors) ids.push_back(a.id);
  for (const auto& s : site.baro_stations) ids.push_back(s.id);
  return ids;
}

void TagFilter::set_site(const Site& site) { selector_.set_always_selected(site_non_tag_ids(site)); }

std::string TagFilter::note() const {
  const int64_t tags = selector_.rejected_ids();
  return selector_.describe() + ": " + std::to_string(skipped_) + " messages of " +
         std::to_string(tags) + " other " + (tags == 1 ? "tag" : "tags") + " skipped";
}

}  // namespace ips
