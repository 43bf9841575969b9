#include "core/site_layout.hpp"

#include <algorithm>
#include <cmath>
#include <set>

namespace ips {

namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr size_t kMaxZoneVertices = 1000;
const char* const kPngPrefix = "data:image/png;base64,";
const char* const kSvgPrefix = "data:image/svg+xml;base64,";

Eigen::Vector2d finite_point(const YamlField& f) {
  const Eigen::Vector2d p = f.as_vec2();
  if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e6) f.fail("must be within 1e6 m");
  return p;
}

FloorPlan parse_plan(const YamlField& f, const std::map<std::string, std::string>& images) {
  f.check_keys({"image", "origin", "size_m", "rotation_deg"});
  FloorPlan plan;
  plan.image = f.required("image").as_string();
  if (plan.image.empty()) f["image"].fail("must not be empty");
  if (f["origin"].defined()) plan.origin = finite_point(f["origin"]);
  const YamlField size = f.required("size_m");
  plan.size_m = size.as_vec2();
  if (!(plan.size_m.minCoeff() > 0) || !(plan.size_m.maxCoeff() <= 1e5))
    size.fail("must be two sizes in (0, 1e5] m: the image's width along x and its height");
  plan.rotation_rad = f.get_double_in("rotation_deg", 0.0, -360.0, 360.0) * kDegToRad;
  if (auto it = images.find(plan.image); it != images.end()) plan.data_uri = it->second;
  return plan;
}

ZoneAlerts parse_zone_alerts(const YamlField& f) {
  ZoneAlerts out;
  auto one = [&](const YamlField& e) {
    const std::string s = e.as_string();
    if (s == "enter") out.enter = true;
    else if (s == "leave") out.leave = true;
    else if (s == "dwell") out.dwell = true;
    else e.fail("unknown event '" + s + "' (enter, leave, dwell)");
  };
  if (f.is_sequence()) {
    for (size_t i = 0; i < f.size(); ++i) one(f[i]);
  } else if (f.defined()) {
    one(f);
  }
  return out;
}

double polygon_area(const std::vector<Eigen::Vector2d>& poly) {
  double a = 0;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++)
    a += poly[j].x() * poly[i].y() - poly[i].x() * poly[j].y();
  return 0.5 * std::abs(a);
}

Zone parse_zone(const YamlField& f, const std::vector<Floor>& floors) {
  f.check_keys({"id", "name", "floor", "polygon", "alert", "dwell_s", "hysteresis_m"});
  Zone z;
  z.id = f.required("id").as_string();
  if (z.id.empty()) f["id"].fail("must not be empty");
  z.name = f.get_string("name", z.id);
  if (f["floor"].defined()) {
    const int64_t fl = f["floor"].as_int();
    const bool known = std::any_of(floors.begin(), floors.end(),
                                   [&](const Floor& x) { return x.index == fl; });
    if (!known) {
      std::string have;
      for (const Floor& x : floors) have += (have.empty() ? "" : ", ") + std::to_string(x.index);
      f["floor"].fail("no floor " + std::to_string(fl) + " in `floors` (" +
                      (have.empty() ? "none defined" : "have " + have) + ")");
    }
    z.floor = static_cast<int>(fl);
  }
  const YamlField poly = f.required("polygon");
  if (!poly.is_sequence() || poly.size() < 3 || poly.size() > kMaxZoneVertices)
    poly.fail("expected a list of 3 to 1000 [x, y] vertices");
  for (size_t i = 0; i < poly.size(); ++i) z.polygon.push_back(finite_point(poly[i]));
  if (!(polygon_area(z.polygon) > 1e-4)) poly.fail("encloses no area");
  z.alert = parse_zone_alerts(f["alert"]);
  z.dwell_s = f.get_double_in("dwell_s", 0.0, 0.0, 1e6);
  if (z.alert.dwell && !(z.dwell_s > 0)) f["alert"].fail("a dwell alert needs dwell_s > 0");
  z.hysteresis_m = f.get_double_in("hysteresis_m", 0.3, 0.0, 10.0);
  return z;
}

std::string dirname_of(const std::string& path) {
  const auto slash = path.rfind('/');
  return slash == std::string::npos ? "" : path.substr(0, slash + 1);
}

}  // namespace

const Floor* SiteLayout::find_floor(int index) const {
  for (const auto& f : floors)
    if (f.index == index) return &f;
  return nullptr;
}

const Zone* SiteLayout::find_zone(const std::string& id) const {
  for (const auto& z : zones)
    if (z.id == id) return &z;
  return nullptr;
}

int SiteLayout::floor_of_height(double z) const {
  if (floors.empty()) return kNoFloor;
  int out = floors.front().index;
  for (const auto& f : floors)
    if (f.height_m <= z + 0.5) out = f.index;
  return out;
}

SiteLayout parse_site_layout(const YamlField& root) {
  SiteLayout out;
  const YamlField images = root["plan_images"];
  if (images.defined()) {
    if (!images.is_map()) images.fail("expected a map of image path to data URI");
    for (const auto& kv : images.node()) {
      const std::string key = kv.first.as<std::string>("");
      const YamlField v = images[key];
      const std::string uri = v.as_string();
      if (uri.rfind(kPngPrefix, 0) != 0 && uri.rfind(kSvgPrefix, 0) != 0)
        v.fail("expected a data:image/png;base64 or data:image/svg+xml;base64 URI");
      if (uri.size() > kMaxPlanImageBytes / 3 * 4 + 64) v.fail("image larger than 2 MiB");
      out.plan_images[key] = uri;
    }
  }

  const YamlField floors = root["floors"];
  if (floors.defined() && !floors.is_sequence()) floors.fail("expected a list of floors");
  std::set<int64_t> indices;
  for (size_t i = 0; i < floors.size(); ++i) {
    const YamlField f = floors[i];
    f.check_keys({"index", "name", "height_m", "plan"});
    Floor fl;
    const int64_t index = f.required("index").as_int();
    if (index < -20 || index > 500) f["index"].fail("must be in [-20, 500]");
    if (!indices.insert(index).second) f["index"].fail("duplicate floor " + std::to_string(index));
    fl.index = static_cast<int>(index);
    fl.name = f.get_string("name", "floor " + std::to_string(index));
    fl.height_m = f.required("height_m").as_double();
    if (!(std::abs(fl.height_m) <= 1e4)) f["height_m"].fail("must be within 1e4 m");
    if (f["plan"].defined()) fl.plan = parse_plan(f["plan"], out.plan_images);
    out.floors.push_back(fl);
  }
  std::stable_sort(out.floors.begin(), out.floors.end(),
                   [](const Floor& a, const Floor& b) { return a.height_m < b.height_m; });
  for (size_t i = 1; i < out.floors.size(); ++i) {
    if (out.floors[i].index <= out.floors[i - 1].index)
      floors.fail("floor indices must rise with height_m (floor " +
                  std::to_string(out.floors[i].index) + " is above floor " +
                  std::to_string(out.floors[i - 1].index) + ")");
  }

  const YamlField zones = root["zones"];
  if (zones.defined() && !zones.is_sequence()) zones.fail("expected a list of zones");
  std::set<std::string> ids;
  for (size_t i = 0; i < zones.size(); ++i) {
    Zone z = parse_zone(zones[i], out.floors);
    if (!ids.insert(z.id).second) zones[i]["id"].fail("duplicate zone id '" + z.id + "'");
    out.zones.push_back(std::move(z));
  }

  const YamlField alerts = root["alerts"];
  if (alerts.defined()) {
    if (!alerts.is_map()) alerts.fail("expected a map (tag_silent_s, process_silent_s, ...)");
    alerts.check_keys({"tag_silent_s", "process_silent_s", "process_degraded"});
    out.alerts.tag_silent_s = alerts.get_double_in("tag_silent_s", 10.0, 0.0, 86400.0);
    out.alerts.process_silent_s = alerts.get_double_in("process_silent_s", 5.0, 0.0, 86400.0);
    out.alerts.process_degraded = alerts.get_bool("process_degraded", true);
  }
  return out;
}

std::string embed_plan_images(const YamlField& root, const std::string& site_path) {
  const YamlField floors = root["floors"];
  if (!floors.is_sequence()) return "";
  const YamlField carried = root["plan_images"];
  std::map<std::string, std::string> added;
  for (size_t i = 0; i < floors.size(); ++i) {
    const YamlField image = floors[i]["plan"]["image"];
    if (!image.defined()) continue;
    const std::string path = image.as_string();
    if (path.empty() || added.count(path)) continue;
    if (carried.is_map() && carried.node()[path]) continue;
    if (carried.defined())
      image.fail("'" + path + "' is not in the file's plan_images: add it there, or remove " +
                 "plan_images so that the images are read from their files");
    const std::string full = path.front() == '/' ? path : dirname_of(site_path) + path;
    std::string bytes;
    try {
      bytes = read_text_file(full);
    } catch (const ConfigError& e) {
      image.fail(std::string("floor plan: ") + e.what());
    }
    if (bytes.size() > kMaxPlanImageBytes)
      image.fail("floor plan '" + full + "' is " + std::to_string(bytes.size() / 1024) +
                 " KiB; at most 2048 KiB (every SITE message carries it): scale it down");
    std::string prefix;
    if (bytes.rfind("\x89PNG\r\n\x1a\n", 0) == 0) {
      prefix = kPngPrefix;
    } else if (bytes.substr(0, 4096).find("<svg") != std::string::npos) {
      prefix = kSvgPrefix;
    } else {
      image.fail("floor plan '" + full + "' is neither PNG nor SVG");
    }
    added[path] = prefix + base64_encode(bytes);
  }
  if (added.empty()) return "";
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "plan_images" << YAML::Value << YAML::BeginMap;
  for (const auto& [k, v] : added) out << YAML::Key << k << YAML::Value << v;
  out << YAML::EndMap << YAML::EndMap;
  return std::string("\n# The floor plans, carried in the site (read from their files when it "
                     "was loaded)\n") +
         out.c_str() + "\n";
}

bool polygon_contains(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool in = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d& a = poly[i];
    const Eigen::Vector2d& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

double polygon_boundary_distance(const std::vector<Eigen::Vector2d>& poly,
                                 const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d ab = poly[i] - poly[j];
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - poly[j]).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (poly[j] + t * ab - p).norm());
  }
  return best;
}

std::string base64_encode(const std::string& bytes) {
  static const char* const kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (uint32_t(uint8_t(bytes[i])) << 16) | (uint32_t(uint8_t(bytes[i + 1])) << 8) |
                       uint32_t(uint8_t(bytes[i + 2]));
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < bytes.size()) {
    uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace ips
