#include "vinci/sim/simulator/finite_difference.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace vinci::sim {
namespace {

// One run of the differentiated map.
struct Run {
  bool ok = false;
  std::string failure;
  VectorXd y;
  std::vector<int> contacts;  // per step
};

using RunFn = std::function<Run(const Params&, const State&)>;

VectorXd StackState(const State& x) {
  VectorXd y(x.q.size() + x.v.size());
  y << x.q, x.v;
  return y;
}

FiniteDifference Differentiate(const Simulator& sim, const Params& params,
                               const ParamSelection& selection, const State& x0,
                               const FiniteDifferenceOptions& options, const RunFn& run) {
  if (!(options.relative_step > 0.0) || !(options.min_step > 0.0))
    throw std::invalid_argument("finite differences: relative_step and min_step must be > 0 (got " +
                                std::to_string(options.relative_step) + ", " +
                                std::to_string(options.min_step) + ")");
  const ParamTable& table = sim.scene().param_table();
  if (params.values.size() != table.size())
    throw std::invalid_argument("finite differences: params have " +
                                std::to_string(params.values.size()) + " entries; the scene has " +
                                std::to_string(table.size()));
  for (int i : selection.indices())
    if (i < 0 || i >= table.size())
      throw std::invalid_argument("finite differences: the selection is not of this scene");
  const int np = selection.size();
  const int nq = static_cast<int>(x0.q.size()), nv = static_cast<int>(x0.v.size());
  const int ncol = np + (options.initial_state ? nq + nv : 0);

  FiniteDifference fd;
  const Run nominal = run(params, x0);
  if (!nominal.ok) {
    fd.nominal_ok = false;
    fd.failure = nominal.failure;
    return fd;
  }
  fd.value = nominal.y;
  fd.jacobian = MatrixXd::Constant(nominal.y.size(), ncol, 0.0);
  fd.steps = VectorXd::Zero(ncol);
  fd.one_sided.assign(ncol, false);
  fd.contact_set_changed.assign(ncol, false);
  fd.failed.assign(ncol, false);

  for (int j = 0; j < ncol; ++j) {
    Params pp = params, pm = params;
    State xp = x0, xm = x0;
    double base, lower = -std::numeric_limits<double>::infinity(),
                 upper = std::numeric_limits<double>::infinity();
    double* cp;
    double* cm;
    if (j < np) {
      const int i = selection.indices()[j];
      base = params.values[i];
      lower = table.info(i).lower;
      upper = table.info(i).upper;
      cp = &pp.values[i];
      cm = &pm.values[i];
    } else {
      const int k = j - np;
      cp = k < nq ? &xp.q[k] : &xp.v[k - nq];
      cm = k < nq ? &xm.q[k] : &xm.v[k - nq];
      base = *cp;
    }
    const double h = std::max(options.relative_step * std::abs(base), options.min_step);
    fd.steps[j] = h;
    const bool plus = base + h <= upper, minus = base - h >= lower;
    *cp = base + h;
    *cm = base - h;
    Run rp, rm;
    if (plus) rp = run(pp, xp);
    if (minus) rm = run(pm, xm);
    fd.one_sided[j] = !(plus && minus);
    const bool failed = (plus && !rp.ok) || (minus && !rm.ok) || (!plus && !minus);
    if (failed) {
      fd.failed[j] = true;
      fd.jacobian.col(j).setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    for (const Run* r : {plus ? &rp : nullptr, minus ? &rm : nullptr}) {
      if (!r) continue;
      if (r->y.size() != nominal.y.size())
        throw std::invalid_argument("finite differences: the output has " +
                                    std::to_string(r->y.size()) + " entries in a perturbed run, " +
                                    std::to_string(nominal.y.size()) + " in the nominal one");
      if (r->contacts != nominal.contacts) fd.contact_set_changed[j] = true;
    }
    const VectorXd& yp = plus ? rp.y : nominal.y;
    const VectorXd& ym = minus ? rm.y : nominal.y;
    fd.jacobian.col(j) = (yp - ym) / ((plus ? h : 0.0) + (minus ? h : 0.0));
  }
  return fd;
}

}  // namespace

bool FiniteDifference::clean() const {
  if (!nominal_ok) return false;
  for (std::size_t j = 0; j < failed.size(); ++j)
    if (failed[j] || contact_set_changed[j]) return false;
  return true;
}

FiniteDifference StepDerivativeFd(const Simulator& sim, const Params& params,
                                  const ParamSelection& selection, const State& x,
                                  const StepInput& u, const FiniteDifferenceOptions& options) {
  const RunFn run = [&](const Params& p, const State& x0) {
    Workspace ws;  // fresh per run: the + and − runs see the same start and warm start
    State next;
    const StepInfo info = sim.Step(p, x0, u, &ws, &next);
    Run r;
    r.ok = info.ok;
    r.failure = info.failure;
    r.contacts = {info.contacts};
    if (r.ok) r.y = StackState(next);
    return r;
  };
  return Differentiate(sim, params, selection, x, options, run);
}

FiniteDifference RolloutDerivativeFd(const Simulator& sim, const Params& params,
                                     const ParamSelection& selection, const State& x0,
                                     const std::vector<StepInput>& inputs,
                                     const RolloutOutput& output,
                                     const FiniteDifferenceOptions& options) {
  const RunFn run = [&](const Params& p, const State& x) {
    const Trajectory tr = sim.Rollout(p, x, inputs);
    Run r;
    r.ok = tr.ok;
    r.failure = tr.failure;
    for (const StepInfo& s : tr.steps) r.contacts.push_back(s.contacts);
    if (r.ok) r.y = output ? output(tr) : StackState(tr.states.back());
    return r;
  };
  return Differentiate(sim, params, selection, x0, options, run);
}

}  // namespace vinci::sim
