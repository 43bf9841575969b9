#pragma once
// One Linux IIO barometer read through sysfs (/sys/bus/iio/devices/iio:deviceN: BMP280,
// BMP388/390, BME280, LPS22, DPS310, ...), and finding one by its `name`. The attributes and their
// units are the IIO ABI's (drivers/baro/sysfs_value.hpp): pressure in kPa, temperature in milli
// degC, relative humidity in milli percent, each from <channel>_input or from <channel>_raw,
// _scale and optional _offset. Pressure is required; temperature and humidity are read when the
// device has them.
//
// Every read opens, preads and closes the attribute files (a few small reads per sample), so a
// device that goes away shows at once: its directory is gone (ENOENT) or the kernel says the
// device was removed (ENODEV). Reads block for the I2C/SPI transfer, about a millisecond.
#include <string>
#include <vector>

#include "drivers/baro/baro_reading.hpp"

namespace ips::baro {

inline constexpr const char* kDefaultSysfsRoot = "/sys/bus/iio/devices";

struct IioDeviceEntry {
  std::string dir;   // ROOT/iio:deviceN
  std::string name;  // the contents of its `name` file (empty when unreadable)
};

// The iio:deviceN directories under `root` with their names, in order of N. False with the reason
// when `root` cannot be read.
bool list_iio_devices(const std::string& root, std::vector<IioDeviceEntry>& out,
                      std::string& error);

struct IioLookup {
  enum class Kind { kFound, kNotFound, kAmbiguous };
  Kind kind = Kind::kNotFound;
  std::string dir;     // kFound
  std::string reason;  // otherwise: lists the names found, or the devices that share the name
};
// The one device under `root` whose `name` is `name`.
IioLookup find_iio_device_by_name(const std::string& root, const std::string& name);

class IioDevice {
 public:
  enum class OpenStatus { kOpen, kMissing, kNotBarometer };
  // Looks at `dir`: its name and which attributes carry each channel. kMissing when there is no
  // such directory; kNotBarometer when it has no pressure channel.
  OpenStatus open(const std::string& dir, std::string& error);
  void close() { open_ = false; }
  bool is_open() const { return open_; }

  enum class ReadStatus { kOk, kBad, kGone };
  // One sample, in Pa, degC and %: kBad with the reason for a failed read or a value that is not
  // a number (the device stays); kGone when the device went away (ENOENT, ENODEV, ENXIO).
  // Values are not range-checked here (reading_problem).
  ReadStatus read(BaroReading& out, std::string& reason) const;

  // Writes `ratio` to in_pressure_oversampling_ratio. False with the reason: the attribute is
  // missing (the kernel driver has none), or the kernel refused the value (with the values
  // in_pressure_oversampling_ratio_available lists).
  bool set_pressure_oversampling(int ratio, std::string& error) const;

  const std::string& dir() const { return dir_; }
  const std::string& real_dir() const { return real_dir_; }  // symbolic links resolved
  const std::string& name() const { return name_; }
  bool has_temperature() const { return temperature_.present; }
  bool has_humidity() const { return humidity_.present; }
  bool pressure_from_raw() const { return pressure_.raw; }

 private:
  struct Channel {
    const char* prefix;  // "in_pressure"
    bool milli;          // milli degC, milli percent: / 1000; else kPa: * 1000
    bool present = false;
    bool raw = false;  // _raw and _scale, else _input
    bool offset = false;
  };
  void find_channel(Channel& c) const;
  ReadStatus read_channel(const Channel& c, double& value, std::string& reason) const;
  bool exists(const std::string& attribute) const;

  bool open_ = false;
  std::string dir_, real_dir_, name_;
  Channel pressure_{"in_pressure", false};
  Channel temperature_{"in_temp", true};
  Channel humidity_{"in_humidityrelative", true};
};

}  // namespace ips::baro
