#pragma once
// Per-anchor angle calibration of BLE AoA anchors: correction polynomials of the measured angle.
//
// Source 000 section 4 fits the chamber's measured angle theta against the true angle Theta and
// inverts the fit (linear, quadratic, cubic; (6.1)-(6.12)), each valid on an interval of theta
// (Table 6.4). We store the inverse directly, as a polynomial of the measured angle:
//   Theta = c0 + c1 theta + c2 theta^2 + c3 theta^3   (degrees), for theta in [valid_min, valid_max]
// which is what ips-aoa-calibrate fits by least squares (no Cardano inversion, no branch quirk:
// the source's Table 6.6 applied its theta < 0 formula to positive angles). A constant c0 alone is
// a mounting-yaw correction (alpha = yaw - Theta); the mounting yaw and tilt themselves are the
// anchor's orientation_deg in the site.
//
// Outside the valid interval a polynomial fitted on data says nothing (the source's quadratic
// sends -55 to -89.9); `beyond` chooses between continuing along the tangent at the nearer end
// (kExtend, the default) and dropping the angle (kReject).
//
// Site file (docs/site-file.md):
//   estimators:
//     aoa:
//       calibration:
//         A1:
//           azimuth:   {polynomial: [c0, c1, c2, c3], valid_deg: [-52, 62], beyond: extend}
//           elevation: {polynomial: [0.5, 1.0]}
#include <array>
#include <map>
#include <optional>
#include <string>

#include "core/yaml_fields.hpp"

namespace ips::aoa {

struct AngleCorrection {
  enum class Beyond { kExtend, kReject };
  std::array<double, 4> coefficients{0.0, 1.0, 0.0, 0.0};  // c0..c3, degrees; identity
  double valid_min_deg = -90.0;
  double valid_max_deg = 90.0;
  Beyond beyond = Beyond::kExtend;

  bool is_identity() const;
  // The corrected angle in degrees, or nullopt when rejected (beyond the interval with kReject,
  // or not finite).
  std::optional<double> apply(double measured_deg) const;
  // The polynomial itself (no interval) and its derivative.
  double evaluate(double theta_deg) const;
  double derivative(double theta_deg) const;
};

struct AnchorCalibration {
  AngleCorrection azimuth;
  AngleCorrection elevation;
};

// `estimators.aoa.calibration`: anchor id -> calibration. Throws ConfigError with file, line and
// field on a bad entry (unknown key, more than 4 coefficients, an empty or reversed interval).
std::map<std::string, AnchorCalibration> parse_calibration(const YamlField& section);
AngleCorrection parse_angle_correction(const YamlField& f);

// The YAML flow map of a correction, e.g. "{polynomial: [1.2, 0.98], valid_deg: [-60, 60]}"
// (trailing zero coefficients omitted, numbers with enough digits to round-trip the fit).
std::string format_angle_correction(const AngleCorrection& c);

}  // namespace ips::aoa
