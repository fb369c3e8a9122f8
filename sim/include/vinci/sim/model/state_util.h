// Reading and writing a State by body name, and a state hash for replay checks.
//
// A dynamic body's block of q is its pose (planar x, y, θ; spatial position and unit quaternion
// w, x, y, z) and its block of ν its velocity in the convention of kinematics.h (planar
// (vx, vy, ω); spatial (v_W, ω_B): the angular velocity in the BODY frame). The functions here
// take and return world-frame quantities and do the conversion.
#pragma once

#include <cstdint>
#include <string>

#include "vinci/sim/model/motion.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim {

/// Index of the body named `body`; throws std::invalid_argument listing the scene's bodies.
int BodyIndexByName(const Scene& scene, const std::string& body);

/// World pose and velocity of a body at x: a dynamic body's from x.q and x.v, a prescribed
/// body's from its motion at x.t (EvaluateMotion with the scene's dt, honouring its pose rule),
/// a static body's X_WB0 at rest. Pass the scene with the rollout's params applied
/// (Simulator::Resolve) when pose or motion parameters differ from the scene's. Throws
/// std::invalid_argument for an unknown body or a state of the wrong size.
BodyKinematics GetBodyKinematics(const Scene& scene, const State& x, const std::string& body);

/// Sets a dynamic body's pose in x->q (spatial: the rotation as a unit quaternion). Its block
/// of ν is left unchanged; since a spatial ν holds ω in the body frame, set the pose BEFORE
/// the velocity. Throws std::invalid_argument for an unknown or non-dynamic body, or a
/// state of the wrong size.
void SetBodyPose(const Scene& scene, const std::string& body, const Isometry3d& X_WB, State* x);
/// Planar scenes: sets (x, y, θ) exactly as given (θ is not wrapped, unlike a pose's angle).
void SetPlanarBodyPose(const Scene& scene, const std::string& body, double x, double y,
                       double theta, State* state);

/// Sets a dynamic body's block of ν from the world-frame velocity of its origin v_W (m/s) and
/// its angular velocity w_W (rad/s): planar (v_W.x, v_W.y, w_W.z); spatial (v_W, R_WBᵀ w_W)
/// with R_WB from the body's pose in x->q. Planar scenes ignore v_W.z, w_W.x and w_W.y.
void SetBodyVelocity(const Scene& scene, const std::string& body, const Vector3d& v_W,
                     const Vector3d& w_W, State* x);

/// A 64-bit FNV-1a hash of the exact bits of x.t, x.q, x.v and x.warm_start (with their sizes):
/// equal states hash equal, and the value is the same on every run and platform (each double's
/// IEEE-754 bit pattern is hashed little-endian). Bitwise, not numeric: −0.0 and 0.0 differ.
/// For replay checks: a replayed rollout is bit-identical iff the hashes of its states match
/// (up to hash collisions).
std::uint64_t StateHash(const State& x);

}  // namespace vinci::sim
