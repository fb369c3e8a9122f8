// The NCP stepper's internals shared with its frozen step model (internal): the step equations
// with their Jacobians by rows, for NcpStepper::EvaluateAssembly (dense) and the model's
// sensitivities (sparse), and the step's record of its assembly.
#pragma once

#include <memory>

#include "sparse_rows.h"
#include "vinci/sim/formulations/ncp.h"

namespace vinci::sim::internal {

/// NcpStepper::EvaluateAssembly into *r (its storage reused; r's d_ matrices left empty), the
/// Jacobians (columns [z; θ], the same entries) by rows into *jac; values only if jac is null.
void NcpEvaluateAssemblyInto(const NcpStepper& ncp, const Scene& model, const Params& params,
                             const StewartTrinkle::Assembly& a, const State& x, const VectorXd& z,
                             StepResiduals* r, SparseJacobians* jac);

/// The NCP stepper's step record (step_record.h), kept with its per-thread step storage: cleared
/// and stamped with its owner by Simulator::Step (ClearStepRecord, StampStepOwner) as the
/// Stewart–Trinkle family's.
void ClearNcpStepRecord();
void StampNcpStepOwner(const std::shared_ptr<const Scene>& scene);
/// *out = the calling thread's last NCP step's assembly if that step was `ncp`'s on (*scene, x,
/// u) (its record holds it): true; else false, *out untouched.
bool CopyNcpStepAssembly(const NcpStepper& ncp, const std::shared_ptr<const Scene>& scene,
                         const State& x, const StepInput& u, StewartTrinkle::Assembly* out);

}  // namespace vinci::sim::internal
