#include "vinci/sim/formulations/formulation.h"

#include <algorithm>
#include <cmath>

namespace vinci::sim {

StateJacobians Formulation::EvaluateStateJacobians(const Scene& model, const Params& params,
                                                   const State& x, const StepInput& u,
                                                   const VectorXd& z, double eps) const {
  const int nq = static_cast<int>(x.q.size()), nv = static_cast<int>(x.v.size());
  const StepLayout base = Layout(model, x);
  const StepResiduals r0 = Evaluate(model, params, x, u, z);
  StateJacobians J;
  J.d_equality = MatrixXd::Zero(r0.equality.size(), nq + nv);
  J.d_comp_a = MatrixXd::Zero(r0.comp_a.size(), nq + nv);
  J.d_comp_b = MatrixXd::Zero(r0.comp_b.size(), nq + nv);
  for (int j = 0; j < nq + nv; ++j) {
    State xp = x, xm = x;
    double& cp = j < nq ? xp.q[j] : xp.v[j - nq];
    double& cm = j < nq ? xm.q[j] : xm.v[j - nq];
    const double step = eps * std::max(1.0, std::abs(cp));
    cp += step;
    cm -= step;
    const StepLayout lp = Layout(model, xp), lm = Layout(model, xm);
    if (lp.size() != base.size() || lm.size() != base.size()) {
      J.contact_set_stable = false;
      continue;
    }
    const StepResiduals rp = Evaluate(model, params, xp, u, z);
    const StepResiduals rm = Evaluate(model, params, xm, u, z);
    J.d_equality.col(j) = (rp.equality - rm.equality) / (2 * step);
    J.d_comp_a.col(j) = (rp.comp_a - rm.comp_a) / (2 * step);
    J.d_comp_b.col(j) = (rp.comp_b - rm.comp_b) / (2 * step);
  }
  return J;
}

}  // namespace vinci::sim
