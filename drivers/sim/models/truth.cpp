// Ground truth of every walker on TRUTH: position, velocity and heading from the trajectory.
// On by default (50 Hz) even when a scenario has no `truth:` section.
#include <ips/pose_t.hpp>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

class TruthSource : public PeriodicSource {
 public:
  TruthSource(double rate_hz, const TagTrajectory& walker)
      : PeriodicSource(period_us(rate_hz), 0), walker_(walker) {}

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    const TrajectoryState st = walker_.path.at(t_s);
    pose_t m;
    m.utime = t;
    m.source = "truth";
    m.tag_id = walker_.tag_id;
    for (int k = 0; k < 3; ++k) {
      m.position[k] = st.position[k];
      m.velocity[k] = st.velocity[k];
    }
    for (double& c : m.position_cov) c = 0.0;
    m.heading_rad = st.heading_rad;
    m.num_used = 0;
    m.residual_m = std::numeric_limits<double>::quiet_NaN();
    m.status = pose_t::STATUS_OK;
    encode_event(m, t, "TRUTH", ev);
    return true;
  }

 private:
  const TagTrajectory& walker_;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "rate_hz"});
  const double rate = param_in_range(f, "rate_hz", 50.0, 0.01, 1000);
  SourceList out;
  for (const auto& w : world.walkers) out.push_back(std::make_unique<TruthSource>(rate, w));
  return out;
}

}  // namespace

SensorModel truth_sensor_model() { return {"truth", &make}; }

}  // namespace ips::sim
