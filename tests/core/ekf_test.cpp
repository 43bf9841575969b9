// EKF toolkit: Joseph-form updates, gating, symmetry.
#include "core/ekf.hpp"

#include <gtest/gtest.h>

namespace ips {
namespace {

TEST(ScalarUpdate, MatchesTextbookKalmanGainOnOneState) {
  // One state with prior variance 4, measurement variance 1: K = 4/5, posterior variance 4/5.
  Vec<1> x(10.0);
  Mat<1> P(4.0);
  Mat<1, 1> H(1.0);
  UpdateResult r = scalar_update<1>(x, P, H, 5.0, 1.0);
  EXPECT_TRUE(r.accepted);
  EXPECT_NEAR(x(0), 10.0 + 0.8 * 5.0, 1e-12);
  EXPECT_NEAR(P(0, 0), 0.8, 1e-12);
  EXPECT_NEAR(r.mahalanobis_sq, 25.0 / 5.0, 1e-12);
}

TEST(ScalarUpdate, GateRejectsWithoutTouchingState) {
  Vec<2> x(1.0, 2.0);
  Mat<2> P = Mat<2>::Identity();
  const Vec<2> x0 = x;
  const Mat<2> P0 = P;
  Mat<1, 2> H(1.0, 0.0);
  // S = 2, innovation 10: d^2 = 50 > 9.
  UpdateResult r = scalar_update<2>(x, P, H, 10.0, 1.0, 9.0);
  EXPECT_FALSE(r.accepted);
  EXPECT_NEAR(r.mahalanobis_sq, 50.0, 1e-12);
  EXPECT_EQ(x, x0);
  EXPECT_EQ(P, P0);
}

TEST(ScalarUpdate, AsymmetricGateTreatsPositiveInnovationsTighter) {
  Mat<1, 1> H(1.0);
  Vec<1> x(0.0);
  Mat<1> P(1.0);
  // S = 2; innovation +3 -> d^2 4.5: rejected by positive gate 4, accepted by negative gate 16.
  EXPECT_FALSE((scalar_update<1>(x, P, H, 3.0, 1.0, 16.0, 4.0).accepted));
  EXPECT_TRUE((scalar_update<1>(x, P, H, -3.0, 1.0, 16.0, 4.0).accepted));
}

TEST(ScalarUpdate, NonFiniteInnovationIsRejected) {
  Vec<1> x(0.0);
  Mat<1> P(1.0);
  EXPECT_FALSE((scalar_update<1>(x, P, Mat<1, 1>(1.0), NAN, 1.0).accepted));
  EXPECT_EQ(x(0), 0.0);
}

TEST(VectorUpdate, EqualsSequentialScalarUpdatesForIndependentMeasurements) {
  Vec<3> xa(1, 2, 3), xb = xa;
  Mat<3> Pa;
  Pa << 2, 0.3, 0.1, 0.3, 1.5, 0.2, 0.1, 0.2, 1.0;
  Mat<3> Pb = Pa;
  Mat<2, 3> H;
  H << 1, 0, 0, 0, 1, 1;
  Vec<2> z(1.5, 4.0);
  Mat<2> R = Mat<2>::Identity() * 0.5;
  Vec<2> y = z - H * xa;
  ASSERT_TRUE((vector_update<3, 2>(xa, Pa, H, y, R).accepted));
  for (int i = 0; i < 2; ++i) {
    Mat<1, 3> Hi = H.row(i);
    double yi = z(i) - Hi.dot(xb.transpose());
    ASSERT_TRUE(scalar_update<3>(xb, Pb, Hi, yi, 0.5).accepted);
  }
  EXPECT_TRUE(xa.isApprox(xb, 1e-10));
  EXPECT_TRUE(Pa.isApprox(Pb, 1e-10));
  EXPECT_TRUE(Pa.isApprox(Pa.transpose(), 0.0));
}

TEST(VectorUpdate, GateUsesMahalanobisDistance) {
  Vec<2> x = Vec<2>::Zero();
  Mat<2> P = Mat<2>::Identity();
  Mat<2> H = Mat<2>::Identity();
  Mat<2> R = Mat<2>::Identity();
  // S = 2 I; y = (4, 0): d^2 = 8.
  UpdateResult r = vector_update<2, 2>(x, P, H, Vec<2>(4, 0), R, 5.99);
  EXPECT_FALSE(r.accepted);
  EXPECT_NEAR(r.mahalanobis_sq, 8.0, 1e-12);
}

}  // namespace
}  // namespace ips
