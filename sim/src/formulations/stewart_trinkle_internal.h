// Helpers shared by the two halves of the Stewart–Trinkle stepper: stewart_trinkle.cc (assembly
// and the step) and stewart_trinkle_residuals.cc (Layout, Evaluate: the step model). Private.
#pragma once

#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim::internal {

/// Pose of a prescribed body at t under its PoseRule (exact, or integrated with the step h).
BodyKinematics PrescribedKinematics(const Scene& model, int body, double t, double h);

/// Throws std::invalid_argument for a scene with a shape this stepper cannot collide (the smooth
/// GI-only kinds), so the error does not depend on whether such a shape is near another one.
void CheckShapesSupported(const Scene& model);

}  // namespace vinci::sim::internal
