// Exact step sensitivities by implicit differentiation of the step's complementarity problem,
// and rollout gradients (forward and reverse mode). docs/sensitivity.md.
//
// A step from x_ℓ solves F(z, θ, x_ℓ) = 0 (the equality rows) and 0 ≤ a(z, θ, x_ℓ) ⊥ b(z, θ,
// x_ℓ) ≥ 0 (the complementarity pairs) for the unknowns z = [q_ℓ+1; ν_ℓ+1; impulses...] of the
// contact set found at x_ℓ — the formulation's own equations, through the frozen step model
// (formulations/step_model.h). At the step's solution z* each pair i is
//   a-active   a_i = 0 < b_i   (held: da_i = 0),
//   b-active   b_i = 0 < a_i   (held: db_i = 0),
//   degenerate a_i = b_i = 0   (weakly active: a contact just touching, a friction cone edge,
//                               a sticking contact's unloaded friction directions).
// Without degenerate pairs the active equations K dz = −(∂_θ r dθ + ∂_x r dx) define z, hence
// x_ℓ+1 = [q_ℓ+1; ν_ℓ+1], as a smooth function of (θ, x_ℓ): the derivative is exact (implicit
// function theorem). With degenerate pairs D the solution map is only directionally
// differentiable; its derivative along a direction d is the solution of the sensitivity LCP
//   K̃ dz = −r_d + E_D λ,   0 ≤ λ ⊥ B_D dz + r_b,D ≥ 0,        λ = da_D,
// (K̃: the equality rows, the held rows and the rows a_D) — exact along +d, one-sided: the
// derivative along −d may differ. `DegenerateRule` selects that or a fixed branch.
//
// K is factored structurally (singleton rows and columns eliminated, the core by LU with complete
// pivoting, a rank-deficient core by the complete orthogonal decomposition): with redundant
// contacts (a box's four corners on a plane) the impulses are not unique, the state's derivative
// still is when the system is consistent, which is checked per column. Where the solver's split
// of such impulses puts a contact at its friction cone edge, the derivative is taken at a split
// moved inside the solution set along K's null space (docs/sensitivity.md).
//
// Parameter columns: friction coefficients, support friction and masses (ParamInfo::
// differentiable) through the step equations' analytic θ columns; motion and tilt parameters of
// prescribed bodies (velocity, amplitude, frequency, phase) by central differences of the step
// equations re-evaluated with the contact set re-detected at x_ℓ (exact up to O(h²) as long as
// the contact set does not change, which is flagged). Sizes and poses are rejected: they move
// the contact set itself. The state columns [q_ℓ; ν_ℓ] are raw coordinates (a spatial body's
// quaternion entries as they are), as in finite_difference.h. Formulations: Stewart–Trinkle,
// Anitescu–Potra, first order, NCP, quasistatic and geometrically implicit (its mixed NCP with
// the candidate pairs found at x_ℓ; its end state depends on x_ℓ explicitly, R_ℓ+1 = R_ℓ Exp(φ),
// which the state columns include; contacts made within a GI step are its own pairs, so GI steps
// are never flagged kModeChange; an unloaded GI pair, p_n = p_t = 0, is held at dσ = dp_t = 0
// and not counted as degenerate).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "vinci/sim/model/params.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {

/// How one step's derivative was obtained.
enum class SensitivityStatus {
  kExact,       ///< strictly complementary: the derivative of the smooth solution map
  kDegenerate,  ///< weakly active pairs: one-sided derivatives (see DegenerateRule)
  kModeChange,  ///< the contact set found at x_ℓ+1 differs from the one at x_ℓ, or a motion
                ///< column's difference changed the contact set: the derivative is of the
                ///< step's branch at x_ℓ, and a mode change lies within the step
  kFailed,      ///< the step failed, or its active system is inconsistent: columns are NaN
};
/// "exact", "degenerate", "mode_change", "failed".
const char* SensitivityStatusName(SensitivityStatus status);

/// What to return where the active set is degenerate.
enum class DegenerateRule {
  /// Per column, the directional derivative along +column (the sensitivity LCP on the
  /// degenerate pairs, solved by Lemke): exact one-sided.
  kDirectional,
  /// Every degenerate pair held at a_i = 0 (the multiplier side stays at its bound).
  kHoldA,
  /// Every degenerate pair held at b_i = 0 (the constraint side stays active).
  kHoldB,
};

struct SensitivityOptions {
  DegenerateRule degenerate = DegenerateRule::kDirectional;
  /// A pair is degenerate if a_i and b_i are both ≤ active_tol · max(‖a‖∞, ‖b‖∞) + 10 · (the
  /// step equations' violation at the solution). In (0, 1).
  double active_tol = 1e-9;
  /// ε > 0: return the derivative of the smoothed step instead, the solution of the equality
  /// rows and a_i + b_i − √(a_i² + b_i² + 2ε) = 0 (a_i b_i = ε, a, b > 0) found by Newton from
  /// the step's solution. Smooth across mode changes, biased by O(√ε) (docs/sensitivity.md).
  double smoothing = 0.0;
  /// Relative central-difference step of the state block (frozen equations, smooth in x_ℓ).
  double state_step = 1e-7;
  /// Relative central-difference step of motion parameters (max(step·|θ|, step)).
  double motion_step = 1e-6;
  /// PropagateStep and StepDerivatives on a Stewart–Trinkle-family step on plain contacts whose
  /// LCP solution is clear of mode boundaries (sliding, sticking strictly inside the cone,
  /// separated), friction coefficients selected: the derivative on the step LCP's basic block
  /// instead of the whole step system's linearization — the same derivative to the central
  /// differences' error, at a fraction of the cost (docs/sensitivity.md). false: always the general
  /// path.
  bool lcp_basis = true;
};

/// ∂x_ℓ+1/∂x_ℓ and ∂x_ℓ+1/∂θ of one step, x = [q; ν].
struct StepSensitivity {
  SensitivityStatus status = SensitivityStatus::kFailed;
  MatrixXd d_x;      ///< (nq + nv) × (nq + nv); empty if not requested
  MatrixXd d_theta;  ///< (nq + nv) × selection size
  int degenerate_pairs = 0;
  /// Columns whose sensitivity LCP Lemke could not solve (their λ = 0 branch is returned).
  int unsolved_columns = 0;
  /// Columns whose held active set stays feasible only for perturbations below 1e-6 of the
  /// column variable (a near-singular active block whose impulse split the solver form's small
  /// compliances decide, e.g. a GI sphere resting between two spheres): the derivative is that
  /// of the step's own branch, which any practically perturbed step has left. The step is
  /// flagged kDegenerate.
  int near_kink_columns = 0;
  /// Contacts at a feature switch of the contact geometry (StepModel::feature_kinks(): a box's
  /// vertex on another box's face edge or vertex, e.g. flush equal boxes): the derivative is
  /// that of the features the collision routine chose at x_ℓ (held fixed); a move of x_ℓ by
  /// ~1e-6 m can make it report others. The step is flagged kDegenerate.
  int feature_kink_contacts = 0;
  bool contact_set_changed = false;
  /// The derivative was taken on the step LCP's basis (SensitivityOptions::lcp_basis).
  bool on_lcp_basis = false;
  std::string message;  ///< what was degenerate, changed or failed
};

/// Names a selection may hold: the differentiable parameters and the motion/tilt parameters of
/// prescribed bodies, in table order.
std::vector<std::string> SensitivityParameterNames(const ParamTable& table);

/// The derivatives of the step sim.Step(params, x, u) → next (`next` as that step returned it;
/// it must have succeeded). `with_state`: also ∂x_ℓ+1/∂x_ℓ (2 (nq + nv) extra evaluations of the
/// frozen equations). `ws`: a workspace to resolve the scene in (the step's own avoids a copy
/// of the scene; null: a local one). Throws std::invalid_argument for a selection entry that is
/// neither differentiable nor a motion parameter, or mismatched sizes.
StepSensitivity StepDerivatives(const Simulator& sim, const Params& params,
                                const ParamSelection& selection, const State& x, const StepInput& u,
                                const State& next, bool with_state,
                                const SensitivityOptions& options = {}, Workspace* ws = nullptr);

/// One forward-mode step: S_next = ∂x_ℓ+1/∂θ_sel [E; 0] + ∂x_ℓ+1/∂x_ℓ S for the step x → next
/// (`next` from sim.Step(params, x, u)), S = ∂x_ℓ/∂(columns): (nq + nv) × m with m ≥ selection
/// size, the first selection-size columns belonging to the parameters in order (further columns,
/// e.g. initial-state directions, have no explicit θ part). Each column is the directional
/// derivative along it. Returns the step's status (matrices left empty). `ws` as for
/// StepDerivatives.
StepSensitivity PropagateStep(const Simulator& sim, const Params& params,
                              const ParamSelection& selection, const State& x, const StepInput& u,
                              const State& next, const MatrixXd& S, MatrixXd* S_next,
                              const SensitivityOptions& options = {}, Workspace* ws = nullptr);

/// Forward mode: x_k's derivatives along a rollout.
struct RolloutSensitivity {
  Trajectory trajectory;  ///< the rollout itself (every state recorded)
  /// d_state[k] = ∂x_k/∂(θ_sel[, x_0]), (nq + nv) × columns; d_state[0] = [0 | I].
  std::vector<MatrixXd> d_state;
  std::vector<StepSensitivity> steps;  ///< per step: status and flags (matrices left empty)
  int exact_steps = 0, degenerate_steps = 0, mode_change_steps = 0, failed_steps = 0;
};

/// Propagates S_ℓ+1 = ∂x_ℓ+1/∂θ + ∂x_ℓ+1/∂x_ℓ S_ℓ through sim.Rollout's steps (warm started as
/// Rollout does). Each column is a directional derivative along that column, so degenerate
/// steps compose exactly along it. `initial_state`: columns for x_0 after the parameters.
RolloutSensitivity RolloutForward(const Simulator& sim, const Params& params,
                                  const ParamSelection& selection, const State& x0,
                                  const std::vector<StepInput>& inputs, bool initial_state,
                                  const SensitivityOptions& options = {});

/// A scalar outcome of the final state and its gradient with respect to [q_N; ν_N].
using TerminalObjective = std::function<double(const State& x_N, VectorXd* gradient)>;

/// Reverse mode: the gradient of objective(x_N) with respect to θ_sel and x_0.
struct RolloutGradient {
  double value = 0.0;
  VectorXd d_theta;  ///< selection size
  VectorXd d_x0;     ///< nq + nv
  bool ok = false;   ///< the rollout succeeded and no step failed to differentiate
  std::string failure;
  int exact_steps = 0, degenerate_steps = 0, mode_change_steps = 0, failed_steps = 0;
};

/// λ_N = ∂g/∂x_N; λ_ℓ = (∂x_ℓ+1/∂x_ℓ)ᵀ λ_ℓ+1, ∇_θ g = Σ_ℓ (∂x_ℓ+1/∂θ)ᵀ λ_ℓ+1, with each step's
/// Jacobians from StepDerivatives (at degenerate steps the columns are one-sided along +e_j).
RolloutGradient RolloutReverse(const Simulator& sim, const Params& params,
                               const ParamSelection& selection, const State& x0,
                               const std::vector<StepInput>& inputs,
                               const TerminalObjective& objective,
                               const SensitivityOptions& options = {});

}  // namespace vinci::sim
