#pragma once
// Barometric height: the hypsometric equation with virtual temperature for an isothermal layer,
// source ../shared/reference/003_baro.md (2.1)-(2.9). Its moist-air density
// rho = (p_d M_d + p_v M_v) / (R T) gives p / rho = R_d T_v, so (2.2) is
//   dh = (R_d T_v / g) ln(p_ref / p),   T_v = T / (1 - (e / p) (1 - M_v / M_d)),
//   e = phi * 611.2 exp(17.67 Tc / (Tc + 243.5))   (Tetens, 2.7)
// (2.9) prints Tetens' denominator in kelvin as T - 29.65, which is Tc + 243.5. 003 gives no
// constants; these are CODATA's R and the usual molar masses. At 293 K, 40 %, 101325 Pa and
// g = 9.81: rho = 1.2006 kg/m^3, dp/dz = -11.78 Pa/m (003 reproduction target 1). Used by the
// simulator's barometers and by ips-altitude, so both use one atmosphere. Pure.
#include <cmath>

namespace ips::barometric {

inline constexpr double kGasConstant = 8.314462618;    // J/(mol K)
inline constexpr double kMolarMassDryAir = 0.0289652;  // kg/mol
inline constexpr double kMolarMassWater = 0.018016;    // kg/mol
inline constexpr double kKelvinOffset = 273.15;
inline constexpr double kDryAirGasConstant = kGasConstant / kMolarMassDryAir;  // J/(kg K)

// Saturation vapour pressure over water, Pa (Tetens, 003 (2.7)).
inline double saturation_vapour_pressure_pa(double temperature_c) {
  return 611.2 * std::exp(17.67 * temperature_c / (temperature_c + 243.5));
}

// The temperature dry air would need for the moist air's density at the same pressure, K.
inline double virtual_temperature_k(double temperature_c, double humidity_pct,
                                    double pressure_pa) {
  const double e = humidity_pct / 100.0 * saturation_vapour_pressure_pa(temperature_c);
  return (temperature_c + kKelvinOffset) /
         (1.0 - e / pressure_pa * (1.0 - kMolarMassWater / kMolarMassDryAir));
}

// Moist-air density, kg/m^3 (003 (2.9)).
inline double air_density(double temperature_c, double humidity_pct, double pressure_pa) {
  return pressure_pa /
         (kDryAirGasConstant * virtual_temperature_k(temperature_c, humidity_pct, pressure_pa));
}

// 1 / scale height = g / (R_d T_v), 1/m: pressure falls by this fraction per metre.
inline double inverse_scale_height_per_m(double temperature_c, double humidity_pct,
                                         double pressure_pa, double gravity_mps2) {
  return gravity_mps2 /
         (kDryAirGasConstant * virtual_temperature_k(temperature_c, humidity_pct, pressure_pa));
}

// Pressure dh above a level where it is p_ref (003 (2.1)).
inline double pressure_above_pa(double p_ref_pa, double dh_m, double inverse_scale_height) {
  return p_ref_pa * std::exp(-inverse_scale_height * dh_m);
}

// Height of pressure p above the level of p_ref (003 (2.2), the hypsometric equation).
inline double height_above_m(double p_ref_pa, double p_pa, double inverse_scale_height) {
  return std::log(p_ref_pa / p_pa) / inverse_scale_height;
}

}  // namespace ips::barometric
