#pragma once
// Per-sensor pressure offsets from a co-located capture (../shared/reference/003_baro.md section
// 2.4): the tag barometers sit beside a reference station for a while; the first minutes, while
// the sensors settle thermally, are discarded (003: 3 of 12 min), and each sensor's offset is the
// mean of its readings minus the reference's (5.1), here paired in time (the reference
// interpolated at each reading's time, so a weather change during the capture cancels). A sensor
// that was not beside the reference can be given the height it stood at: the hypsometric
// pressure difference to the reference is then expected and not counted as offset.
// ips-altitude subtracts the offsets (5.2); the reference is left as it is (5.3). Pure.
#include <ips/baro_t.hpp>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "core/time.hpp"

namespace ips::altitude {

class OffsetCalibrationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct OffsetCalibrationOptions {
  std::string reference;    // station id; empty: the log's only reference station
  double settle_s = 180.0;  // 003: the first 3 minutes discarded
  double span_s = 0.0;      // use this long after settling; 0: to the end (003: 9 min)
  std::map<std::string, double> heights_m;  // sensors not beside the reference: their height
  // The site's offsets: the reference's own, if it has one, is applied (the others are fitted
  // afresh on their raw readings).
  std::map<std::string, double> site_offsets_pa;
  double humidity_pct = 50.0;        // as ips-altitude, for a height difference
  double temperature_c = 20.0;
  double gravity_mps2 = 9.81;
  double max_pair_gap_s = 1.0;  // a reading further from the reference's readings is not paired
};

struct SensorOffset {
  std::string sensor_id;
  int64_t readings = 0;        // all of the sensor's readings
  int64_t used = 0;            // paired, in the window
  double window_start_s = 0;   // after the first reading of the capture
  double window_end_s = 0;
  double offset_pa = 0;        // subtract from the sensor's readings
  double offset_height_m = 0;  // what the offset would do to a height, m (negative: reads low)
  double sigma_pa = 0;         // standard deviation of the paired differences
  double drift_pa_per_min = 0; // their slope over the window: large when still settling
  double expected_difference_pa = 0;  // from heights_m (0 when beside the reference)
};

class OffsetCalibration {
 public:
  explicit OffsetCalibration(OffsetCalibrationOptions options);
  // Readings as recorded (no offsets applied). Invalid or out-of-order readings are counted.
  void on_baro(const baro_t& m);
  // The site gives the station heights when readings lack known_height_m.
  void set_site(const Site& site) { site_ = site; }
  // Throws OffsetCalibrationError: no reference, several and none chosen, a chosen one not heard.
  // Sensors with no reading in the window come back with used = 0.
  std::vector<SensorOffset> finish() const;
  int64_t dropped() const { return dropped_; }
  const std::string& reference_id() const { return chosen_reference_; }

 private:
  struct Reading {
    utime_t utime;
    double pressure_pa;
    double temperature_c;
    double humidity_pct;
  };
  struct Series {
    bool is_reference = false;
    double known_height_m = 0;  // NaN unless a reference reported it
    std::vector<Reading> readings;
  };
  OffsetCalibrationOptions opt_;
  std::optional<Site> site_;
  std::map<std::string, Series> sensors_;
  int64_t dropped_ = 0;
  mutable std::string chosen_reference_;
};

// The site's YAML with estimators.altitude.offsets_pa set for every sensor with used > 0.
// Throws ConfigError when the site's YAML cannot be edited.
std::string site_with_offsets(const Site& site, const std::vector<SensorOffset>& offsets,
                              const std::vector<std::string>& header);

}  // namespace ips::altitude
