// What the calling thread's last Stewart–Trinkle-family step assembled (internal header), so
// that the step derivative's frozen model (step_model.h) reuses that assembly instead of
// assembling the same step again. The NCP stepper keeps a StepRecord of its own step's assembly
// the same way (ncp_internal.h).
//
// The step assembles into its thread's StepScratch (sparse_lcp.h) and stamps the scratch's
// StepRecord with what the assembly is a function of: the formulation, the scene, x (t, q, ν)
// and the input force (the input's motions are part of the scene). Simulator::Step then names
// the scene's owner (the workspace's shared scene): a scene is identified by its owner, not by
// its address, which a later scene may reuse. A derivative on the same thread, with the same
// owner, x and u bitwise, may copy the assembly (FreezeInto); anything else assembles again.
#pragma once

#include <memory>

#include "sparse_rows.h"
#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/formulations/stewart_trinkle.h"

namespace vinci::sim::internal {

struct StepRecord {
  bool valid = false;  // the key below describes the scratch's assembly
  const StewartTrinkle* formulation = nullptr;
  const Scene* model = nullptr;
  std::weak_ptr<const Scene> owner;  // set by Simulator::Step (StampStepOwner)
  double t = 0.0;
  VectorXd q, v, force;

  /// Before the step assembles: nothing is held.
  void Clear() {
    valid = false;
    owner.reset();
  }
  /// After the step assembled AssembleInto(m, x, u) with `st` (x, u copied into kept storage).
  void Stamp(const StewartTrinkle& st, const Scene& m, const State& x, const StepInput& u) {
    formulation = &st;
    model = &m;
    t = x.t;
    q = x.q;
    v = x.v;
    force = u.generalized_force;
    valid = true;
  }
  /// The assembly is AssembleInto(*scene, x, u) of `st`.
  bool Holds(const StewartTrinkle& st, const std::shared_ptr<const Scene>& scene, const State& x,
             const StepInput& u) const {
    return valid && formulation == &st && model == scene.get() && !owner.expired() &&
           !owner.owner_before(scene) && !scene.owner_before(owner) && t == x.t && Same(q, x.q) &&
           Same(v, x.v) && Same(force, u.generalized_force);
  }

 private:
  static bool Same(const VectorXd& a, const VectorXd& b) {
    return a.size() == b.size() && (a.array() == b.array()).all();
  }
};

/// Drops the calling thread's step record (Simulator::Step, before the step): after the step
/// the record is valid only if that step made it, whatever the formulation.
void ClearStepRecord();
/// Names `scene` as the owner of the calling thread's step record if its last step was
/// assembled on *scene (Simulator::Step, after the step).
void StampStepOwner(const std::shared_ptr<const Scene>& scene);

/// The calling thread's last step's assembly if it is AssembleInto(*scene, x, u) of `st` (its
/// StepRecord holds it), else null. Valid until the thread's next Stewart–Trinkle-family step.
const StewartTrinkle::Assembly* StepAssembly(const StewartTrinkle& st,
                                             const std::shared_ptr<const Scene>& scene,
                                             const State& x, const StepInput& u);

/// *frozen = Freeze(formulation, model, params, x, u): the same model (same results), made
/// cheaper for the Stewart–Trinkle family: where *frozen already holds a model of this
/// formulation its storage is reused, and where the calling thread's last step assembled
/// (*model, x, u) (its StepRecord) that assembly is copied instead of assembled again; where
/// *frozen is already that model, frozen at (*model, params, x, u) bitwise, it is kept.
void FreezeInto(const Formulation& formulation, std::shared_ptr<const Scene> model,
                const Params& params, const State& x, const StepInput& u,
                std::unique_ptr<StepModel>* frozen);

/// The values of m.EvaluateResiduals(z, θ, x, u, true) in *out and its Jacobians by rows in
/// *jac (out's d_ matrices unspecified), storage reused; a Stewart–Trinkle-family model evaluated
/// at its freeze point writes the Jacobians by rows directly (no dense matrices).
void EvaluateResidualsInto(const StepModel& m, const VectorXd& z, const Params& theta,
                           const State& x, const StepInput& u, StepResiduals* out,
                           SparseJacobians* jac);
/// *out = m.StateDirectionalDerivative(z, u, s, step), the same numbers, in storage reused for
/// the Stewart–Trinkle family.
void StateDirectionalDerivativeInto(const StepModel& m, const VectorXd& z, const StepInput& u,
                                    const VectorXd& s, double step, StepResiduals* out);

/// The frozen Stewart–Trinkle-family model's assembly at its freeze point (x_ℓ, the step's
/// contacts); null for other formulations.
const StewartTrinkle::Assembly* FrozenAssembly(const StepModel& m);
/// The LCP's w = M z + q (StewartTrinkle::BuildLcpInto's M and q) and ν_ℓ+1 = VelocityAfter for
/// the impulses z, for the frozen model moved to x_ℓ + t s — its contacts moved along s as
/// StateDirectionalDerivative moves them, assembled there; t = 0: the freeze's own assembly. For a
/// Stewart–Trinkle-family model on plain contacts
/// (no joints, corners, support points or compliant pairs; false otherwise, nothing written),
/// without forming M: BuildLcpInto's rows through ν_ℓ+1 = ν* + W G z — G_nᵀ ν_ℓ+1 +
/// ∂ψ_n/∂t (+ ψ_n/h but for Anitescu–Potra), G_fᵀ ν_ℓ+1 + ∂ψ_f/∂t + E σ, U p_n − Eᵀ p_f.
bool PlainLcpAlongInto(const StepModel& m, const StepInput& u, const VectorXd& s, double t,
                       const VectorXd& z, VectorXd* w, VectorXd* v1);

}  // namespace vinci::sim::internal
