#include "vinci/sim/model/motion.h"

#include <gtest/gtest.h>

#include <cmath>

namespace vinci::sim {
namespace {

constexpr double kFdTol = 1e-6;  // central differences with step 1e-6 on smooth signals

TEST(MotionTest, HarmonicOffsetIsZeroAtStartAndRateMatchesFiniteDifference) {
  DofMotion m;
  m.velocity = 0.3;
  m.harmonics = {{0.01, 30.0, 0.7}, {0.002, 60.0, -1.1}};
  EXPECT_DOUBLE_EQ(m.Value(0.0), 0.0);
  for (double t : {0.0, 0.013, 0.2, 1.7}) {
    const double e = 1e-6;
    EXPECT_NEAR(m.Rate(t), (m.Value(t + e) - m.Value(t - e)) / (2 * e), kFdTol * 100);
  }
}

TEST(MotionTest, KeyframesInterpolateAndHold) {
  DofMotion m;
  m.keyframes = {{0.0, 0.0}, {1.0, 2.0}, {3.0, 2.0}};
  EXPECT_DOUBLE_EQ(m.Value(0.5), 1.0);
  EXPECT_DOUBLE_EQ(m.Rate(0.5), 2.0);
  EXPECT_DOUBLE_EQ(m.Value(2.0), 2.0);
  EXPECT_DOUBLE_EQ(m.Rate(2.0), 0.0);
  EXPECT_DOUBLE_EQ(m.Value(10.0), 2.0);
  EXPECT_DOUBLE_EQ(m.Value(-1.0), 0.0);
}

TEST(MotionTest, SpatialAngularVelocityMatchesFiniteDifferenceOfRotation) {
  PrescribedMotion pm;
  pm.dofs.resize(6);
  pm.dofs[3].harmonics = {{0.3, 2.0, 0.1}};
  pm.dofs[4].harmonics = {{0.2, 3.0, 0.4}};
  pm.dofs[5].velocity = 1.5;
  Isometry3d X0 = Isometry3d::Identity();
  X0.linear() = Eigen::AngleAxisd(0.4, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (double t : {0.05, 0.31, 0.9}) {
    const double e = 1e-6;
    const Matrix3d Rp = EvaluateMotion(pm, X0, false, t + e).X_WB.linear();
    const Matrix3d Rm = EvaluateMotion(pm, X0, false, t - e).X_WB.linear();
    const BodyKinematics k = EvaluateMotion(pm, X0, false, t);
    const Matrix3d Rdot = (Rp - Rm) / (2 * e);
    const Matrix3d W = Rdot * k.X_WB.linear().transpose();  // [ω]× in world
    const Vector3d w(W(2, 1), W(0, 2), W(1, 0));
    EXPECT_NEAR((w - k.w_WB).norm(), 0.0, kFdTol * 10);
  }
}

}  // namespace
}  // namespace vinci::sim
