// Prescribed motions of position-controlled bodies (moving floors, pushers, vibrating plates).
#pragma once

#include <vector>

#include "vinci/sim/types.h"

namespace vinci::sim {

/// One sinusoidal term A sin(2π f t + φ).
struct Harmonic {
  double amplitude = 0.0;  ///< m or rad
  double frequency = 0.0;  ///< Hz
  double phase = 0.0;      ///< rad
};

/// (t, value) pair of a piecewise-linear keyframe track.
struct Keyframe {
  double t = 0.0;      ///< s
  double value = 0.0;  ///< m or rad
};

/// Offset of one degree of freedom from the body's initial pose:
///   keyframes non-empty: piecewise-linear interpolation (held constant outside the range);
///   otherwise: velocity·t + Σ_k A_k sin(2π f_k t + φ_k) − Σ_k A_k sin(φ_k)
/// (the constant keeps the offset zero at t = 0, so the initial pose is the pose at t = 0).
struct DofMotion {
  double velocity = 0.0;  ///< m/s or rad/s
  std::vector<Harmonic> harmonics;
  std::vector<Keyframe> keyframes;  ///< strictly increasing t

  double Value(double t) const;
  double Rate(double t) const;
  bool IsZero() const { return velocity == 0.0 && harmonics.empty() && keyframes.empty(); }
};

/// Per-DOF prescription of a body. Planar: (x, y, θ). Spatial: (x, y, z, roll, pitch, yaw)
/// with orientation R(t) = R_0 · Rz(yaw) · Ry(pitch) · Rx(roll) — body-fixed Euler angles
/// applied after the initial orientation R_0. Angular velocity is computed exactly from the
/// Euler rates.
struct PrescribedMotion {
  std::vector<DofMotion> dofs;  ///< 3 (planar) or 6 (spatial); empty = at rest
};

/// Pose and velocity of a prescribed (or static) body at time t.
struct BodyKinematics {
  Isometry3d X_WB = Isometry3d::Identity();
  Vector3d v_WB = Vector3d::Zero();  ///< velocity of the body origin, world frame (m/s)
  Vector3d w_WB = Vector3d::Zero();  ///< angular velocity, world frame (rad/s)
};

/// Evaluates a prescribed motion from the initial pose X_WB0 at time t.
BodyKinematics EvaluateMotion(const PrescribedMotion& motion, const Isometry3d& X_WB0, bool planar,
                              double t);

}  // namespace vinci::sim
