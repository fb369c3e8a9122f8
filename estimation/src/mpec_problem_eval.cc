// The MPEC estimator's problem evaluation (the MpecProblem interface and the accessors of
// mpec_estimator.h), in the solver's scaled unknowns y = x / scale.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mpec_problem.h"

namespace vinci::estimation {

using mpec_internal::kDefaultSigma;
using mpec_internal::kInf;
using mpec_internal::ParallelFor;
using mpec_internal::ResidualRow;
using mpec_internal::StepBlock;
using sim::Params;
using sim::State;
using sim::VectorXd;

int MpecEstimationProblem::num_variables() const { return impl_->n; }
int MpecEstimationProblem::num_constraints() const { return impl_->m; }
double MpecEstimationProblem::process_noise() const { return impl_->sigma_q; }
double MpecEstimationProblem::dropped_jacobian() const { return impl_->max_dropped; }
int MpecEstimationProblem::num_steps() const { return static_cast<int>(impl_->steps.size()); }
int MpecEstimationProblem::num_residuals() const {
  return static_cast<int>(impl_->residuals.size());
}

void MpecEstimationProblem::Bounds(VectorXd* x_l, VectorXd* x_u, VectorXd* g_l,
                                   VectorXd* g_u) const {
  *x_l = impl_->x_l;
  *x_u = impl_->x_u;
  *g_l = VectorXd::Zero(impl_->m);
  *g_u = VectorXd::Zero(impl_->m);
}

VectorXd MpecEstimationProblem::StartingPoint() const { return impl_->start; }

std::vector<std::pair<int, int>> MpecEstimationProblem::ComplementarityPairs() const {
  return impl_->pairs;
}

bool MpecEstimationProblem::Objective(const VectorXd& y, double* f) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  double s = 0.0;
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    s += v * v;
  }
  double w = 0.0;
  for (int c : I.w_cols) w += x.segment(c, I.nv).squaredNorm();
  *f = s / (I.sigma * I.sigma) + w / (I.sigma_q * I.sigma_q);
  return std::isfinite(*f);
}

bool MpecEstimationProblem::Gradient(const VectorXd& y, VectorXd* grad) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  grad->setZero(I.n);
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    for (int i = 0; i < r.n; ++i) (*grad)[r.col[i]] += 2 * v * r.coef[i] / (I.sigma * I.sigma);
  }
  for (int c : I.w_cols) grad->segment(c, I.nv) += 2 * x.segment(c, I.nv) / (I.sigma_q * I.sigma_q);
  *grad = grad->cwiseProduct(I.scale);
  return grad->allFinite();
}

bool MpecEstimationProblem::Constraints(const VectorXd& y, VectorXd* g) const {
  const Impl& I = *impl_;
  if (I.cache_g_ok && I.cache_g_x.size() == y.size() && I.cache_g_x == y) {
    *g = I.cache_g;
    return true;
  }
  const VectorXd x = I.Physical(y);
  g->setZero(I.m);
  const Params theta = I.Theta(x);
  std::vector<char> ok(I.steps.size(), 1);
  ParallelFor(static_cast<int>(I.steps.size()), I.opts.threads, [&](int k) {
    const StepBlock& b = I.steps[k];
    try {
      thread_local sim::StepModelValues v;  // storage reuse
      I.EvaluateStepInto(b, x, theta, false, &v);
      g->segment(b.row, b.neq) = v.equality;
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) (*g)[b.row + b.neq + b.a_slack[r]] = x[b.a_var[r]] - v.comp_a[r];
        if (b.b_slack[r] >= 0) (*g)[b.row + b.neq + b.b_slack[r]] = x[b.b_var[r]] - v.comp_b[r];
      }
    } catch (const std::exception&) {
      ok[k] = 0;
    }
  });
  for (const auto& [row, col] : I.quat_rows) (*g)[row] = x.segment(col, 4).squaredNorm() - 1.0;
  const bool all = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  if (!all || !g->allFinite()) return false;
  I.cache_g_x = y;
  I.cache_g = *g;
  I.cache_g_ok = true;
  return true;
}

std::vector<Entry> MpecEstimationProblem::JacobianStructure() const { return impl_->jac; }

bool MpecEstimationProblem::JacobianValues(const VectorXd& y, VectorXd* values) const {
  const Impl& I = *impl_;
  if (I.cache_j_ok && I.cache_j_x.size() == y.size() && I.cache_j_x == y) {
    *values = I.cache_j;
    return true;
  }
  const VectorXd x = I.Physical(y);
  values->setZero(static_cast<int>(I.jac.size()));
  const Params theta = I.Theta(x);
  std::vector<char> ok(I.steps.size(), 1);
  std::vector<double> dropped(I.steps.size(), 0.0);
  VectorXd g(I.m);
  ParallelFor(static_cast<int>(I.steps.size()), I.opts.threads, [&](int k) {
    const StepBlock& b = I.steps[k];
    try {
      thread_local sim::StepModelValues v;  // storage reuse
      I.EvaluateStepInto(b, x, theta, true, &v);
      I.ForEachEntry(b, v, [&](int lr, int lc, double val) {
        const long long key = I.Key(b, lr, lc);
        const auto it = std::lower_bound(b.keys.begin(), b.keys.end(), key);
        if (it == b.keys.end() || *it != key) {
          // Outside the structure: rounding noise of the x_ℓ block, or (never seen; reported
          // as MpecEstimateResult::dropped_jacobian) a non-zero the structure missed.
          if (I.IsStateColumn(b, lc) && std::abs(val) <= mpec_internal::kStateJacobianNoise) return;
          dropped[k] = std::max(dropped[k], std::abs(val));
          return;
        }
        (*values)[b.jac_offset + static_cast<int>(it - b.keys.begin())] = val;
      });
      int e = b.jac_offset + static_cast<int>(b.keys.size());
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) (*values)[e++] = 1.0;
        if (b.b_slack[r] >= 0) (*values)[e++] = 1.0;
      }
      g.segment(b.row, b.neq) = v.equality;
      for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
        if (b.a_slack[r] >= 0) g[b.row + b.neq + b.a_slack[r]] = x[b.a_var[r]] - v.comp_a[r];
        if (b.b_slack[r] >= 0) g[b.row + b.neq + b.b_slack[r]] = x[b.b_var[r]] - v.comp_b[r];
      }
    } catch (const std::exception&) {
      ok[k] = 0;
    }
  });
  int e = I.quat_jac_offset;
  for (const auto& [row, col] : I.quat_rows) {
    g[row] = x.segment(col, 4).squaredNorm() - 1.0;
    for (int j = 0; j < 4; ++j) (*values)[e++] = 2 * x[col + j];
  }
  const bool all = std::all_of(ok.begin(), ok.end(), [](char c) { return c != 0; });
  if (!all || !values->allFinite()) return false;
  for (std::size_t k = 0; k < I.jac.size(); ++k)
    (*values)[static_cast<int>(k)] *= I.scale[I.jac[k].col];
  for (double d : dropped) I.max_dropped = std::max(I.max_dropped, d);
  I.cache_j_x = y;
  I.cache_j = *values;
  I.cache_j_ok = true;
  I.cache_g_x = y;
  I.cache_g = g;
  I.cache_g_ok = true;
  return true;
}

std::vector<Entry> MpecEstimationProblem::HessianStructure() const { return impl_->hess; }

bool MpecEstimationProblem::HessianValues(const VectorXd& /*x*/, double obj_factor,
                                          const VectorXd& lambda, VectorXd* values) const {
  const Impl& I = *impl_;
  *values = obj_factor * I.hess_obj;
  // (quaternion unknowns have scale 1)
  for (const auto& [entry, row] : I.hess_quat) (*values)[entry] += 2 * lambda[row];
  return true;
}

VectorXd MpecEstimationProblem::Parameters(const VectorXd& y) const {
  return impl_->Physical(y).head(impl_->ntheta);
}

State MpecEstimationProblem::InitialState(const VectorXd& y, int episode) const {
  const Impl& I = *impl_;
  return I.NodeState(I.Physical(y), I.x0_col.at(episode), I.node_t.at(episode).front());
}

double MpecEstimationProblem::SquaredResiduals(const VectorXd& y, std::vector<double>* per_episode,
                                               double* max_w) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  if (per_episode) per_episode->assign(I.num_episodes, 0.0);
  double s = 0.0;
  for (const ResidualRow& r : I.residuals) {
    double v = -r.y;
    for (int i = 0; i < r.n; ++i) v += r.coef[i] * x[r.col[i]];
    s += v * v;
    if (per_episode) (*per_episode)[r.episode] += v * v;
  }
  if (max_w) {
    *max_w = 0.0;
    for (int c : I.w_cols) *max_w = std::max(*max_w, x.segment(c, I.nv).cwiseAbs().maxCoeff());
  }
  return s;
}

void MpecEstimationProblem::StepViolation(const VectorXd& y, double* equality,
                                          double* complementarity) const {
  const Impl& I = *impl_;
  const VectorXd x = I.Physical(y);
  const Params theta = I.Theta(x);
  *equality = 0.0;
  *complementarity = 0.0;
  for (const StepBlock& b : I.steps) {
    const sim::StepModelValues v = I.EvaluateStep(b, x, theta, false);
    if (v.equality.size() > 0) *equality = std::max(*equality, v.equality.cwiseAbs().maxCoeff());
    if (v.comp_a.size() > 0) {
      *complementarity =
          std::max(*complementarity, v.comp_a.cwiseMin(v.comp_b).cwiseAbs().maxCoeff());
    }
  }
  for (const auto& [row, col] : I.quat_rows)
    *equality = std::max(*equality, std::abs(x.segment(col, 4).squaredNorm() - 1.0));
}

VectorXd MpecEstimationProblem::VariablesFromRollouts(const std::vector<sim::Trajectory>& rollouts,
                                                      const Params& params) const {
  const Impl& I = *impl_;
  if (static_cast<int>(rollouts.size()) != I.num_episodes)
    throw std::invalid_argument("mpec: one rollout per episode expected");
  VectorXd x = I.Physical(I.start);
  x.head(I.ntheta) = I.sel.Get(params);
  auto find = [&](int e, double t) -> const State& {
    for (const State& s : rollouts[e].states)
      if (std::abs(s.t - t) <= 1e-9) return s;
    throw std::invalid_argument("mpec: no rollout state at t = " + std::to_string(t));
  };
  for (int e = 0; e < I.num_episodes; ++e) {
    const State& s0 = find(e, I.node_t[e].front());
    x.segment(I.x0_col[e], I.nq) = s0.q;
    x.segment(I.x0_col[e] + I.nq, I.nv) = s0.v;
  }
  int k = 0;
  for (int e = 0; e < I.num_episodes; ++e) {
    for (std::size_t l = 0; l + 1 < I.node_t[e].size(); ++l, ++k) {
      const StepBlock& b = I.steps[k];
      const VectorXd z = b.model->UnknownsFromStep(find(e, I.node_t[e][l + 1]));
      x.segment(b.z_col, b.nz) = z;
      x.segment(b.w_col, I.nv).setZero();
    }
  }
  // Slacks = their rows.
  const Params theta = I.Theta(x);
  for (const StepBlock& b : I.steps) {
    const sim::StepModelValues v = I.EvaluateStep(b, x, theta, false);
    for (std::size_t r = 0; r < b.a_slack.size(); ++r) {
      if (b.a_slack[r] >= 0) x[b.a_var[r]] = v.comp_a[r];
      if (b.b_slack[r] >= 0) x[b.b_var[r]] = v.comp_b[r];
    }
  }
  return x.cwiseQuotient(I.scale);
}

}  // namespace vinci::estimation
