#pragma once
// ips-baro's sensors as the command line names them, and the heights of the reference stations:
//   --iio ID=NAME        an IIO device by its `name` file (bmp280, bmp388, lps22hb, ...)
//   --iio ID=PATH        an IIO device by its directory (anything with a '/', or iio:deviceN),
//                        or the directory holding it (/sys/bus/i2c/devices/1-0077)
//   --serial ID=PATH     a serial line sensor (P <Pa> T <degC> [H <%>] lines)
//   --reference ID[=H]   sensor ID is a reference station at height H m above the site origin,
//                        or at the z of the site's baro_stations entry ID
// Pure: checks the text, never touches a device or a file.
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/site.hpp"

namespace ips::baro {

struct SensorSpec {
  enum class Kind { kIioByName, kIioByPath, kSerial, kFile };
  Kind kind = Kind::kIioByName;
  std::string id;
  std::string target;  // the name or the path (kFile: the file, "-" for stdin)
};

// A sensor id: 1 to 32 of A-Za-z0-9_.:- (as the site file's ids).
bool valid_sensor_id(std::string_view id);

// "ID=NAME" or "ID=PATH" (--iio); false with the reason.
bool parse_iio_spec(std::string_view text, SensorSpec& out, std::string& reason);
// "ID=PATH" (--serial); false with the reason.
bool parse_serial_spec(std::string_view text, SensorSpec& out, std::string& reason);

// Heights are taken within +-10 km of the site origin.
inline constexpr double kMaxReferenceHeightM = 10'000.0;

struct ReferenceSpec {
  std::string id;
  std::optional<double> height_m;
};
// "ID" or "ID=HEIGHT_M" (--reference); false with the reason.
bool parse_reference_spec(std::string_view text, ReferenceSpec& out, std::string& reason);

// False with the reason when two sensors share an id or two serial sensors a path.
bool check_sensors(const std::vector<SensorSpec>& sensors, std::string& reason);

// The known height of every reference station, by sensor id: its =H, else the z of the site's
// baro_stations entry with its id (`site` may be null: no --site). False with the reason when a
// reference names no sensor, is given twice, or has no height from either. `warnings` gets a
// line for every =H that differs from the site's z (=H wins) and for every sensor that is a
// site station but not a --reference.
bool reference_heights(const std::vector<ReferenceSpec>& references,
                       const std::vector<SensorSpec>& sensors, const Site* site,
                       std::map<std::string, double>& heights, std::vector<std::string>& warnings,
                       std::string& reason);

}  // namespace ips::baro
