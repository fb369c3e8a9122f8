// Simulation state, per-step inputs and per-step reports.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/motion.h"
#include "vinci/sim/solvers/solver_report.h"
#include "vinci/sim/types.h"

namespace vinci::sim {

/// Everything a step depends on besides the scene and params — including the solver warm
/// start, so that Step and Rollout are pure functions of their arguments.
struct State {
  double t = 0.0;       ///< s
  VectorXd q;           ///< positions of the dynamic bodies (Scene::index(b).q)
  VectorXd v;           ///< velocities of the dynamic bodies (Scene::index(b).v)
  VectorXd warm_start;  ///< last step's complementarity solution (may be empty); what it holds
                        ///< per formulation and how rollouts use it: WarmStartPolicy
                        ///< (simulator/options.h)
};

/// Per-step input: generalized forces added to the scene's applied forces, and motions that
/// replace prescribed bodies' scene motions for this step (motion_input.h).
struct StepInput {
  VectorXd generalized_force;        ///< size num_velocities() or empty (= 0); N, N·m (body frame
                                     ///< torques for spatial bodies, as ν is)
  std::vector<MotionInput> motions;  ///< at most one per prescribed body; empty: scene motions
};

/// How a step ended (StepInfo::status). Every failure leaves the output state equal to the input.
enum class StepStatus {
  kOk,              ///< solved; the next state is finite and within max_penetration
  kPenetration,     ///< a gap below −max_penetration at the start or the end of the step
  kSolverFailed,    ///< the complementarity solver did not converge
  kNonFinite,       ///< the solution or the next state (t, q or v) is not finite
  kGeometryFailed,  ///< contact detection failed (closest points of implicit surfaces)
};

/// "ok", "penetration", "solver failed", "non-finite", "geometry failed".
const char* ToString(StepStatus status);

/// What one step did.
struct StepInfo {
  bool ok = false;                                ///< status == StepStatus::kOk
  StepStatus status = StepStatus::kSolverFailed;  ///< why the step failed, kOk if it did not
  int contacts = 0;                               ///< contacts in the step's LCP
  int joint_rows = 0;                             ///< bilateral constraint rows
  double min_gap = 0.0;  ///< smallest ψ_n at the start of the step (m); 0 if no contact
  SolverReport solver;   ///< the complementarity solve
  std::string failure;   ///< reason when !ok
};

/// A rollout: states[0] is x0, states[k+1] follows from states[k] by step k.
/// A failed step stops the rollout: steps.back() records it and states has one entry fewer.
/// With RolloutOptions::record_every = r > 1, states[i] is the state after i·r steps, except
/// that the final state (after the last successful step) is always the last entry.
struct Trajectory {
  std::vector<State> states;
  std::vector<StepInfo> steps;
  bool ok = true;
  std::string failure;
  bool stopped = false;  ///< ended by RolloutOptions::stop (ok stays true)
  int record_every = 1;  ///< RolloutOptions::record_every
};

}  // namespace vinci::sim
