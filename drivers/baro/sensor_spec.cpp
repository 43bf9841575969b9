#include "drivers/baro/sensor_spec.hpp"

#include <cmath>
#include <set>

#include "core/device_text.hpp"
#include "core/text_escape.hpp"
#include "drivers/baro/baro_reading.hpp"

namespace ips::baro {

namespace {

constexpr size_t kMaxIdLength = 32;

bool split_id(std::string_view text, std::string_view& id, std::string_view& rest, const char* form,
              std::string& reason) {
  const size_t eq = text.find('=');
  id = text.substr(0, eq);
  rest = eq == std::string_view::npos ? std::string_view() : text.substr(eq + 1);
  if (!valid_sensor_id(id)) {
    reason = "'" + printable(text) + "' is not " + form + " (ID: 1 to 32 of A-Za-z0-9_.:-)";
    return false;
  }
  return true;
}

std::string height_text(double h) { return format_number(h) + " m"; }

}  // namespace

bool valid_sensor_id(std::string_view id) { return valid_device_id(id, kMaxIdLength); }

bool parse_iio_spec(std::string_view text, SensorSpec& out, std::string& reason) {
  std::string_view id, target;
  if (!split_id(text, id, target, "ID=NAME or ID=PATH", reason)) return false;
  if (target.empty() || !printable_ascii(target)) {
    reason = "'" + printable(text) + "' is not ID=NAME or ID=PATH (e.g. T1=bmp280 or " +
             "B1=/sys/bus/iio/devices/iio:device1)";
    return false;
  }
  out.id = std::string(id);
  out.target = std::string(target);
  const bool device_entry = target.substr(0, 10) == "iio:device";
  out.kind = target.find('/') != std::string_view::npos || device_entry
                 ? SensorSpec::Kind::kIioByPath
                 : SensorSpec::Kind::kIioByName;
  return true;
}

bool parse_serial_spec(std::string_view text, SensorSpec& out, std::string& reason) {
  std::string_view id, path;
  if (!split_id(text, id, path, "ID=PATH", reason)) return false;
  if (path.empty()) {
    reason = "'" + printable(text) + "' is not ID=PATH (e.g. T2=/dev/ttyUSB0)";
    return false;
  }
  out.kind = SensorSpec::Kind::kSerial;
  out.id = std::string(id);
  out.target = std::string(path);
  return true;
}

bool parse_reference_spec(std::string_view text, ReferenceSpec& out, std::string& reason) {
  std::string_view id, height;
  if (!split_id(text, id, height, "ID or ID=HEIGHT_M", reason)) return false;
  out.id = std::string(id);
  out.height_m.reset();
  if (text.find('=') == std::string_view::npos) return true;
  double h = 0;
  if (!parse_decimal(height, h) || std::fabs(h) > kMaxReferenceHeightM) {
    reason = "'" + printable(text) +
             "': the height is not a number of metres within +-10000 (e.g. B1=2.4)";
    return false;
  }
  out.height_m = h;
  return true;
}

bool check_sensors(const std::vector<SensorSpec>& sensors, std::string& reason) {
  std::set<std::string> ids, serial_paths;
  for (const SensorSpec& s : sensors) {
    if (!ids.insert(s.id).second) {
      reason = "sensor id " + s.id + " is given twice";
      return false;
    }
    if (s.kind == SensorSpec::Kind::kSerial && !serial_paths.insert(s.target).second) {
      reason = "--serial " + printable(s.target) + " is given twice";
      return false;
    }
  }
  return true;
}

bool reference_heights(const std::vector<ReferenceSpec>& references,
                       const std::vector<SensorSpec>& sensors, const Site* site,
                       std::map<std::string, double>& heights, std::vector<std::string>& warnings,
                       std::string& reason) {
  heights.clear();
  auto station = [&](const std::string& id) -> const BaroStation* {
    if (!site) return nullptr;
    for (const BaroStation& s : site->baro_stations)
      if (s.id == id) return &s;
    return nullptr;
  };
  for (const ReferenceSpec& r : references) {
    bool known = false;
    for (const SensorSpec& s : sensors) known = known || s.id == r.id;
    if (!known) {
      reason = "--reference " + r.id + ": no sensor " + r.id + " (give it with --iio, --serial or a --file column)";
      return false;
    }
    if (heights.count(r.id)) {
      reason = "--reference " + r.id + " is given twice";
      return false;
    }
    const BaroStation* st = station(r.id);
    if (r.height_m) {
      heights[r.id] = *r.height_m;
      if (st && std::fabs(st->position.z() - *r.height_m) > 1e-6)
        warnings.push_back("--reference " + r.id + ": height " + height_text(*r.height_m) +
                           " from the command line, not the site's " +
                           height_text(st->position.z()));
      continue;
    }
    if (st) {
      heights[r.id] = st->position.z();
      continue;
    }
    if (!site) {
      reason = "--reference " + r.id + ": no height: give " + r.id +
               "=HEIGHT_M, or --site with a baro_stations entry " + r.id;
    } else {
      std::string ids;
      for (const BaroStation& s : site->baro_stations) ids += (ids.empty() ? "" : ", ") + s.id;
      reason = "--reference " + r.id + ": no height: the site " + printable(site->origin) +
               " has no baro_stations entry " + r.id + " (" +
               (ids.empty() ? std::string("it has none") : "it has " + ids) + "); or give " + r.id +
               "=HEIGHT_M";
    }
    return false;
  }
  if (site)
    for (const SensorSpec& s : sensors)
      if (station(s.id) && !heights.count(s.id))
        warnings.push_back("sensor " + s.id +
                           " is a baro_stations entry of the site but not a --reference: it is "
                           "published as a tag barometer");
  return true;
}

}  // namespace ips::baro
