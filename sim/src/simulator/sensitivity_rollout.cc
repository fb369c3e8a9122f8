// Rollout gradients: forward mode (RolloutForward) and reverse mode (RolloutReverse) over the
// step derivatives of sensitivity.cc.
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "sensitivity_internal.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {

using internal::CheckSelection;
using internal::Count;

RolloutSensitivity RolloutForward(const Simulator& sim, const Params& params,
                                  const ParamSelection& selection, const State& x0,
                                  const std::vector<StepInput>& inputs, bool initial_state,
                                  const SensitivityOptions& options) {
  CheckSelection(sim, selection);
  const int nx = static_cast<int>(x0.q.size() + x0.v.size());
  const int ncols = selection.size() + (initial_state ? nx : 0);
  RolloutSensitivity out;
  MatrixXd S = MatrixXd::Zero(nx, ncols), S1;
  if (initial_state) S.rightCols(nx).setIdentity();
  out.d_state.push_back(S);
  out.trajectory.states.push_back(x0);
  Workspace ws;
  State x = x0, next;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    StepInfo info = sim.Step(params, x, inputs[k], &ws, &next);
    const bool ok = info.ok;
    out.trajectory.steps.push_back(std::move(info));
    if (!ok) {
      out.trajectory.ok = false;
      out.trajectory.failure =
          "step " + std::to_string(k) + ": " + out.trajectory.steps.back().failure;
      break;
    }
    StepSensitivity st =
        PropagateStep(sim, params, selection, x, inputs[k], next, S, &S1, options, &ws);
    Count(st.status, &out.exact_steps, &out.degenerate_steps, &out.mode_change_steps,
          &out.failed_steps);
    out.steps.push_back(std::move(st));
    S = S1;
    out.d_state.push_back(S);
    out.trajectory.states.push_back(next);
    std::swap(x, next);
  }
  return out;
}

RolloutGradient RolloutReverse(const Simulator& sim, const Params& params,
                               const ParamSelection& selection, const State& x0,
                               const std::vector<StepInput>& inputs,
                               const TerminalObjective& objective,
                               const SensitivityOptions& options) {
  CheckSelection(sim, selection);
  if (!objective) throw std::invalid_argument("RolloutReverse: null objective");
  const int nx = static_cast<int>(x0.q.size() + x0.v.size());
  RolloutGradient out;
  std::vector<MatrixXd> dx, dtheta;
  dx.reserve(inputs.size());
  dtheta.reserve(inputs.size());
  Workspace ws;
  State x = x0, next;
  bool failed = false;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    const StepInfo info = sim.Step(params, x, inputs[k], &ws, &next);
    if (!info.ok) {
      out.failure = "step " + std::to_string(k) + ": " + info.failure;
      return out;
    }
    StepSensitivity st =
        StepDerivatives(sim, params, selection, x, inputs[k], next, true, options, &ws);
    Count(st.status, &out.exact_steps, &out.degenerate_steps, &out.mode_change_steps,
          &out.failed_steps);
    failed = failed || st.status == SensitivityStatus::kFailed;
    dx.push_back(std::move(st.d_x));
    dtheta.push_back(std::move(st.d_theta));
    std::swap(x, next);
  }
  VectorXd lambda = VectorXd::Zero(nx);
  out.value = objective(x, &lambda);
  if (lambda.size() != nx)
    throw std::invalid_argument("RolloutReverse: the objective's gradient has " +
                                std::to_string(lambda.size()) + " entries; expected " +
                                std::to_string(nx));
  out.d_theta = VectorXd::Zero(selection.size());
  for (std::size_t k = dx.size(); k-- > 0;) {
    out.d_theta += dtheta[k].transpose() * lambda;
    lambda = dx[k].transpose() * lambda;
  }
  out.d_x0 = lambda;
  out.ok = !failed;
  if (failed) out.failure = "a step's derivative failed (NaN columns)";
  return out;
}

}  // namespace vinci::sim
