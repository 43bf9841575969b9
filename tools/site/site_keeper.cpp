#include "tools/site/site_keeper.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <exception>
#include <set>
#include <spdlog/fmt/fmt.h>
#include <vector>

#include "estimators/altitude/altitude_estimator.hpp"
#include "estimators/aoa/aoa_estimator.hpp"
#include "estimators/ins/ins_estimator.hpp"
#include "estimators/pdr/pdr_estimator.hpp"
#include "estimators/uwb_tdoa/tdoa_estimator.hpp"
#include "estimators/uwb_twr/twr_estimator.hpp"
#include "fusion/fuse_estimator.hpp"

namespace ips::site_tool {

SiteKeeper::SiteKeeper(std::string origin) : origin_(std::move(origin)) {}

SiteOutcome SiteKeeper::reject(std::string error) {
  ++rejected_;
  error_ = std::move(error);
  return {SiteOutcome::Kind::kRejected, false, error_};
}

SiteOutcome SiteKeeper::offer_read_error(const std::string& error) { return reject(error); }

SiteOutcome SiteKeeper::offer_text(const std::string& text) {
  if (text.size() > kMaxSiteFileBytes)
    return reject(fmt::format("{}: {} bytes; a site file may have at most {}", origin_,
                              text.size(), kMaxSiteFileBytes));
  const bool was_rejected = !error_.empty();
  Site site;
  try {
    // The floor plans it names are read again too (relative to the file): a new image is a
    // change even when the text is not.
    site = load_site_text(text, origin_);
    check_estimator_sections(site);
  } catch (const ConfigError& e) {
    return reject(e.what());
  } catch (const std::exception& e) {
    // Not expected from the loader or the estimators' checks; never let it end the process.
    return reject(origin_ + ": " + e.what());
  }
  error_.clear();
  if (site_ && site.yaml_text == site_->yaml_text)
    return {SiteOutcome::Kind::kUnchanged, was_rejected, ""};
  if (!site_) {
    site_ = std::move(site);
    return {SiteOutcome::Kind::kFirst, was_rejected, ""};
  }
  std::string change = describe_site_change(*site_, site);
  site_ = std::move(site);
  ++replaced_;
  return {SiteOutcome::Kind::kReplaced, was_rejected, std::move(change)};
}

namespace {

// "moved 0.10 m to [10.1, 0, 2.4]"
std::string moved_text(const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  return fmt::format("moved {:.2f} m to [{:g}, {:g}, {:g}]", (to - from).norm(), to.x(), to.y(),
                     to.z());
}

// Both NaN counts as equal (an unset height or start).
bool same(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }
bool same(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return same(a.x(), b.x()) && same(a.y(), b.y()) && same(a.z(), b.z());
}

// Added, removed and changed items of two lists with ids; `changes(before, after)` lists what
// differs in one item kept.
template <class Item, class Changes>
void compare_by_id(const char* what, const std::vector<Item>& before,
                   const std::vector<Item>& after, Changes changes,
                   std::vector<std::string>& out) {
  auto find = [](const std::vector<Item>& items, const std::string& id) -> const Item* {
    for (const auto& i : items)
      if (i.id == id) return &i;
    return nullptr;
  };
  for (const auto& b : before) {
    const Item* a = find(after, b.id);
    if (!a) {
      out.push_back(fmt::format("{} {} removed", what, b.id));
      continue;
    }
    for (const auto& c : changes(b, *a)) out.push_back(fmt::format("{} {} {}", what, b.id, c));
  }
  for (const auto& a : after)
    if (!find(before, a.id)) out.push_back(fmt::format("{} {} added", what, a.id));
}

std::string yaml_text(const YAML::Node& node) {
  YAML::Emitter out;
  out << node;
  return out.c_str();
}

std::set<std::string> map_keys(const YAML::Node& node) {
  std::set<std::string> keys;
  if (node.IsMap())
    for (const auto& kv : node) keys.insert(kv.first.IsScalar() ? kv.first.Scalar() : "?");
  return keys;
}

}  // namespace

std::string describe_site_change(const Site& before, const Site& after) {
  std::vector<std::string> out;
  if (before.name != after.name) out.push_back(fmt::format("name {} -> {}", before.name, after.name));
  compare_by_id("anchor", before.anchors, after.anchors,
                [](const Anchor& b, const Anchor& a) {
                  std::vector<std::string> c;
                  if (!same(b.position, a.position))
                    c.push_back(moved_text(b.position, a.position));
                  if (b.kind != a.kind) c.push_back(fmt::format("kind {} -> {}", b.kind, a.kind));
                  if (!same(b.orientation_rad, a.orientation_rad)) c.push_back("turned");
                  if (b.enabled != a.enabled) c.push_back(a.enabled ? "enabled" : "disabled");
                  return c;
                },
                out);
  compare_by_id("baro station", before.baro_stations, after.baro_stations,
                [](const BaroStation& b, const BaroStation& a) {
                  std::vector<std::string> c;
                  if (!same(b.position, a.position))
                    c.push_back(moved_text(b.position, a.position));
                  return c;
                },
                out);
  compare_by_id("tag", before.tags, after.tags,
                [](const Tag& b, const Tag& a) {
                  std::vector<std::string> c;
                  if (!same(b.height_m, a.height_m))
                    c.push_back(fmt::format("height_m {:g} -> {:g}", b.height_m, a.height_m));
                  if (!same(b.start_position, a.start_position) ||
                      !same(b.start_heading_rad, a.start_heading_rad))
                    c.push_back("start changed");
                  return c;
                },
                out);
  const YAML::Node& eb = before.estimators.node();
  const YAML::Node& ea = after.estimators.node();
  std::set<std::string> sections = map_keys(eb);
  sections.merge(map_keys(ea));
  for (const auto& s : sections) {
    const bool in_b = eb.IsMap() && eb[s].IsDefined();
    const bool in_a = ea.IsMap() && ea[s].IsDefined();
    if (in_b && in_a && yaml_text(eb[s]) == yaml_text(ea[s])) continue;
    out.push_back(fmt::format("estimators.{} {}", s,
                              !in_b ? "added" : !in_a ? "removed" : "changed"));
  }
  if (out.empty()) return "comments or layout only";
  std::string text;
  for (const auto& o : out) text += (text.empty() ? "" : "; ") + o;
  return text;
}

void check_estimator_sections(const Site& site) {
  // The estimators themselves, fresh, with sinks that are never called: set_site() is exactly
  // the check each runs when it takes a site, and throws ConfigError on the first failure.
  uwb_twr::TwrEstimator([](const pose_t&) {}).set_site(site);
  uwb_tdoa::TdoaEstimator([](const pose_t&) {}, [](const ips::clock_t&) {}).set_site(site);
  aoa::AoaEstimator([](const pose_t&) {}).set_site(site);
  pdr::PdrEstimator([](const step_t&) {}, [](const pose_t&) {}).set_site(site);
  ins::InsEstimator([](const pose_t&) {}).set_site(site);
  altitude::AltitudeEstimator([](const altitude_t&) {}).set_site(site);
  fusion::FuseEstimator([](const pose_t&) {}).set_site(site);
}

}  // namespace ips::site_tool
