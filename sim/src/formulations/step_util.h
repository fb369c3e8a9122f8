// Shared end-of-step bookkeeping of the steppers (internal header).
#pragma once

#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim::internal {

/// Writes the end-of-step state from the solved velocity: t + h, ν_ℓ+1 = v1,
/// q_ℓ+1 = q_ℓ + h G(q_ℓ) ν_ℓ+1 per dynamic body (IntegratePosition), and the solver warm start.
/// Returns false, with info->failure and a numerical-failure status set and *next untouched, if
/// v1 is not finite.
inline bool CompleteStep(const Scene& model, const State& x, const VectorXd& v1, double h,
                         VectorXd warm_start, State* next, StepInfo* info) {
  if (!v1.allFinite()) {
    info->failure = "non-finite velocity after the step";
    info->solver.status = SolverStatus::kNumericalFailure;
    return false;
  }
  next->t = x.t + h;
  next->v = v1;
  next->q.resize(x.q.size());
  for (int bi : model.dynamic_bodies()) {
    const BodyIndex& idx = model.index(bi);
    IntegratePosition(model.dim, x.q.data() + idx.q, v1.data() + idx.v, h, next->q.data() + idx.q);
  }
  next->warm_start = std::move(warm_start);
  return true;
}

}  // namespace vinci::sim::internal
