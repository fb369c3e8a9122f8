// Prescribed motion given per step or per segment (StepInput::motions) instead of only as a
// function of absolute time: "apply plate motion M, phase-locked, for k cycles from now".
//
// Semantics. A step whose input holds MotionInput{b, M, X_ref} (M.time_origin = t0) moves the
// prescribed body b, at every time t the formulation evaluates in that step (its start t_ℓ and
// end t_ℓ + h), as
//     X_WB(t) = EvaluateMotion(M, X_ref, planar, t[, h]),   i.e. the offsets of M at τ = t − t0
// applied to the reference pose X_ref, exactly as a scene body with motion M (time origin 0) and
// X_WB0 = X_ref would move at time τ. Bodies without an entry keep the scene's motion. The
// scene's own motion is the input {b, scene motion, Body::X_WB0} with t0 = 0, and gives a
// bit-identical trajectory.
//
// Phase-locked segments. A segment applies one MotionInput to k consecutive steps with t0 = the
// state time at the segment's first step, so M starts at its own phase τ = 0 whatever the
// absolute time (with PoseRule::kIntegrated, the integration also restarts: ℓ = round(τ/h)).
// Continuity. The reference pose of a segment is chosen so that the body continues from where
// the previous motion left it: X_ref = ReferencePose(M, planar, X_start), with X_start the
// body's pose at t0 under the previous step's motion (PrescribedKinematicsAt). Then
// X_WB(t0) = X_start to rounding (exactly when M's offsets vanish at τ = 0, as for harmonics,
// velocities and zero-phase tilts), so the body's pose is continuous across the switch; its
// velocity jumps to M's velocity at τ = 0, as a real actuator switching commands would.
// PhaseLockedSegment builds a whole segment and returns where it ends, for chaining.
//
// The estimation face (Formulation::Evaluate, Layout) takes a model: pass
// ApplyMotionInputs(model, u.motions) to evaluate a step that had motion inputs.
#pragma once

#include <vector>

#include "vinci/sim/model/motion.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim {

/// `model` with each input's body moving by the input's motion from its reference pose (the
/// body's `motion` and `X_WB0` replaced). Throws std::invalid_argument naming the input if a
/// body index is out of range, not prescribed or repeated, or a motion is not valid for the
/// scene's dimension (dof count, finite numbers, tilt axis, keyframe order, a proper reference
/// pose: rotation orthonormal, planar about z).
Scene ApplyMotionInputs(const Scene& model, const std::vector<MotionInput>& motions);

/// Checks what ApplyMotionInputs checks, without copying the scene.
void ValidateMotionInputs(const Scene& model, const std::vector<MotionInput>& motions);

/// Bitwise equality of motion inputs (every field; NaN never equal).
bool SameMotionInputs(const std::vector<MotionInput>& a, const std::vector<MotionInput>& b);

/// The reference pose X_ref for which `motion` puts the body at X_start at τ = 0:
/// EvaluateMotion(motion, X_ref, planar, motion.time_origin).X_WB == X_start to rounding, and
/// X_ref == X_start exactly when the motion's offset at τ = 0 is the identity.
Isometry3d ReferencePose(const PrescribedMotion& motion, bool planar, const Isometry3d& X_start);

/// Kinematics of prescribed (or static) body `body` at time t under step input u: u's motion
/// for that body if it has one, else the scene's. h > 0 honours PoseRule::kIntegrated as the
/// formulations do (EvaluateMotion with h); h = 0 gives the exact pose.
BodyKinematics PrescribedKinematicsAt(const Scene& scene, int body, const StepInput& u, double t,
                                      double h = 0.0);

/// A phase-locked segment and where it ends.
struct MotionSegment {
  std::vector<StepInput> inputs;  ///< one per step, each with the segment's MotionInput only
  double t_end = 0.0;             ///< t0 + h + h + ... (accumulated as the simulator does)
  Isometry3d X_end = Isometry3d::Identity();  ///< the body's pose at t_end (next X_start)
};

/// The inputs that apply `motion` to prescribed body `body`, phase-locked, for `cycles` cycles
/// from time t0 and pose X_start: cycles · max(1, round(1/(f·h))) steps of h, f = `frequency`
/// if > 0, else motion.base_frequency, else motion.tilt.frequency. Each input is
/// {body, motion with time_origin = t0, ReferencePose(motion, planar, X_start)}. Chain segments
/// by passing the previous t_end and X_end. Throws std::invalid_argument on a bad body or motion,
/// cycles < 0, h ≤ 0, no frequency, or more than 10⁷ steps.
MotionSegment PhaseLockedSegment(const Scene& scene, int body, const PrescribedMotion& motion,
                                 double t0, const Isometry3d& X_start, int cycles, double h,
                                 double frequency = 0.0);

}  // namespace vinci::sim
