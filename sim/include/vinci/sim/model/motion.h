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
  /// The offset at t = ℓh integrated from the rates with step h like a dynamic body's position
  /// (q_ℓ+1 = q_ℓ + h·Rate(t_ℓ+1)), ℓ = round(t/h): Σ_{k=1..ℓ} h·Rate(kh), in closed form for
  /// velocity and harmonics (a geometric sum of sampled sinusoids). Keyframe tracks return Value.
  double IntegratedValue(double t, double h) const;
  bool IsZero() const { return velocity == 0.0 && harmonics.empty() && keyframes.empty(); }
};

/// The tilting family of the vibrating-plate literature: a rotation θ(t) = α sin(2π f t + φ) about
/// a line parallel to `axis_B` through the point at `depth` d below the body origin (along the
/// body's surface normal n: body z spatial, body y planar). Applied to the initial pose first:
/// the body origin moves by R(θ)(d n) − d n, i.e. planar X = −d sin θ, Y = d(cos θ − 1). Unlike
/// DofMotion there is no offset: X_WB0 is the untilted (θ = 0) pose.
struct TiltMotion {
  double amplitude = 0.0;               ///< α (rad); 0 = no tilt
  double frequency = 0.0;               ///< Hz
  double phase = 0.0;                   ///< φ (rad)
  double depth = 0.0;                   ///< d (m), along −n from the body origin
  Vector3d axis_B = Vector3d::UnitX();  ///< unit, body frame, ⟂ n (spatial); planar uses z
  double Angle(double t) const;         ///< θ(t)
  double Rate(double t) const;          ///< θ̇(t)
  double IntegratedAngle(double t, double h) const;  ///< Σ h θ̇(kh), see DofMotion
  bool IsZero() const { return amplitude == 0.0; }
};

/// How EvaluateMotion computes the pose of a prescribed body.
enum class PoseRule {
  kExact,       ///< from the prescription at t (default)
  kIntegrated,  ///< each dof (and the tilt angle) integrated from its rate with the step h
};

/// Per-DOF prescription of a body. Planar: (x, y, θ). Spatial: (x, y, z, roll, pitch, yaw)
/// with orientation R(t) = R_0 · Rz(yaw) · Ry(pitch) · Rx(roll) — body-fixed Euler angles
/// applied after the initial orientation R_0. Angular velocity is computed exactly from the
/// Euler rates.
///
/// A tilt (TiltMotion) may be combined with the dofs: R(t) = R_0 · R_tilt(t) · R_dofs(t),
/// origin(t) = origin_0 + R_0 (R_tilt(θ) d n − d n) + Δ(x, y, z).
/// EvaluateMotion memoizes its last evaluations per thread, keyed on every field it reads
/// (motion.cc, SameMotion): a field added here that evaluation reads must join that key.
struct PrescribedMotion {
  std::vector<DofMotion> dofs;  ///< 3 (planar) or 6 (spatial); empty = no dof offsets
  TiltMotion tilt;              ///< inactive when tilt.amplitude == 0
  PoseRule pose = PoseRule::kExact;
  double base_frequency = 0.0;  ///< Hz; the scene file's motion `frequency` (0: not given)
  /// s: the motion is evaluated at τ = t − time_origin (everything above is a function of τ).
  /// 0 for a scene's own motion; a phase-locked segment (motion_input.h) sets its start time.
  double time_origin = 0.0;
  bool IsAtRest() const { return dofs.empty() && tilt.IsZero(); }
};

/// A prescribed body's motion for one step, replacing the scene's (StepInput::motions): during
/// the step the body moves as a scene body with motion `motion` and initial pose X_WB0 would,
/// i.e. EvaluateMotion(motion, X_WB0, planar, t[, h]). Semantics and helpers: motion_input.h.
struct MotionInput {
  int body = -1;                              ///< index of a prescribed body
  PrescribedMotion motion;                    ///< with its time_origin t0
  Isometry3d X_WB0 = Isometry3d::Identity();  ///< reference pose the offsets apply to
};

/// Pose and velocity of a prescribed (or static) body at time t.
struct BodyKinematics {
  Isometry3d X_WB = Isometry3d::Identity();
  Vector3d v_WB = Vector3d::Zero();  ///< velocity of the body origin, world frame (m/s)
  Vector3d w_WB = Vector3d::Zero();  ///< angular velocity, world frame (rad/s)
};

/// Evaluates a prescribed motion from the initial pose X_WB0 at time t (at τ = t −
/// motion.time_origin): the exact pose (whatever motion.pose says) and the exact velocity at t.
BodyKinematics EvaluateMotion(const PrescribedMotion& motion, const Isometry3d& X_WB0, bool planar,
                              double t);
/// As above, but honours motion.pose: with PoseRule::kIntegrated and h > 0 the pose is the one
/// integrated from the rates with step h (DofMotion::IntegratedValue); the velocity stays exact at
/// t.
BodyKinematics EvaluateMotion(const PrescribedMotion& motion, const Isometry3d& X_WB0, bool planar,
                              double t, double h);

}  // namespace vinci::sim
