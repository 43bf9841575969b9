#pragma once
// One barometer of ips-baro on Linux IIO, as the user named it (--iio ID=NAME or ID=PATH): finds
// its device, reads a checked sample on each poll, notices when the device goes away (sensor
// unbound, module unloaded, the I2C adapter removed) and finds it again when it returns, by
// re-scanning the tree for its name (the device number may change) or by its path. What to
// report is handed back; the caller owns the clock, the counters and the bus.
#include <string>

#include "drivers/baro/baro_reading.hpp"
#include "drivers/baro/iio_device.hpp"

namespace ips::baro {

struct IioSensorConfig {
  std::string id;                        // sensor_id
  std::string root = kDefaultSysfsRoot;  // where iio:deviceN are
  std::string name;                      // chosen by its `name` file, or
  std::string path;                      // by path: ROOT/iio:deviceN ("iio:deviceN" alone:
                                         // under root), or a directory holding exactly one
                                         // iio:deviceN (/sys/bus/i2c/devices/1-0077)
  int oversampling = 0;                  // in_pressure_oversampling_ratio at every open; 0: as is
  double reopen_s = 1.0;                 // retry period while the device is away, s
};

class IioSensor {
 public:
  explicit IioSensor(IioSensorConfig config);

  // Finds and opens the device, and sets the oversampling. False with the reason when the device
  // cannot be used (not found, its name ambiguous, not a barometer, oversampling refused): at
  // start-up that is the user's mistake, not a device that went away.
  bool start(std::string& error);

  struct Poll {
    enum class Kind {
      kNothing,  // waiting for the next retry, or a retry failed for the reason reported before
      kSample,   // `reading` is a checked sample
      kBad,      // a failed read or a value that is not plausible: `text` (the device stays)
      kGone,     // the device went away: `text`
      kMissing,  // a retry failed for a new reason: `text`
    };
    Kind kind = Kind::kNothing;
    BaroReading reading;
    std::string text;
    bool reopened = false;       // this poll found the device again
    std::string reopen_problem;  // ... but could not set its oversampling
  };
  // Reads one sample, or retries the device at most every reopen_s (`now_s`: monotonic seconds).
  Poll poll(double now_s);

  bool present() const { return device_.is_open(); }
  const IioSensorConfig& config() const { return config_; }
  const IioDevice& device() const { return device_; }
  // "name 'bmp280'" or "path /sys/bus/iio/devices/iio:device1"
  std::string selector() const;

 private:
  // Finds and opens the device; `not_found` when it is simply not there.
  bool open_device(std::string& error, bool& not_found);

  IioSensorConfig config_;
  IioDevice device_;
  double next_retry_s_ = 0;
  bool quiet_retry_ = false;  // just gone: "not there" on the first retry was said already
  std::string last_retry_error_;
};

}  // namespace ips::baro
