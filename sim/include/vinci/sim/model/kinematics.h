// Body-level kinematic maps shared by contacts, joints and the integrator.
//
// Velocity convention (one for the whole code base): a planar body's ν = (vx, vy, ω); a spatial
// body's ν = (v_W ∈ R³, ω_B ∈ R³) — linear velocity of the origin in world frame, angular
// velocity in the BODY frame. The body origin is its centre of mass.
#pragma once

#include "vinci/sim/model/motion.h"
#include "vinci/sim/types.h"

namespace vinci::sim {

/// Row r such that r · ν_B = d · (velocity of the material point at p_W), i.e. the wrench column
/// [d; r × d] of docs/formulations.md expressed in the body's ν coordinates (size 3 or 6).
/// Planar: (d.x, d.y, (p − c) × d). Spatial: (d, R_WBᵀ((p − c) × d)). At most 6 entries, held
/// inline (no heap allocation).
using PointVelocityRowType = Eigen::Matrix<double, 1, Eigen::Dynamic, Eigen::RowMajor, 1, 6>;
PointVelocityRowType PointVelocityRow(Dim dim, const Isometry3d& X_WB, const Vector3d& p_W,
                                      const Vector3d& d_W);

/// ν of a prescribed/static body from its world kinematics, in the convention above.
VectorXd BodyVelocity(Dim dim, const BodyKinematics& k);

/// Velocity of a material point at p_W of a body with world kinematics k.
inline Vector3d PointVelocity(const BodyKinematics& k, const Vector3d& p_W) {
  return k.v_WB + k.w_WB.cross(p_W - k.X_WB.translation());
}

/// Pose of a dynamic body from its block of q: planar (x, y, θ), spatial (p, qw, qx, qy, qz).
Isometry3d PoseFromQ(Dim dim, const double* q);
/// World kinematics of a dynamic body from its blocks of q and ν.
BodyKinematics KinematicsFromQV(Dim dim, const double* q, const double* v);
/// The same into *k (every field written).
void KinematicsFromQV(Dim dim, const double* q, const double* v, BodyKinematics* k);
/// Writes a pose into a q block (quaternion with qw ≥ 0 is not enforced; it is normalized).
void PoseToQ(Dim dim, const Isometry3d& X_WB, double* q);
/// Writes world velocities into a ν block.
void VelocityToV(Dim dim, const Isometry3d& X_WB, const Vector3d& v_W, const Vector3d& w_W,
                 double* v);

/// Kinematic update q⁺ = q + h G(q) ν for one body: planar exactly linear; spatial
/// p⁺ = p + h v, quaternion⁺ = quaternion ⊗ exp(h ω_B / 2), renormalized.
void IntegratePosition(Dim dim, const double* q, const double* v, double h, double* q_next);

}  // namespace vinci::sim
