// Jacobians of a least-squares shooting segment by forward step sensitivities
// (sim/simulator/sensitivity.h, docs/sensitivity.md) instead of finite differences of rollouts.
// Not installed.
//
// A segment is rolled out from x_0 = X(s) (StateFromVector; s the segment's start-state
// unknowns) with the scene's dt, every step cold-started (as RolloutResiduals). Along the rollout
// the forward-mode sensitivities S_ℓ = ∂x_ℓ/∂(θ, s) (x = [q; ν] raw) are propagated,
// S_ℓ+1 = ∂x_ℓ+1/∂θ [E; 0] + ∂x_ℓ+1/∂x_ℓ S_ℓ, S_0 = [0 | ∂X/∂s], each column a directional
// derivative (exact where the step's contact mode is fixed, one-sided at degenerate steps). The
// observations are smooth functions of the bracketing states (linear interpolation, slerp,
// rotation logarithms): their derivatives along each column of S are central differences of
// those functions (no simulation), as is ∂X/∂s. Spatial quaternions are renormalized after a
// perturbation, so only their rotation is differentiated.
#pragma once

#include <string>

#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation::internal {

/// Outcome of SegmentSensitivity.
enum class SegmentSensitivityStatus {
  kOk,
  kRolloutFailed,      ///< a step failed: no residuals (as RolloutResiduals)
  kSensitivityFailed,  ///< a step's derivative failed (NaN): residuals valid, Jacobian not
};

struct SegmentSensitivityResult {
  SegmentSensitivityStatus status = SegmentSensitivityStatus::kRolloutFailed;
  sim::VectorXd measured;    ///< the first measured_rows residuals (EpisodeResiduals layout)
  sim::MatrixXd d_measured;  ///< measured_rows × (θ, s)
  sim::VectorXd end;         ///< `next`'s state unknowns of the rollout at next->t.front()
  sim::MatrixXd d_end;       ///< end's rows × (θ, s)
  int mode_change_steps = 0, degenerate_steps = 0;
  std::string failure;
};

/// Rolls out the segment `ep` (from t.front() to t.back()) with `params` from
/// StateFromVector(sim, ep, ref, s) and returns the residuals of its first `measured_rows`
/// rows, the state unknowns (of `next`'s references) at next->t.front() if `next` is not null,
/// and their Jacobians with respect to (θ of `selection`, s) — the s columns only if
/// `with_state` (else only θ's columns). Throws std::invalid_argument where step sensitivities
/// are not available (the geometrically implicit stepper, a selection entry they cannot
/// differentiate).
SegmentSensitivityResult SegmentSensitivity(const sim::Simulator& sim,
                                            const sim::ParamSelection& selection,
                                            const sim::Params& params, const Episode& ep,
                                            const sim::State& ref, const sim::VectorXd& s,
                                            bool with_state, int measured_rows, const Episode* next,
                                            double orientation_length);

}  // namespace vinci::estimation::internal
