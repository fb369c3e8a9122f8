// Shared pieces of the steppers' Step (internal header): the report's start, the start-of-step
// penetration check, the solver-failure wording and the end-of-step state. The checks every step
// gets after the formulation has run (non-finite state, end-of-step penetration) are in
// step_skeleton.h.
#pragma once

#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/params.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"

namespace vinci::sim::internal {

/// A number for a message: %.6g (never a 300-digit std::to_string).
inline std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// The column of each differentiable parameter (ParamInfo::differentiable) in a StepResiduals'
/// Jacobians, after its `first` step unknowns, in table order (−1 for the others), into
/// *column_of (its storage reused); the parameters are appended to *param_columns.
inline void DifferentiableParamColumnsInto(const ParamTable& table, int first,
                                           std::vector<int>* param_columns,
                                           std::vector<int>* column_of) {
  column_of->assign(static_cast<std::size_t>(table.size()), -1);
  for (int i = 0; i < table.size(); ++i)
    if (table.info(i).differentiable) {
      (*column_of)[static_cast<std::size_t>(i)] = first + static_cast<int>(param_columns->size());
      param_columns->push_back(i);
    }
}
/// DifferentiableParamColumnsInto, returning the columns.
inline std::vector<int> DifferentiableParamColumns(const ParamTable& table, int first,
                                                   std::vector<int>* param_columns) {
  std::vector<int> column_of;
  DifferentiableParamColumnsInto(table, first, param_columns, &column_of);
  return column_of;
}

/// Marks the step failed with `status` and `failure`.
inline void FailStep(StepStatus status, std::string failure, StepInfo* info) {
  info->ok = false;
  info->status = status;
  info->failure = std::move(failure);
  if (status != StepStatus::kSolverFailed) info->solver.status = SolverStatus::kNumericalFailure;
}

/// Starts a step: a fresh report and *next = x (the output state on failure).
inline void BeginStep(const State& x, State* next, StepInfo* info) {
  *info = StepInfo{};
  *next = x;
}

/// The start-of-step penetration check on the smallest gap of the nc contacts (info->min_gap).
/// Returns false, the step failed with kPenetration, if it is below −max_penetration.
inline bool CheckStartPenetration(int nc, double max_penetration, StepInfo* info) {
  if (nc == 0 || !(info->min_gap < -max_penetration)) return true;
  FailStep(StepStatus::kPenetration,
           "penetration " + FormatNumber(-info->min_gap) +
               " m at the start of the step exceeds max_penetration " +
               FormatNumber(max_penetration) + " m",
           info);
  return false;
}

/// Marks the step failed because `solver` (e.g. "LCP solver 'lemke'") did not converge; the
/// solver report in info->solver gives the status and message.
inline void SolverFailed(const std::string& solver, StepInfo* info) {
  FailStep(StepStatus::kSolverFailed,
           solver + " failed: " + std::string(ToString(info->solver.status)) +
               (info->solver.message.empty() ? "" : " (" + info->solver.message + ")"),
           info);
}

/// Writes the end-of-step state from the solved velocity: t + h, ν_ℓ+1 = v1,
/// q_ℓ+1 = q_ℓ + h G(q_ℓ) ν_ℓ+1 per dynamic body (IntegratePosition), and the solver warm start.
/// Returns false, the step failed with kNonFinite and *next untouched, if v1 is not finite.
/// The same with the warm start swapped in from *warm_start (which receives next's old buffer):
/// no allocation when the sizes did not change.
inline bool CompleteStep(const Scene& model, const State& x, const VectorXd& v1, double h,
                         VectorXd* warm_start, State* next, StepInfo* info) {
  if (!v1.allFinite()) {
    FailStep(StepStatus::kNonFinite, "non-finite velocity after the step", info);
    return false;
  }
  next->t = x.t + h;
  next->v = v1;
  next->q.resize(x.q.size());
  for (int bi : model.dynamic_bodies()) {
    const BodyIndex& idx = model.index(bi);
    IntegratePosition(model.dim, x.q.data() + idx.q, v1.data() + idx.v, h, next->q.data() + idx.q);
  }
  next->warm_start.swap(*warm_start);
  return true;
}

inline bool CompleteStep(const Scene& model, const State& x, const VectorXd& v1, double h,
                         VectorXd warm_start, State* next, StepInfo* info) {
  return CompleteStep(model, x, v1, h, &warm_start, next, info);
}

}  // namespace vinci::sim::internal
