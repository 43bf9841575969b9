#include "estimators/aoa/aoa_calibration.hpp"

#include <spdlog/fmt/fmt.h>

#include <cmath>

namespace ips::aoa {

bool AngleCorrection::is_identity() const {
  return coefficients == std::array<double, 4>{0.0, 1.0, 0.0, 0.0};
}

double AngleCorrection::evaluate(double t) const {
  const auto& c = coefficients;
  return c[0] + t * (c[1] + t * (c[2] + t * c[3]));
}

double AngleCorrection::derivative(double t) const {
  const auto& c = coefficients;
  return c[1] + t * (2.0 * c[2] + t * 3.0 * c[3]);
}

std::optional<double> AngleCorrection::apply(double measured_deg) const {
  if (!std::isfinite(measured_deg)) return std::nullopt;
  if (measured_deg >= valid_min_deg && measured_deg <= valid_max_deg)
    return evaluate(measured_deg);
  if (beyond == Beyond::kReject) return std::nullopt;
  const double edge = measured_deg < valid_min_deg ? valid_min_deg : valid_max_deg;
  return evaluate(edge) + derivative(edge) * (measured_deg - edge);
}

AngleCorrection parse_angle_correction(const YamlField& f) {
  if (!f.is_map()) f.fail("expected a map {polynomial: [c0, c1, ...], valid_deg: [min, max]}");
  f.check_keys({"polynomial", "valid_deg", "beyond"});
  AngleCorrection c;
  const YamlField poly = f.required("polynomial");
  if (!poly.is_sequence() || poly.size() < 1 || poly.size() > 4)
    poly.fail("expected 1 to 4 coefficients [c0, c1, c2, c3] of the measured angle in degrees");
  c.coefficients = {0.0, 0.0, 0.0, 0.0};
  for (size_t i = 0; i < poly.size(); ++i) {
    c.coefficients[i] = poly[i].as_double();
    if (!std::isfinite(c.coefficients[i])) poly[i].fail("must be finite");
  }
  if (f["valid_deg"].defined()) {
    const Eigen::Vector2d v = f["valid_deg"].as_vec2();
    if (!(v.x() < v.y()) || v.x() < -90 || v.y() > 90)
      f["valid_deg"].fail("expected [min, max] with -90 <= min < max <= 90");
    c.valid_min_deg = v.x();
    c.valid_max_deg = v.y();
  }
  const std::string beyond = f.get_string("beyond", "extend");
  if (beyond == "extend") c.beyond = AngleCorrection::Beyond::kExtend;
  else if (beyond == "reject") c.beyond = AngleCorrection::Beyond::kReject;
  else f["beyond"].fail("expected extend or reject, got '" + beyond + "'");
  return c;
}

std::map<std::string, AnchorCalibration> parse_calibration(const YamlField& section) {
  std::map<std::string, AnchorCalibration> out;
  if (!section.defined()) return out;
  if (!section.is_map()) section.fail("expected a map of anchor id: {azimuth: ..., elevation: ...}");
  for (const auto& kv : section.node()) {
    const std::string id = kv.first.IsScalar() ? kv.first.Scalar() : "?";
    const YamlField entry = section[id];
    if (!entry.is_map()) entry.fail("expected {azimuth: ..., elevation: ...}");
    entry.check_keys({"azimuth", "elevation"});
    AnchorCalibration cal;
    if (entry["azimuth"].defined()) cal.azimuth = parse_angle_correction(entry["azimuth"]);
    if (entry["elevation"].defined()) cal.elevation = parse_angle_correction(entry["elevation"]);
    out[id] = cal;
  }
  return out;
}

std::string format_angle_correction(const AngleCorrection& c) {
  size_t n = 4;
  while (n > 1 && c.coefficients[n - 1] == 0.0) --n;
  std::string poly;
  for (size_t i = 0; i < n; ++i)
    poly += fmt::format("{}{:.9g}", i ? ", " : "", c.coefficients[i]);
  std::string out = "{polynomial: [" + poly + "]";
  if (c.valid_min_deg != -90.0 || c.valid_max_deg != 90.0)
    out += fmt::format(", valid_deg: [{:.4g}, {:.4g}]", c.valid_min_deg, c.valid_max_deg);
  if (c.beyond == AngleCorrection::Beyond::kReject) out += ", beyond: reject";
  return out + "}";
}

}  // namespace ips::aoa
