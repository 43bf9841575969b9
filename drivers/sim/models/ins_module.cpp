// Positions computed on board by a foot-mounted INS module (pose_t on INS_MODULE), as the
// source thesis simulates them (../shared/reference/001_hybrid_uwb_ins.md, chapter 4, eq. 4.1):
// the walked path is cut into steps; every step vector is rotated by the accumulated heading
// error (an initial error, then a random walk of N(gamma, sigma) per step) and stretched by a
// length error N(0, sigma_len) per step, integrated from the start point. Defaults: Tab. 4.1
// (-0.27 rad initial error, 0.007 +- 0.003 rad per step, 0.01 m per step), output at 2 Hz.
#include <cmath>
#include <ips/pose_t.hpp>

#include "drivers/sim/sensor_model.hpp"

namespace ips::sim {

namespace {

struct InsModuleParams {
  double rate_hz = 2.0;
  double step_length_m = 0.7;              // the thesis does not give one; a typical stride/2
  double initial_heading_error_rad = -0.27;  // Tab. 4.1 (0.27 rad), sign as in section 4 ("true -0.27 rad")
  double heading_drift_rad_per_step = 0.007;
  double heading_sigma_rad_per_step = 0.003;
  double length_sigma_m_per_step = 0.01;
  double internal_rate_hz = 50.0;  // integration steps between outputs
};

class InsModuleSource : public PeriodicSource {
 public:
  InsModuleSource(const InsModuleParams& p, const TagTrajectory& walker, std::mt19937_64 rng)
      : PeriodicSource(period_us(p.rate_hz), 0), p_(p), walker_(walker), rng_(std::move(rng)) {
    const TrajectoryState s0 = walker_.path.at(0.0);
    start_ = s0.position;
    ins_ = s0.position;
    last_true_ = s0.position;
    heading_error_ = p_.initial_heading_error_rad;
    next_step_m_ = p_.step_length_m;
    draw_length_scale();
  }

 protected:
  bool emit(utime_t t, double t_s, SimEvent& ev) override {
    // Integrate the true path in small increments up to t_s, applying the current step's errors.
    const double dt = 1.0 / p_.internal_rate_hz;
    while (internal_t_ + dt < t_s) advance_to(internal_t_ + dt);
    advance_to(t_s);
    pose_t m;
    m.utime = t;
    m.source = "ins_module";
    m.tag_id = walker_.tag_id;
    for (int k = 0; k < 3; ++k) m.position[k] = ins_[k];
    for (double& c : m.position_cov) c = std::numeric_limits<double>::quiet_NaN();
    for (double& v : m.velocity) v = std::numeric_limits<double>::quiet_NaN();
    m.heading_rad = std::numeric_limits<double>::quiet_NaN();
    m.num_used = static_cast<int32_t>(steps_);
    m.residual_m = std::numeric_limits<double>::quiet_NaN();
    m.status = pose_t::STATUS_OK;
    encode_event(m, t, "INS_MODULE", ev);
    return true;
  }

 private:
  void draw_length_scale() {
    std::normal_distribution<double> g(0.0, 1.0);
    length_scale_ = 1.0 + p_.length_sigma_m_per_step * g(rng_) / p_.step_length_m;
  }

  void advance_to(double t) {
    const TrajectoryState s = walker_.path.at(t);
    const Eigen::Vector3d d = s.position - last_true_;
    const double c = std::cos(heading_error_), sn = std::sin(heading_error_);
    ins_.x() += length_scale_ * (c * d.x() - sn * d.y());
    ins_.y() += length_scale_ * (sn * d.x() + c * d.y());
    ins_.z() += d.z();
    last_true_ = s.position;
    internal_t_ = t;
    // A new step at every step_length_m walked: its heading increment and length error.
    while (s.distance_m >= next_step_m_) {
      std::normal_distribution<double> g(0.0, 1.0);
      heading_error_ += p_.heading_drift_rad_per_step + p_.heading_sigma_rad_per_step * g(rng_);
      draw_length_scale();
      next_step_m_ += p_.step_length_m;
      ++steps_;
    }
  }

  InsModuleParams p_;
  const TagTrajectory& walker_;
  std::mt19937_64 rng_;
  Eigen::Vector3d start_, ins_, last_true_;
  double heading_error_ = 0;
  double length_scale_ = 1;
  double next_step_m_ = 0;
  double internal_t_ = 0;
  int64_t steps_ = 0;
};

SourceList make(const YamlField& f, const SimWorld& world) {
  f.check_keys({"enabled", "rate_hz", "step_length_m", "initial_heading_error_rad",
                "heading_drift_rad_per_step", "heading_sigma_rad_per_step",
                "length_sigma_m_per_step"});
  InsModuleParams p;
  p.rate_hz = param_in_range(f, "rate_hz", p.rate_hz, 0.1, 100);
  p.step_length_m = param_in_range(f, "step_length_m", p.step_length_m, 0.1, 3);
  p.initial_heading_error_rad =
      param_in_range(f, "initial_heading_error_rad", p.initial_heading_error_rad, -M_PI, M_PI);
  p.heading_drift_rad_per_step =
      param_in_range(f, "heading_drift_rad_per_step", p.heading_drift_rad_per_step, -1, 1);
  p.heading_sigma_rad_per_step =
      param_in_range(f, "heading_sigma_rad_per_step", p.heading_sigma_rad_per_step, 0, 1);
  p.length_sigma_m_per_step =
      param_in_range(f, "length_sigma_m_per_step", p.length_sigma_m_per_step, 0, 1);
  SourceList out;
  for (const auto& w : world.walkers)
    out.push_back(std::make_unique<InsModuleSource>(p, w, stream_rng(world.seed, "INS_MODULE " + w.tag_id)));
  return out;
}

}  // namespace

SensorModel ins_module_sensor_model() { return {"ins_module", &make}; }

}  // namespace ips::sim
