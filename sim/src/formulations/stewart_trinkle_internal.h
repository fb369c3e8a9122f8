// Helpers shared by the parts of the Stewart–Trinkle stepper: stewart_trinkle.cc (assembly
// and the step), stewart_trinkle_lcp.cc (the LCP, the velocity update) and
// stewart_trinkle_residuals.cc (Layout, Evaluate: the step model). Private.
#pragma once

#include "sparse_rows.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim::internal {

/// Pose of a prescribed body at t under its PoseRule (exact, or integrated with the step h).
BodyKinematics PrescribedKinematics(const Scene& model, int body, double t, double h);

/// Throws std::invalid_argument for a scene with a shape this stepper cannot collide (the smooth
/// GI-only kinds), so the error does not depend on whether such a shape is near another one.
void CheckShapesSupported(const Scene& model);

/// At an assembly `a` of x without joints, corners, support points or compliant pairs: the step
/// LCP's w = M z + q (BuildLcpInto's rows, formed through ν_after, no M formed) and ν_after =
/// ν* + W G z into *v1.
void PlainLcpAtInto(const StewartTrinkle& st, const StewartTrinkle::Assembly& a, const State& x,
                    const VectorXd& z, VectorXd* w, VectorXd* v1);

// ν_ℓ+1 = ν* + W G_c p_c (+ the joints' correction) into *v1, with the intermediate vectors in
// *impulse, *product and *dv (their storage reused): StewartTrinkle::VelocityAfter's body.
void VelocityAfterWith(const StewartTrinkle::Assembly& a, const VectorXd& v_star, const VectorXd& z,
                       const StewartTrinkle::JointElimination& joints, VectorXd* impulse,
                       VectorXd* product, VectorXd* dv, VectorXd* v1);

/// StewartTrinkle::EvaluateAssembly into *r, its storage reused (every field overwritten; the
/// same numbers). Without `jacobians` the d_ matrices are left empty; with `sparse` the
/// Jacobians (the same entries) go to *sparse by rows and r's d_ matrices are left empty.
/// `normal_pairs_only`: of the pairs' Jacobians only the normal rows' b side is written (the
/// other rows empty, every value still computed): what the NCP stepper's equations read.
void EvaluateAssemblyInto(const StewartTrinkle& st, const Scene& model, const Params& params,
                          const StewartTrinkle::Assembly& a, const State& x, const VectorXd& z,
                          bool jacobians, StepResiduals* r, SparseJacobians* sparse = nullptr,
                          bool normal_pairs_only = false);

}  // namespace vinci::sim::internal
