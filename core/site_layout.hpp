#pragma once
// The building in the site file (docs/site-file.md#floors-plans-zones-and-alerts): its floors
// with their plan images, its zones (polygons watched by ips-zones, drawn by ips-view) and the
// alert rules. Parsed by parse_site; the plan images are read when a site file is loaded and
// carried inside the site's YAML (`plan_images:`), so a SITE message and a log hold them too.
#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/yaml_fields.hpp"

namespace ips {

// A floor plan: an image stretched over a rectangle of the site, from `origin` (the image's
// bottom-left corner) along x rotated by `rotation_rad` (CCW from site +x).
struct FloorPlan {
  std::string image;       // the path written in the site file (relative to it)
  std::string data_uri;    // "data:image/png;base64,..." once read (empty: not available)
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  Eigen::Vector2d size_m = Eigen::Vector2d::Zero();  // width (along x), height
  double rotation_rad = 0.0;
};

struct Floor {
  int index = 0;
  std::string name;
  double height_m = 0.0;  // the floor's surface, site z
  std::optional<FloorPlan> plan;
};

// Which of a zone's events are alerts.
struct ZoneAlerts {
  bool enter = false, leave = false, dwell = false;
  bool any() const { return enter || leave || dwell; }
};

struct Zone {
  std::string id;
  std::string name;          // the id when not given
  std::optional<int> floor;  // absent: every floor
  std::vector<Eigen::Vector2d> polygon;  // >= 3 vertices, site x, y
  ZoneAlerts alert;
  double dwell_s = 0.0;       // > 0: a dwell event once a tag has been inside this long
  double hysteresis_m = 0.3;  // in when this far inside, out when this far outside
};

// The rules of the ALERT channel (`alerts:` in the site).
struct AlertRules {
  double tag_silent_s = 10.0;      // a tag with no pose for this long; 0: off
  double process_silent_s = 5.0;   // a process with no HEALTH for this long; 0: off
  bool process_degraded = true;    // a process whose HEALTH is degraded or error
};

struct SiteLayout {
  std::vector<Floor> floors;  // ascending height
  std::vector<Zone> zones;
  AlertRules alerts;
  // image path -> data URI, as carried in the site's YAML (`plan_images:`).
  std::map<std::string, std::string> plan_images;

  const Floor* find_floor(int index) const;
  const Zone* find_zone(const std::string& id) const;
  // The floor a height is on: the highest floor whose surface is at most `z + 0.5` m (a tag is
  // carried above its floor); the lowest floor below all of them. -1000 when there are no floors.
  int floor_of_height(double z) const;
};

inline constexpr int kNoFloor = -1000;
// Largest plan image the site carries (it is repeated in every SITE message).
inline constexpr size_t kMaxPlanImageBytes = 2 * 1024 * 1024;

// Parses `floors`, `zones`, `alerts` and `plan_images` of a site's root map (absent: empty).
SiteLayout parse_site_layout(const YamlField& root);

// Reads the plan images a site file names (relative to `site_path`'s folder) that its
// `plan_images:` does not carry yet, and returns the YAML text to append to the file's text so
// that it carries them ("" when there is nothing to add). Fails with ConfigError naming the file
// and line of the plan (unreadable, not PNG/SVG, larger than kMaxPlanImageBytes).
std::string embed_plan_images(const YamlField& root, const std::string& site_path);

// Point in polygon (even-odd rule) and the distance from a point to the polygon's boundary.
bool polygon_contains(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p);
double polygon_boundary_distance(const std::vector<Eigen::Vector2d>& polygon,
                                 const Eigen::Vector2d& p);

std::string base64_encode(const std::string& bytes);

}  // namespace ips
