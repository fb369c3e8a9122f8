// Finite-difference derivatives of one step and of a rollout with respect to chosen parameters
// (and optionally the initial state): the baseline that exact step sensitivities are checked
// against (issue 12 item 6).
//
// Central differences, column i:  D_i = (y(θ + h_i e_i) − y(θ − h_i e_i)) / (2 h_i),
//   h_i = max(relative_step · |θ_i|, min_step)      (state entries: relative to |x_i|)
// with common random numbers: the + and − runs start from the same state (including its warm
// start) and use the same inputs, each with a fresh Workspace, so the two runs differ only in
// θ_i. Where θ_i ± h_i leaves the parameter's admissible range the difference is one-sided
// against the nominal run (flagged). A column whose + or − run failed a step is NaN and flagged;
// a column where either run's contact count differs from the nominal run's at some step is
// flagged `contact_set_changed` (the derivative then spans a contact-mode change and is not a
// derivative of one smooth branch).
#pragma once

#include <functional>
#include <vector>

#include "vinci/sim/model/params.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {

struct FiniteDifferenceOptions {
  double relative_step = 1e-6;  ///< h_i relative to |θ_i| (or |x_i|); > 0
  double min_step = 1e-8;       ///< lower bound of h_i; > 0
  /// Also differentiate with respect to the initial state: columns [q_0 (nq); ν_0 (nv)] after
  /// the parameters (raw coordinates; a spatial body's quaternion entries are perturbed as they
  /// are, the pose map normalizes them).
  bool initial_state = false;
};

/// A finite-difference Jacobian and what happened in its runs.
struct FiniteDifference {
  VectorXd value;               ///< the output at the nominal point
  MatrixXd jacobian;            ///< outputs × columns (selection order, then the state if asked)
  VectorXd steps;               ///< h_i per column
  std::vector<bool> one_sided;  ///< per column: a bound forced a one-sided difference
  std::vector<bool> contact_set_changed;  ///< per column (see the file comment)
  std::vector<bool> failed;               ///< per column: a perturbed run failed (column NaN)
  bool nominal_ok = true;                 ///< the nominal run succeeded (else nothing else is set)
  std::string failure;                    ///< the nominal run's failure
  /// Nominal run ok, no failed column and no contact-set change.
  bool clean() const;
};

/// Output of a rollout to be differentiated; null means the final state [q_N; ν_N].
using RolloutOutput = std::function<VectorXd(const Trajectory&)>;

/// ∂[q_ℓ+1; ν_ℓ+1]/∂(θ_sel[, x_ℓ]) of one Simulator::Step from x with input u. `selection` must be
/// built from sim.scene().param_table(). Throws std::invalid_argument for bad sizes or options.
FiniteDifference StepDerivativeFd(const Simulator& sim, const Params& params,
                                  const ParamSelection& selection, const State& x,
                                  const StepInput& u, const FiniteDifferenceOptions& options = {});

/// ∂output/∂(θ_sel[, x_0]) of sim.Rollout(params, x0, inputs). `output` may be null (final
/// state). A perturbed rollout that stops early counts as failed.
FiniteDifference RolloutDerivativeFd(const Simulator& sim, const Params& params,
                                     const ParamSelection& selection, const State& x0,
                                     const std::vector<StepInput>& inputs,
                                     const RolloutOutput& output = nullptr,
                                     const FiniteDifferenceOptions& options = {});

}  // namespace vinci::sim
