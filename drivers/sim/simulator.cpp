#include "drivers/sim/simulator.hpp"

#include <ips/site_t.hpp>

namespace ips::sim {

namespace {
// SITE at the start and every site_period_s, so that every log is self-contained.
class SiteSource : public PeriodicSource {
 public:
  SiteSource(const Site& site, double period_s)
      : PeriodicSource(period_us(1.0 / period_s), 0), site_(site) {}

 protected:
  bool emit(utime_t t, double, SimEvent& ev) override {
    encode_event(site_to_msg(site_, t, kSimSource), t, "SITE", ev);
    return true;
  }

 private:
  const Site& site_;
};
}  // namespace

Simulator::Simulator(Scenario scenario, uint64_t seed, utime_t start_utime)
    : sc_(std::move(scenario)), start_(start_utime), end_(start_utime + s_to_utime(sc_.duration_s)) {
  sources_.push_back(std::make_unique<SiteSource>(sc_.site, sc_.site_period_s));
  const SimWorld world{sc_.site, sc_.trajectories, seed};
  for (const auto& s : sc_.sensors)
    for (auto& src : s.model->make(s.section, world)) sources_.push_back(std::move(src));
  for (size_t i = 0; i < sources_.size(); ++i)
    if (sources_[i]->next_us() != SensorSource::kNoMoreEvents) queue_.push({sources_[i]->next_us(), i});
}

bool Simulator::next(SimEvent& ev) {
  // The earliest source; on equal times the one added first (SITE, then the registry order).
  while (!queue_.empty()) {
    const auto [due_us, i] = queue_.top();
    if (start_ + due_us > end_) return false;
    queue_.pop();
    SensorSource& src = *sources_[i];
    const bool produced = src.fire(start_, ev);
    if (src.next_us() != SensorSource::kNoMoreEvents) queue_.push({src.next_us(), i});
    if (produced) return true;
  }
  return false;
}

}  // namespace ips::sim
