// Bilateral joint constraints ψ_b(q, t) = 0 and their Jacobians (docs/formulations.md notation).
#pragma once

#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// Number of scalar constraints of a joint type in a scene dimension. Throws
/// std::invalid_argument for a type that does not exist in that dimension (planar: revolute,
/// prismatic, weld; spatial: revolute, prismatic, spherical, fixed).
int JointRowCount(JointType type, Dim dim);

/// Constraint values and Jacobians of one joint at the given body kinematics.
/// d/dt ψ = J_a ν_a + J_b ν_b exactly at the evaluation point (ν in the convention of
/// kinematics.h). For b = world, pass identity kinematics for B (X_BJ is then X_WJ).
struct JointRows {
  VectorXd psi;  ///< m (translations) or rad (rotations); size JointRowCount
  MatrixXd J_a;  ///< rows × VelocitySize(dim)
  MatrixXd J_b;  ///< rows × VelocitySize(dim)
};
void EvaluateJoint(const Joint& joint, Dim dim, const BodyKinematics& A, const BodyKinematics& B,
                   JointRows* rows);

}  // namespace vinci::sim
