#pragma once
// The simulator's sensor models. Each model is one file, drivers/sim/models/NAME.cpp, that
// defines `SensorModel NAME_sensor_model()`: the key of its section under `sensors:` in a
// scenario file and a function that parses that section and makes the model's sources. The
// build collects every file in models/ into the registry (sensor_models()), so adding a sensor
// is adding a file (the pattern of Crazyflie's kalman_core measurement models).
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/site.hpp"
#include "core/time.hpp"
#include "core/yaml_fields.hpp"
#include "drivers/sim/trajectory.hpp"

namespace ips::sim {

inline constexpr const char* kSimSource = "ips-sim";  // `source` of every simulated message

struct SimEvent {
  utime_t utime = 0;
  std::string kind;           // default channel name, e.g. "UWB_RANGE"
  std::vector<uint8_t> data;  // LCM-encoded message
};

// One walker: a tag carried along a trajectory.
struct TagTrajectory {
  std::string tag_id;
  WaypointTrajectory path;
};

// What a model may look at when it makes its sources.
struct SimWorld {
  const Site& site;
  const std::vector<TagTrajectory>& walkers;
  uint64_t seed;
};

// A stream of simulated messages. The simulator merges all sources in time order.
class SensorSource {
 public:
  virtual ~SensorSource() = default;
  // Offset from the scenario start (us) of the next event; kNoMoreEvents when there is none.
  virtual int64_t next_us() const = 0;
  // Produces the event due at start + next_us() into `ev` (utime and kind set) and advances.
  // Returns false when that event is lost (nothing to publish).
  virtual bool fire(utime_t start, SimEvent& ev) = 0;
  static constexpr int64_t kNoMoreEvents = std::numeric_limits<int64_t>::max();
};
using SourceList = std::vector<std::unique_ptr<SensorSource>>;

// A source whose k-th event is due at phase_us + k * period_us.
class PeriodicSource : public SensorSource {
 public:
  PeriodicSource(int64_t period_us, int64_t phase_us) : period_us_(period_us), phase_us_(phase_us) {}
  int64_t next_us() const override { return phase_us_ + count_ * period_us_; }
  bool fire(utime_t start, SimEvent& ev) override {
    const int64_t offset = next_us();
    ++count_;
    return emit(start + offset, utime_to_s(offset), ev);
  }

 protected:
  // t: the event's utime; t_s: seconds since the scenario start (for trajectories).
  virtual bool emit(utime_t t, double t_s, SimEvent& ev) = 0;

 private:
  int64_t period_us_;
  int64_t phase_us_;
  int64_t count_ = 0;
};

struct SensorModel {
  const char* name;  // key under `sensors:`
  // Parses the section (a map, or null for all defaults; throws ConfigError naming file, line
  // and field) and makes the sources. Called once to validate a scenario and once to simulate.
  SourceList (*make)(const YamlField& section, const SimWorld& world);
};

// Every model in drivers/sim/models/ (generated at build time).
const std::vector<SensorModel>& sensor_models();

// A random stream per source, keyed by the source's name (e.g. "UWB_RANGE T1 A3"), so that
// adding a sensor, a tag or an anchor does not change the noise of the others.
std::mt19937_64 stream_rng(uint64_t seed, const std::string& name);

// The uwb_twr model's constant range offset of one ranging pair (initiator, anchor) when its
// section sets pair_offset_min_m / pair_offset_max_m: uniform in [min, max], from its own stream
// ("UWB_RANGE_OFFSET T1 A3"), so that the other streams stay as they were (tests compare what an
// estimator learns with it).
double uwb_pair_offset_m(uint64_t seed, const std::string& initiator, const std::string& anchor,
                         double min_m, double max_m);

// The uwb_twr model's antenna delay of one device (a tag or an anchor) when its section sets
// device_delay_min_m / device_delay_max_m: uniform in [min, max], from its own stream
// ("UWB_DEVICE_DELAY A3"). Every range, tag-anchor or anchor-anchor, reads long by the delays of
// both its ends (plus its pair offset).
double uwb_device_delay_m(uint64_t seed, const std::string& device, double min_m, double max_m);

// Event period for a rate; at least 1 us.
int64_t period_us(double rate_hz);

// Reads a number from a model section, checking lo <= value <= hi.
double param_in_range(const YamlField& section, const char* key, double fallback, double lo,
                      double hi);

// Encodes msg into ev and stamps it.
template <class Msg>
void encode_event(const Msg& msg, utime_t t, const char* kind, SimEvent& ev) {
  ev.utime = t;
  ev.kind = kind;
  ev.data.resize(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(ev.data.data(), 0, static_cast<int>(ev.data.size()));
}

}  // namespace ips::sim
