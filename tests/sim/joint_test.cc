#include "vinci/sim/formulations/joint.h"

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Central differences along a motion with O(1) poses and velocities: truncation ≈ h²/6 ≈ 2e-11,
// rounding ≈ 1e-16/h ≈ 1e-11.
constexpr double kFdStep = 1e-5;
// Allowed |finite difference − J ν| relative to max(1, |J ν|∞): 100× the expected FD error.
constexpr double kRateTol = 1e-6;
// Algebraic identities (ψ = 0 at a consistent pose, J ν = 0 along the free axis) hold to
// rounding of a few compositions of O(1) transforms.
constexpr double kIdentityTol = 1e-12;
constexpr int kTrials = 40;

struct Case {
  JointType type;
  Dim dim;
};
constexpr Case kAllCases[] = {
    {JointType::kRevolute, Dim::kPlanar},   {JointType::kPrismatic, Dim::kPlanar},
    {JointType::kWeld, Dim::kPlanar},       {JointType::kSpherical, Dim::kSpatial},
    {JointType::kFixed, Dim::kSpatial},     {JointType::kRevolute, Dim::kSpatial},
    {JointType::kPrismatic, Dim::kSpatial},
};

std::string CaseName(const Case& c) {
  const char* names[] = {"revolute", "prismatic", "weld", "spherical", "fixed"};
  return std::string(names[static_cast<int>(c.type)]) +
         (c.dim == Dim::kPlanar ? "/planar" : "/spatial");
}

class Sampler {
 public:
  explicit Sampler(unsigned seed) : gen_(seed) {}
  double Uniform(double lo, double hi) { return std::uniform_real_distribution<>(lo, hi)(gen_); }
  Vector3d Vec(double scale) {
    return Vector3d(Uniform(-scale, scale), Uniform(-scale, scale), Uniform(-scale, scale));
  }
  Vector3d UnitVec() {
    Vector3d v;
    do v = Vec(1.0);
    while (v.norm() < 0.1 || v.norm() > 1.0);
    return v.normalized();
  }
  Isometry3d Pose(Dim dim, double scale) {
    if (dim == Dim::kPlanar) {
      return PlanarPose(Uniform(-scale, scale), Uniform(-scale, scale), Uniform(-kPi, kPi));
    }
    Isometry3d X = Isometry3d::Identity();
    X.linear() = Eigen::AngleAxisd(Uniform(0.0, kPi), UnitVec()).toRotationMatrix();
    X.translation() = Vec(scale);
    return X;
  }
  VectorXd Velocity(Dim dim) {
    VectorXd v(VelocitySize(dim));
    for (int i = 0; i < v.size(); ++i) v[i] = Uniform(-1.0, 1.0);
    return v;
  }
  /// A small rigid displacement (translation and rotation of size ≈ eps).
  Isometry3d Perturbation(Dim dim, double eps) {
    if (dim == Dim::kPlanar) {
      return PlanarPose(Uniform(-eps, eps), Uniform(-eps, eps), Uniform(-eps, eps));
    }
    Isometry3d X = Isometry3d::Identity();
    X.linear() = Eigen::AngleAxisd(eps, UnitVec()).toRotationMatrix();
    X.translation() = Vec(eps);
    return X;
  }

 private:
  std::mt19937 gen_;
};

/// Pose after time t of a body moving with constant ν: planar (x, y, θ) + t ν; spatial
/// p + t v_W, R exp(t ω_B).
Isometry3d Advance(Dim dim, const Isometry3d& X, const VectorXd& nu, double t) {
  Isometry3d Y = X;
  if (dim == Dim::kPlanar) {
    Y.translation() += t * Vector3d(nu[0], nu[1], 0.0);
    Y.linear() = Eigen::AngleAxisd(t * nu[2], Vector3d::UnitZ()).toRotationMatrix() * X.linear();
    return Y;
  }
  const Vector3d w = nu.tail<3>();
  Y.translation() += t * nu.head<3>();
  if (w.norm() > 0.0) {
    Y.linear() = X.linear() * Eigen::AngleAxisd(t * w.norm(), w.normalized()).toRotationMatrix();
  }
  return Y;
}

/// World kinematics from a pose and ν (ν in the kinematics.h convention).
BodyKinematics Kinematics(Dim dim, const Isometry3d& X, const VectorXd& nu) {
  BodyKinematics k;
  k.X_WB = X;
  if (dim == Dim::kPlanar) {
    k.v_WB = Vector3d(nu[0], nu[1], 0.0);
    k.w_WB = Vector3d(0.0, 0.0, nu[2]);
  } else {
    k.v_WB = nu.head<3>();
    k.w_WB = X.linear() * nu.tail<3>();
  }
  return k;
}

JointRows Evaluate(const Joint& joint, Dim dim, const Isometry3d& X_WA, const Isometry3d& X_WB) {
  JointRows rows;
  EvaluateJoint(joint, dim, Kinematics(dim, X_WA, VectorXd::Zero(VelocitySize(dim))),
                Kinematics(dim, X_WB, VectorXd::Zero(VelocitySize(dim))), &rows);
  return rows;
}

/// Relative displacement of J_b from J_a along the joint's free directions (X_JaJb).
Isometry3d FreeMotion(const Case& c, Sampler* s) {
  Isometry3d X = Isometry3d::Identity();
  switch (c.type) {
    case JointType::kRevolute:
      X.linear() = Eigen::AngleAxisd(s->Uniform(-kPi, kPi), Vector3d::UnitZ()).toRotationMatrix();
      break;
    case JointType::kPrismatic:
      X.translation() =
          (c.dim == Dim::kPlanar ? Vector3d::UnitX() : Vector3d::UnitZ()) * s->Uniform(-1.0, 1.0);
      break;
    case JointType::kSpherical:
      X.linear() = Eigen::AngleAxisd(s->Uniform(0.0, kPi), s->UnitVec()).toRotationMatrix();
      break;
    default:
      break;
  }
  return X;
}

/// A random joint between two bodies and poses where ψ = 0 (B's pose is built from A's).
struct Config {
  Joint joint;
  Isometry3d X_WA, X_WB;
};
Config ConsistentConfig(const Case& c, Sampler* s, bool world_attached) {
  Config cfg;
  cfg.joint.name = "j";
  cfg.joint.type = c.type;
  cfg.joint.body_a = 0;
  cfg.joint.body_b = world_attached ? -1 : 1;
  cfg.joint.X_AJ = s->Pose(c.dim, 0.5);
  cfg.X_WA = s->Pose(c.dim, 1.0);
  const Isometry3d X_WJb = cfg.X_WA * cfg.joint.X_AJ * FreeMotion(c, s);
  if (world_attached) {
    cfg.joint.X_BJ = X_WJb;
    cfg.X_WB = Isometry3d::Identity();
  } else {
    cfg.joint.X_BJ = s->Pose(c.dim, 0.5);
    cfg.X_WB = X_WJb * cfg.joint.X_BJ.inverse();
  }
  return cfg;
}

/// Checks rows [first, first + count) of dψ/dt by central differences along the motion with
/// constant ν_a, ν_b against J_a ν_a + J_b ν_b at the evaluation point.
void ExpectRatesMatchFd(const Case& c, const Config& cfg, const VectorXd& nu_a,
                        const VectorXd& nu_b, int first, int count, const std::string& what) {
  const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
  const JointRows plus = Evaluate(cfg.joint, c.dim, Advance(c.dim, cfg.X_WA, nu_a, kFdStep),
                                  Advance(c.dim, cfg.X_WB, nu_b, kFdStep));
  const JointRows minus = Evaluate(cfg.joint, c.dim, Advance(c.dim, cfg.X_WA, nu_a, -kFdStep),
                                   Advance(c.dim, cfg.X_WB, nu_b, -kFdStep));
  const VectorXd fd = (plus.psi - minus.psi) / (2.0 * kFdStep);
  const VectorXd rate = rows.J_a * nu_a + rows.J_b * nu_b;
  const double scale = std::max(1.0, rate.lpNorm<Eigen::Infinity>());
  for (int i = first; i < first + count; ++i) {
    EXPECT_NEAR(fd[i], rate[i], kRateTol * scale)
        << CaseName(c) << " " << what << " row " << i << " psi " << rows.psi.transpose();
  }
}

TEST(JointTest, RowCounts) {
  EXPECT_EQ(JointRowCount(JointType::kRevolute, Dim::kPlanar), 2);
  EXPECT_EQ(JointRowCount(JointType::kPrismatic, Dim::kPlanar), 2);
  EXPECT_EQ(JointRowCount(JointType::kWeld, Dim::kPlanar), 3);
  EXPECT_EQ(JointRowCount(JointType::kSpherical, Dim::kSpatial), 3);
  EXPECT_EQ(JointRowCount(JointType::kFixed, Dim::kSpatial), 6);
  EXPECT_EQ(JointRowCount(JointType::kRevolute, Dim::kSpatial), 5);
  EXPECT_EQ(JointRowCount(JointType::kPrismatic, Dim::kSpatial), 5);
  Sampler s(1);
  for (const Case& c : kAllCases) {
    const Config cfg = ConsistentConfig(c, &s, false);
    const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
    const int m = JointRowCount(c.type, c.dim);
    EXPECT_EQ(rows.psi.size(), m) << CaseName(c);
    EXPECT_EQ(rows.J_a.rows(), m) << CaseName(c);
    EXPECT_EQ(rows.J_a.cols(), VelocitySize(c.dim)) << CaseName(c);
    EXPECT_EQ(rows.J_b.rows(), m) << CaseName(c);
    EXPECT_EQ(rows.J_b.cols(), VelocitySize(c.dim)) << CaseName(c);
  }
}

// Message must name the type and the dimension.
void ExpectInvalid(JointType type, Dim dim, const std::string& type_word,
                   const std::string& dim_word) {
  try {
    JointRowCount(type, dim);
    ADD_FAILURE() << "JointRowCount did not throw for " << type_word << " in " << dim_word;
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(type_word), std::string::npos) << msg;
    EXPECT_NE(msg.find(dim_word), std::string::npos) << msg;
  }
  Joint joint;
  joint.name = "bad_joint";
  joint.type = type;
  JointRows rows;
  try {
    EvaluateJoint(joint, dim, BodyKinematics(), BodyKinematics(), &rows);
    ADD_FAILURE() << "EvaluateJoint did not throw for " << type_word << " in " << dim_word;
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(type_word), std::string::npos) << msg;
    EXPECT_NE(msg.find(dim_word), std::string::npos) << msg;
    EXPECT_NE(msg.find("bad_joint"), std::string::npos) << msg;
  }
}

TEST(JointTest, InvalidTypeForDimensionThrows) {
  ExpectInvalid(JointType::kWeld, Dim::kSpatial, "weld", "spatial");
  ExpectInvalid(JointType::kSpherical, Dim::kPlanar, "spherical", "planar");
  ExpectInvalid(JointType::kFixed, Dim::kPlanar, "fixed", "planar");
}

TEST(JointTest, ConsistentConfigurationHasZeroResidualAndIndependentRows) {
  Sampler s(2);
  for (const Case& c : kAllCases) {
    for (int world = 0; world < 2; ++world) {
      for (int trial = 0; trial < kTrials; ++trial) {
        const Config cfg = ConsistentConfig(c, &s, world == 1);
        const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
        EXPECT_LT(rows.psi.lpNorm<Eigen::Infinity>(), kIdentityTol) << CaseName(c);
        // The rows constrain independent directions of A's motion relative to a fixed B:
        // σ_min(J_a) is bounded away from zero (here |p_b − c_A| < 2 m keeps it above ≈ 0.4).
        Eigen::JacobiSVD<MatrixXd> svd(rows.J_a);
        EXPECT_GT(svd.singularValues().minCoeff(), 0.1) << CaseName(c);
      }
    }
  }
}

TEST(JointTest, JacobianMatchesFiniteDifferencesAtConsistentPoses) {
  Sampler s(3);
  for (const Case& c : kAllCases) {
    const int m = JointRowCount(c.type, c.dim);
    for (int trial = 0; trial < kTrials; ++trial) {
      const Config cfg = ConsistentConfig(c, &s, false);
      ExpectRatesMatchFd(c, cfg, s.Velocity(c.dim), s.Velocity(c.dim), 0, m, "consistent");
    }
  }
}

// Position rows, revolute axis rows and (this implementation) the orientation-error rows are
// exact away from ψ = 0 too.
TEST(JointTest, JacobianMatchesFiniteDifferencesAtViolatedPoses) {
  constexpr double kViolation = 1e-2;  // m and rad
  Sampler s(4);
  for (const Case& c : kAllCases) {
    const int m = JointRowCount(c.type, c.dim);
    for (int trial = 0; trial < kTrials; ++trial) {
      Config cfg = ConsistentConfig(c, &s, false);
      cfg.X_WB = cfg.X_WB * s.Perturbation(c.dim, kViolation);
      const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
      if (c.type != JointType::kSpherical) {
        // A spherical joint's point may stay coincident under a perturbation of B only by
        // chance; every other joint is visibly violated.
        ASSERT_GT(rows.psi.lpNorm<Eigen::Infinity>(), 1e-4) << CaseName(c);
      }
      ExpectRatesMatchFd(c, cfg, s.Velocity(c.dim), s.Velocity(c.dim), 0, m, "violated");
    }
  }
}

// The orientation error e = vee(log(R_WJa R_WJbᵀ)) has an exact Jacobian for |e| < π, not
// only at e = 0 (the identity blocks [R_WA, −R_WB] would be off by O(|e|) here).
TEST(JointTest, OrientationErrorJacobianIsExactForLargeErrors) {
  Sampler s(5);
  for (const Case c :
       {Case{JointType::kFixed, Dim::kSpatial}, Case{JointType::kPrismatic, Dim::kSpatial}}) {
    const int first = JointRowCount(c.type, c.dim) - 3;
    for (int trial = 0; trial < kTrials; ++trial) {
      Config cfg = ConsistentConfig(c, &s, false);
      Isometry3d rot = Isometry3d::Identity();
      const double angle = s.Uniform(0.3, 2.8);
      rot.linear() = Eigen::AngleAxisd(angle, s.UnitVec()).toRotationMatrix();
      cfg.X_WB = cfg.X_WB * rot;
      const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
      EXPECT_NEAR(rows.psi.segment<3>(first).norm(), angle, kIdentityTol) << CaseName(c);
      ExpectRatesMatchFd(c, cfg, s.Velocity(c.dim), s.Velocity(c.dim), first, 3, "large e");
    }
  }
}

TEST(JointTest, WorldAttachedJointMatchesFiniteDifferences) {
  Sampler s(6);
  for (const Case& c : kAllCases) {
    const int m = JointRowCount(c.type, c.dim);
    const VectorXd zero = VectorXd::Zero(VelocitySize(c.dim));
    for (int trial = 0; trial < kTrials; ++trial) {
      Config cfg = ConsistentConfig(c, &s, true);
      ExpectRatesMatchFd(c, cfg, s.Velocity(c.dim), zero, 0, m, "world, consistent");
      cfg.X_WA = cfg.X_WA * s.Perturbation(c.dim, 1e-2);
      ExpectRatesMatchFd(c, cfg, s.Velocity(c.dim), zero, 0, m, "world, violated");
    }
  }
}

/// ν of a body at X_W whose world twist is ω_W and velocity v_W at the point o_W.
VectorXd NuFromTwist(Dim dim, const Isometry3d& X_W, const Vector3d& w_W, const Vector3d& o_W,
                     const Vector3d& v_o_W) {
  const Vector3d v_origin = v_o_W + w_W.cross(X_W.translation() - o_W);
  VectorXd nu(VelocitySize(dim));
  if (dim == Dim::kPlanar) {
    nu << v_origin.x(), v_origin.y(), w_W.z();
  } else {
    nu << v_origin, X_W.linear().transpose() * w_W;
  }
  return nu;
}

// Both bodies share an arbitrary rigid motion; A additionally moves along the free axis
// (revolute: rotation about J's z through J's origin; prismatic: slide along J's free axis).
// The constraint rates vanish; a motion off the free axis does not.
TEST(JointTest, FreeAxisMotionHasZeroConstraintRate) {
  Sampler s(7);
  for (const Case& c : kAllCases) {
    if (c.type != JointType::kRevolute && c.type != JointType::kPrismatic) continue;
    const bool planar = c.dim == Dim::kPlanar;
    for (int trial = 0; trial < kTrials; ++trial) {
      for (int world = 0; world < 2; ++world) {
        const Config cfg = ConsistentConfig(c, &s, world == 1);
        const Isometry3d X_WJa = cfg.X_WA * cfg.joint.X_AJ;
        // Common rigid motion (zero for a world-attached joint: B is the world).
        Vector3d w_common = world == 1 ? Vector3d::Zero() : s.Vec(1.0);
        Vector3d v_common = world == 1 ? Vector3d::Zero() : s.Vec(1.0);
        if (planar) {
          w_common.head<2>().setZero();
          v_common.z() = 0.0;
        }
        const Vector3d o = Vector3d::Zero();  // reference point of the common twist
        const Vector3d axis = c.type == JointType::kRevolute || !planar
                                  ? Vector3d(X_WJa.linear().col(2))
                                  : Vector3d(X_WJa.linear().col(0));
        const double rate = s.Uniform(-2.0, 2.0);
        Vector3d w_a = w_common, v_a_at_o = v_common;
        if (c.type == JointType::kRevolute) {
          w_a += rate * axis;
          v_a_at_o += (rate * axis).cross(o - X_WJa.translation());
        } else {
          v_a_at_o += rate * axis;
        }
        const VectorXd nu_a = NuFromTwist(c.dim, cfg.X_WA, w_a, o, v_a_at_o);
        const VectorXd nu_b = NuFromTwist(c.dim, cfg.X_WB, w_common, o, v_common);
        const JointRows rows = Evaluate(cfg.joint, c.dim, cfg.X_WA, cfg.X_WB);
        const VectorXd jv = rows.J_a * nu_a + rows.J_b * nu_b;
        EXPECT_LT(jv.lpNorm<Eigen::Infinity>(), kIdentityTol) << CaseName(c);

        // Control: the same relative speed along a constrained direction is seen.
        const Vector3d off_axis = planar ? Vector3d(X_WJa.linear().col(1))  // planar: ŷ_J
                                         : Vector3d(X_WJa.linear().col(0));
        VectorXd nu_off = nu_a;
        if (c.type == JointType::kRevolute && !planar) {
          nu_off = NuFromTwist(c.dim, cfg.X_WA, w_common + rate * off_axis, X_WJa.translation(),
                               v_common + w_common.cross(X_WJa.translation() - o));
        } else {
          nu_off = NuFromTwist(c.dim, cfg.X_WA, w_common, o, v_common + rate * off_axis);
        }
        const VectorXd jv_off = rows.J_a * nu_off + rows.J_b * nu_b;
        EXPECT_GT(jv_off.lpNorm<Eigen::Infinity>(), 0.5 * std::abs(rate)) << CaseName(c);
      }
    }
  }
}

TEST(JointTest, ResidualSignsAndValuesInClosedForm) {
  // Planar revolute: ψ = p_a − p_b.
  Joint rev;
  rev.type = JointType::kRevolute;
  rev.X_AJ.translation() = Vector3d(1.0, 0.0, 0.0);
  rev.X_BJ.translation() = Vector3d(0.0, 2.0, 0.0);
  JointRows rows =
      Evaluate(rev, Dim::kPlanar, PlanarPose(0.0, 0.0, kPi / 2), Isometry3d::Identity());
  // p_a = R(90°)(1, 0) = (0, 1); p_b = (0, 2).
  EXPECT_NEAR(rows.psi[0], 0.0, kIdentityTol);
  EXPECT_NEAR(rows.psi[1], -1.0, kIdentityTol);

  // Planar prismatic: ψ_0 = (p_b − p_a)·ŷ_Ja, ψ_1 = θ_Ja − θ_Jb.
  Joint pri;
  pri.type = JointType::kPrismatic;
  rows = Evaluate(pri, Dim::kPlanar, PlanarPose(0.0, 0.0, 0.25), PlanarPose(3.0, 0.5, 0.0));
  EXPECT_NEAR(rows.psi[0], -3.0 * std::sin(0.25) + 0.5 * std::cos(0.25), kIdentityTol);
  EXPECT_NEAR(rows.psi[1], 0.25, kIdentityTol);

  // Weld angle wraps into (−π, π]: 3 − (−3) = 6 → 6 − 2π.
  Joint weld;
  weld.type = JointType::kWeld;
  rows = Evaluate(weld, Dim::kPlanar, PlanarPose(0, 0, 3.0), PlanarPose(0, 0, -3.0));
  EXPECT_NEAR(rows.psi[2], 6.0 - 2.0 * kPi, kIdentityTol);
  // A half-turn whose sine rounds to −0 maps to +π, not −π.
  Isometry3d half_turn = Isometry3d::Identity();
  half_turn.linear() = Vector3d(-1.0, -1.0, 1.0).asDiagonal();
  rows = Evaluate(weld, Dim::kPlanar, Isometry3d::Identity(), half_turn);
  EXPECT_EQ(rows.psi[2], kPi);

  // Spatial fixed: e = vee(log(R_WJa R_WJbᵀ)), here A rotated by 0.3 rad about u, B = world.
  Joint fixed;
  fixed.type = JointType::kFixed;
  const Vector3d u = Vector3d(1.0, -2.0, 0.5).normalized();
  Isometry3d X_WA = Isometry3d::Identity();
  X_WA.linear() = Eigen::AngleAxisd(0.3, u).toRotationMatrix();
  X_WA.translation() = Vector3d(0.1, 0.2, 0.3);
  rows = Evaluate(fixed, Dim::kSpatial, X_WA, Isometry3d::Identity());
  EXPECT_LT((rows.psi.head<3>() - Vector3d(0.1, 0.2, 0.3)).norm(), kIdentityTol);
  EXPECT_LT((rows.psi.tail<3>() - 0.3 * u).norm(), kIdentityTol);

  // Spatial revolute: tilting J_a about J_b's x by α gives ẑ_Ja·ŷ_Jb = −sin α.
  Joint srev;
  srev.type = JointType::kRevolute;
  X_WA = Isometry3d::Identity();
  X_WA.linear() = Eigen::AngleAxisd(0.2, Vector3d::UnitX()).toRotationMatrix();
  rows = Evaluate(srev, Dim::kSpatial, X_WA, Isometry3d::Identity());
  EXPECT_NEAR(rows.psi[3], 0.0, kIdentityTol);
  EXPECT_NEAR(rows.psi[4], -std::sin(0.2), kIdentityTol);

  // Spatial prismatic: ψ = (p_b − p_a)·(x̂, ŷ) of J_a; the slide along ẑ is free.
  Joint spri;
  spri.type = JointType::kPrismatic;
  Isometry3d X_WB = Isometry3d::Identity();
  X_WB.translation() = Vector3d(0.5, -0.25, 7.0);
  rows = Evaluate(spri, Dim::kSpatial, Isometry3d::Identity(), X_WB);
  EXPECT_NEAR(rows.psi[0], 0.5, kIdentityTol);
  EXPECT_NEAR(rows.psi[1], -0.25, kIdentityTol);
  EXPECT_LT(rows.psi.tail<3>().norm(), kIdentityTol);
}

}  // namespace
}  // namespace vinci::sim
