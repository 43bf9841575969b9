// The atmosphere of core/barometric.hpp and the pressure measurement model against hand-computed
// values: ../shared/reference/003_baro.md sections 2.2 and 5 (reproduction targets 1, 2, 4 and
// 6), computed from (2.1)-(2.9) with R = 8.314462618, M_d = 0.0289652, M_v = 0.018016.
#include <gtest/gtest.h>

#include <cmath>

#include "core/barometric.hpp"
#include "estimators/altitude/models/baro_height.hpp"

namespace ips::altitude {
namespace {

namespace b = barometric;
constexpr double kTc = 19.85;  // 293 K, 003's default
constexpr double kP0 = 101325.0;

TEST(Barometric, TetensAt20C) {
  // 611.2 exp(17.67 * 20 / 263.5) = 2336.95 Pa (003 (2.7)).
  EXPECT_NEAR(b::saturation_vapour_pressure_pa(20.0), 2336.95, 0.01);
}

TEST(Barometric, MoistAirDensityAndGradientAt293K40Percent) {
  // Target 1: rho = 1.2006 kg/m^3, dp/dz = -11.78 Pa/m; (2.9) evaluated as printed (with
  // Tetens' denominator T - 29.65 in kelvin) gives the same 1.2005720.
  EXPECT_NEAR(b::air_density(kTc, 40, kP0), 1.2005720, 1e-6);
  const double k = b::inverse_scale_height_per_m(kTc, 40, kP0, 9.81);
  EXPECT_NEAR(-k * kP0, -11.7776, 1e-4);
  // Scale height p0 / (rho g), about 8603 m.
  EXPECT_NEAR(1.0 / k, 8603.19, 0.01);
}

TEST(Barometric, HeightFromThePressureDifference) {
  // Target 2: p_h = 1013.015 hPa under p0 = 1013.25 hPa is 1.9955 m higher.
  const double k = b::inverse_scale_height_per_m(kTc, 40, kP0, 9.81);
  EXPECT_NEAR(b::height_above_m(kP0, 101301.5, k), 1.99554, 1e-5);
  // And back.
  EXPECT_NEAR(b::pressure_above_pa(kP0, 1.99554, k), 101301.5, 1e-3);
  // Target 4: 25 Pa is 2.12 m.
  EXPECT_NEAR(b::height_above_m(kP0, kP0 - 25.0, k), 2.1229, 1e-4);
}

TEST(Barometric, TemperatureMovesATwoMetreDifferenceBySevenCentimetresPer10C) {
  // 003 section 2.2: about 7 cm per 10 C at 2 m (3.5 %), not negligible. The pressure of a
  // true 2 m at 293 K, read at 283 and 303 K: 1.9286 and 2.0741 m.
  const double p2 = b::pressure_above_pa(kP0, 2.0, b::inverse_scale_height_per_m(kTc, 40, kP0, 9.81));
  const auto height_at = [&](double tc) {
    return b::height_above_m(kP0, p2, b::inverse_scale_height_per_m(tc, 40, kP0, 9.81));
  };
  EXPECT_NEAR(height_at(kTc), 2.0, 1e-9);
  EXPECT_NEAR(height_at(kTc - 10), 1.92856, 1e-5);
  EXPECT_NEAR(height_at(kTc + 10), 2.07414, 1e-5);
  EXPECT_NEAR(height_at(kTc + 10) - height_at(kTc), 0.074, 0.001);
}

TEST(Barometric, HumidityAndGravityAreCentimetreEffects) {
  // 003 section 2.2: phi 0 to 100 % moves 2 m by 1.7 cm; 40 -> 50 % (the EKF's constant) by
  // 1.7 mm; g 9.78 to 9.82 by about 8 mm.
  const double p2 = b::pressure_above_pa(kP0, 2.0, b::inverse_scale_height_per_m(kTc, 40, kP0, 9.81));
  const auto h = [&](double phi, double g) {
    return b::height_above_m(kP0, p2, b::inverse_scale_height_per_m(kTc, phi, kP0, g));
  };
  EXPECT_NEAR(h(0, 9.81), 1.99309, 1e-5);
  EXPECT_NEAR(h(100, 9.81), 2.01046, 1e-5);
  EXPECT_NEAR(h(50, 9.81), 2.00174, 1e-5);
  EXPECT_NEAR(h(40, 9.78) - h(40, 9.82), 0.00817, 1e-4);
}

TEST(BaroHeightModel, JacobianMatchesFiniteDifferencesAnd4_32) {
  // Target 6: 003 (4.32), dp/dz = -rho0 g exp(-rho0 g (z - h0) / p0), about -11.8 Pa/m.
  const BaroReference ref{kP0, 2.4, b::inverse_scale_height_per_m(kTc, 50, kP0, 9.81)};
  const double rho0 = b::air_density(kTc, 50, kP0);
  for (double z : {0.82, 1.07, 2.4, 5.0}) {
    const BaroPrediction at = predict_baro(z, ref);
    const double numeric =
        (predict_baro(z + 1e-3, ref).pressure_pa - predict_baro(z - 1e-3, ref).pressure_pa) / 2e-3;
    EXPECT_NEAR(at.dpressure_dheight, numeric, 1e-6) << z;
    EXPECT_NEAR(at.dpressure_dheight, -rho0 * 9.81 * std::exp(-rho0 * 9.81 * (z - 2.4) / kP0),
                1e-9)
        << z;
    EXPECT_NEAR(at.dpressure_dheight, -11.77, 0.02) << z;
  }
}

TEST(BaroHeightModel, AnExactReadingLandsOnItsHeight) {
  BaroReference ref{100800.0, 2.4, b::inverse_scale_height_per_m(22.0, 50, 100800.0, 9.81)};
  const double truth = 0.82;
  const double p = predict_baro(truth, ref).pressure_pa;
  Vec<2> x(1.5, 0.0);
  Mat<2> P = Mat<2>::Identity();
  for (int i = 0; i < 50; ++i) update_baro_height<2>(x, P, 0, p, ref, 0.01, kNoGate);
  EXPECT_NEAR(x(0), truth, 1e-4);
  // Gated: a reading 30 sigma off is refused and leaves the state alone.
  const Vec<2> before = x;
  const double sigma_pa = std::sqrt(P(0, 0) * 11.8 * 11.8 + 0.01);
  const UpdateResult u = update_baro_height<2>(x, P, 0, p + 30.0 * sigma_pa, ref, 0.01, 25.0);
  EXPECT_FALSE(u.accepted);
  EXPECT_EQ(x, before);
}

}  // namespace
}  // namespace ips::altitude
