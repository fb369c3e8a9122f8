#include "vinci/sim/simulator/sensitivity.h"

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "../formulations/step_record.h"
#include "../solvers/scratch_lease.h"
#include "sensitivity_internal.h"
#include "sensitivity_lcp_basis.h"
#include "sensitivity_linearization.h"
#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/formulations/ncp.h"
#include "vinci/sim/formulations/step_model.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool IsMotionKind(ParamKind k) {
  switch (k) {
    case ParamKind::kMotionVelocity:
    case ParamKind::kMotionAmplitude:
    case ParamKind::kMotionFrequency:
    case ParamKind::kMotionPhase:
    case ParamKind::kTiltAmplitude:
    case ParamKind::kTiltFrequency:
    case ParamKind::kTiltPhase:
    case ParamKind::kTiltDepth:
      return true;
    default:
      return false;
  }
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s.empty() ? "(none)" : s;
}

using internal::kMinStableRadius;
using internal::Linearization;
using internal::ResidualColumn;

// The smoothed step's solution: Newton on [equality; φ_ε(a, b)] = 0 from z*.
bool SmoothedSolution(const StepModel& model, const Params& theta, const State& x,
                      const StepInput& u, double eps, VectorXd* z) {
  StepModelOptions jac;
  jac.state_jacobian = false;
  const auto residual = [&](const StepModelValues& v) {
    VectorXd g(v.equality.size() + v.comp_a.size());
    g.head(v.equality.size()) = v.equality;
    for (int i = 0; i < v.comp_a.size(); ++i) {
      const double a = v.comp_a[i], b = v.comp_b[i];
      g[v.equality.size() + i] = a + b - std::sqrt(a * a + b * b + 2.0 * eps);
    }
    return g;
  };
  StepModelValues v = model.Evaluate(*z, theta, x, u, jac);
  VectorXd g = residual(v);
  // Converged at the round-off level of z: far below the smoothing's own O(√ε) bias, so the
  // derivative returned is that of the smoothed step itself (docs/sensitivity.md).
  const double tol = 1e-13 * std::max(1.0, z->cwiseAbs().maxCoeff());
  for (int it = 0; it < 50; ++it) {
    if (g.cwiseAbs().maxCoeff() <= tol) return true;
    const MatrixXd E = MatrixXd(v.d_equality.d_z), A = MatrixXd(v.d_comp_a.d_z),
                   B = MatrixXd(v.d_comp_b.d_z);
    MatrixXd J(g.size(), z->size());
    J.topRows(E.rows()) = E;
    for (int i = 0; i < A.rows(); ++i) {
      const double a = v.comp_a[i], b = v.comp_b[i];
      const double r = std::sqrt(a * a + b * b + 2.0 * eps);
      J.row(E.rows() + i) = (1.0 - a / r) * A.row(i) + (1.0 - b / r) * B.row(i);
    }
    const VectorXd step = J.completeOrthogonalDecomposition().solve(-g);
    if (!step.allFinite()) return false;
    double t = 1.0;
    const double g0 = g.norm();
    for (; t > 1e-8; t *= 0.5) {
      const VectorXd trial = *z + t * step;
      StepModelValues vt = model.Evaluate(trial, theta, x, u, jac);
      const VectorXd gt = residual(vt);
      if (gt.norm() <= (1.0 - 1e-4 * t) * g0) {
        *z = trial;
        v = std::move(vt);
        g = gt;
        break;
      }
    }
    if (t <= 1e-8) return g.cwiseAbs().maxCoeff() <= 1e3 * tol;
  }
  return g.cwiseAbs().maxCoeff() <= 1e3 * tol;
}

// Per-thread storage of the residuals at the linearization point and along s (distinct types:
// distinct ScratchLease slots).
struct ValsStorage {
  StepResiduals r;
  internal::SparseJacobians J;
};
struct AlongStorage {
  StepResiduals r;
};

// Everything one step's derivative needs, built once per step.
class StepDifferentiator {
 public:
  StepDifferentiator(const Simulator& sim, const Params& params, const ParamSelection& selection,
                     const State& x, const StepInput& u, const State& next,
                     const SensitivityOptions& options, bool full_state, Workspace* ws)
      : sim_(sim), params_(params), selection_(selection), x_(x), u_(u), options_(options) {
    // The scene resolved in the caller's workspace (the step's own: no copy if it already holds
    // these parameters), shared by the frozen model.
    Workspace* w = ws ? ws : &own_ws_;
    const Scene& model = sim.ResolveWithInputs(params, u, w);
    // The frozen model in the calling thread's storage, from the step's own assembly where the
    // workspace's last step was this one (FreezeInto).
    internal::FreezeInto(sim.formulation(), u.motions.empty() ? w->model : w->motion_model, params,
                         x, u, &frozen_);
    z_ = frozen_->UnknownsFromStep(next);
    if (options.smoothing > 0.0) {
      if (!SmoothedSolution(*frozen_, params, x, u, options.smoothing, &z_)) {
        message_ = "the smoothed step's Newton iteration did not converge";
        return;
      }
    }
    // The residuals with their dense z and θ Jacobians; the x_ℓ block (central differences of
    // the frozen equations) only for the full state Jacobian.
    const int nz = frozen_->layout().size();
    internal::EvaluateResidualsInto(*frozen_, z_, params, x, u, &vals_, &jac_);
    const bool gi = dynamic_cast<const GeometricallyImplicit*>(&sim.formulation()) != nullptr;
    // The NCP stepper's pairs: [(p_n, normal) nc; (σ, quadratic cone) nc].
    const int quadratic_from =
        dynamic_cast<const NcpStepper*>(&sim.formulation()) ? frozen_->layout().nc : -1;
    lin_->Compute(vals_, jac_, nz, options, options.smoothing > 0.0,
                  gi ? &frozen_->layout() : nullptr, quadratic_from, &frozen_->layout());
    lin_computed_ = true;
    if (!lin_->ok()) {
      message_ = lin_->message();
      return;
    }
    if (!gi && options.degenerate == DegenerateRule::kDirectional) {
      // Redundant contacts with a contact at its cone edge: linearize at a split inside the
      // solution set instead (Linearization::InteriorShift).
      const StepLayout& l = frozen_->layout();
      const VectorXd shift = lin_->InteriorShift(l.nq + l.nv, z_);
      if (shift.size() == z_.size()) {
        z_ += shift;
        internal::EvaluateResidualsInto(*frozen_, z_, params, x, u, &vals_, &jac_);
        lin_->Compute(vals_, jac_, nz, options, false, nullptr, quadratic_from, &frozen_->layout());
        if (!lin_->ok()) {
          message_ = lin_->message();
          return;
        }
      }
    }
    if (full_state) {
      // ∂r/∂x_ℓ as StepModel::Evaluate's x_ℓ block: the ν_ℓ columns in closed form where the
      // formulation has them, the others by central differences of the frozen equations
      // (values only) along each coordinate, step state_step · max(1, |x_i|).
      const int nq = static_cast<int>(x.q.size()), n = nx();
      d_eq_x_.setZero(vals_.equality.size(), n);
      d_a_x_.setZero(vals_.comp_a.size(), n);
      d_b_x_.setZero(vals_.comp_b.size(), n);
      const bool velocity = frozen_->FreezeVelocityColumns(nq, &d_eq_x_, &d_a_x_, &d_b_x_);
      for (int j = 0; j < (velocity ? nq : n); ++j) {
        const double c0 = j < nq ? x.q[j] : x.v[j - nq];
        const double step = options.state_step * std::max(1.0, std::abs(c0));
        const StepResiduals d =
            frozen_->StateDirectionalDerivative(z_, u, VectorXd::Unit(n, j), step);
        d_eq_x_.col(j) = d.equality;
        d_a_x_.col(j) = d.comp_a;
        d_b_x_.col(j) = d.comp_b;
      }
    }
    // A mode change within the step: the contact set found at the end differs. GI finds its
    // contacts at ℓ+1 inside the step (a contact made within the step is one of its pairs'
    // complementarity, classified above); its candidate pairs at ℓ+1 belong to the next step.
    explicit_start_ = gi;
    if (!explicit_start_) {
      const StepLayout end = sim.formulation().Layout(model, next);
      const StepLayout& l = frozen_->layout();
      contact_set_changed_ = end.nc != l.nc || end.nk != l.nk || end.ns != l.ns;
    }
    ok_ = true;
  }

  bool ok() const { return ok_; }
  const std::string& message() const { return message_; }
  int degenerate() const { return lin_computed_ ? lin_->degenerate() : 0; }
  int feature_kinks() const { return frozen_ ? frozen_->feature_kinks() : 0; }
  bool contact_set_changed() const { return contact_set_changed_; }
  int nx() const { return static_cast<int>(x_.q.size() + x_.v.size()); }

  // The residual column of selection entry j.
  ResidualColumn ParamColumn(int j) {
    const int index = selection_.indices()[j];
    const ParamInfo& info = sim_.scene().param_table().info(index);
    ResidualColumn r;
    if (info.differentiable) {
      const std::vector<int>& cols = frozen_->param_columns();
      const auto it = std::find(cols.begin(), cols.end(), index);
      const int c = static_cast<int>(it - cols.begin());
      if (it == cols.end()) {
        r = ZeroColumn();
      } else {
        const int col = frozen_->layout().size() + c;
        jac_.equality.Column(col, &r.eq);
        jac_.comp_a.Column(col, &r.a);
        jac_.comp_b.Column(col, &r.b);
      }
      return r;
    }
    // Motion parameters: the equations re-evaluated with the contact set re-detected at x_ℓ.
    const double v = params_.values[index];
    const double h = options_.motion_step * std::max(1.0, std::abs(v));
    const auto eval = [&](double value, StepResiduals* out) {
      Params p = params_;
      p.values[index] = value;
      Workspace ws;
      const Scene& m = sim_.ResolveWithInputs(p, u_, &ws);
      *out = sim_.formulation().Evaluate(m, p, x_, u_, z_);
      const StepLayout& l = frozen_->layout();
      return out->layout.size() == l.size() && out->layout.nc == l.nc;
    };
    StepResiduals rp, rm;
    const bool same = eval(v + h, &rp) && eval(v - h, &rm);
    if (!same) {
      r.contact_set_changed = true;
      r.eq = VectorXd::Constant(vals_.equality.size(), kNaN);
      r.a = VectorXd::Constant(vals_.comp_a.size(), kNaN);
      r.b = VectorXd::Constant(vals_.comp_b.size(), kNaN);
      return r;
    }
    r.eq = (rp.equality - rm.equality) / (2 * h);
    r.a = (rp.comp_a - rm.comp_a) / (2 * h);
    r.b = (rp.comp_b - rm.comp_b) / (2 * h);
    return r;
  }

  ResidualColumn ZeroColumn() const {
    ResidualColumn r;
    r.eq = VectorXd::Zero(vals_.equality.size());
    r.a = VectorXd::Zero(vals_.comp_a.size());
    r.b = VectorXd::Zero(vals_.comp_b.size());
    return r;
  }

  // The residual column of state entry i (needs full_state).
  ResidualColumn StateColumn(int i) const {
    ResidualColumn r;
    r.eq = d_eq_x_.col(i);
    r.a = d_a_x_.col(i);
    r.b = d_b_x_.col(i);
    return r;
  }

  // ∂r/∂x_ℓ · s by central differences of the frozen equations along s.
  ResidualColumn StateDirection(const VectorXd& s) const {
    ResidualColumn r;
    const double sn = s.cwiseAbs().maxCoeff();
    if (!(sn > 0.0)) return ZeroColumn();
    double xn = std::max(x_.q.size() ? x_.q.cwiseAbs().maxCoeff() : 0.0,
                         x_.v.size() ? x_.v.cwiseAbs().maxCoeff() : 0.0);
    // Along the unit direction s / |s|_∞, scaled back: a step h / |s|_∞ overflows to ∞ for a
    // carried column that decayed to denormals (~1e-317), and ∞ · 0 poisons the state with NaN.
    const double h = options_.state_step * std::max(1.0, xn);
    // Contacts with a closed-form rate move along it instead of being re-collided.
    internal::ScratchLease<AlongStorage> along;
    StepResiduals& d = along.get().r;
    internal::StateDirectionalDerivativeInto(*frozen_, z_, u_, s / sn, h, &d);
    r.eq = sn * d.equality;
    r.a = sn * d.comp_a;
    r.b = sn * d.comp_b;
    return r;
  }

  static ResidualColumn Add(ResidualColumn a, const ResidualColumn& b) {
    a.eq += b.eq;
    a.a += b.a;
    a.b += b.b;
    a.contact_set_changed = a.contact_set_changed || b.contact_set_changed;
    return a;
  }

  // ∂x_ℓ+1 along a residual column whose state direction is s (empty: none); NaN if the system
  // is inconsistent along it. *near_kink: the held active set stays feasible only within a
  // perturbation below kMinStableRadius · scale along the column (scale: the column variable's
  // magnitude, ≥ 1).
  VectorXd EndStateDerivative(const ResidualColumn& r, const VectorXd& s, double scale,
                              bool* unsolved, bool* failed, bool* near_kink) const {
    *failed = false;
    *near_kink = false;
    VectorXd dz;
    if (!r.eq.allFinite() || !r.a.allFinite() || !r.b.allFinite() ||
        !lin_->Solve(r, &dz, unsolved)) {
      *failed = true;
      return VectorXd::Constant(nx(), kNaN);
    }
    *near_kink = lin_->StableRadius(r, dz) < kMinStableRadius * std::max(1.0, scale);
    // The end state as the model writes it from z: the z blocks q_ℓ+1, ν_ℓ+1 for every
    // formulation but GI (read directly). GI writes a spatial body's orientation from its
    // rotation unknowns and x_ℓ (R_ℓ+1 = R_ℓ Exp(φ)): a central difference along the unit
    // direction of the pose and velocity blocks of dz (and the state direction s) only — the
    // impulse and geometry blocks, which the end state does not read, can be 1e8 times larger
    // (a stiff contact's dp_n) and would shrink the pose step below round-off.
    const StepLayout& l = frozen_->layout();
    VectorXd d(nx());
    if (!explicit_start_) {
      d << dz.segment(l.q1(), l.nq), dz.segment(l.v1(), l.nv);
      return d;
    }
    VectorXd dzs = VectorXd::Zero(dz.size());
    dzs.segment(l.q1(), l.nq) = dz.segment(l.q1(), l.nq);
    dzs.segment(l.v1(), l.nv) = dz.segment(l.v1(), l.nv);
    const bool with_x = s.size() == nx() && s.allFinite();
    const double dn = std::max(dzs.cwiseAbs().maxCoeff(), with_x ? s.cwiseAbs().maxCoeff() : 0.0);
    if (!(dn > 0.0)) return VectorXd::Zero(nx());
    // Unit directions first: h / dn overflows for columns that decayed to denormals (~1e-318).
    const double zs = std::max(z_.segment(l.q1(), l.nq).cwiseAbs().maxCoeff(),
                               z_.segment(l.v1(), l.nv).cwiseAbs().maxCoeff());
    const double h = 1e-6 * std::max(1.0, zs);
    const VectorXd unit = dzs / dn;
    State xp = x_, xm = x_;
    if (with_x) {
      const int nq = static_cast<int>(x_.q.size());
      const VectorXd us = s / dn;
      xp.q += h * us.head(nq);
      xm.q -= h * us.head(nq);
      xp.v += h * us.tail(us.size() - nq);
      xm.v -= h * us.tail(us.size() - nq);
    }
    const State p = frozen_->StateFromUnknowns(z_ + h * unit, xp);
    const State m = frozen_->StateFromUnknowns(z_ - h * unit, xm);
    d << (p.q - m.q) * (dn / (2 * h)), (p.v - m.v) * (dn / (2 * h));
    return d;
  }

 private:
  const Simulator& sim_;
  const Params& params_;
  const ParamSelection& selection_;
  const State& x_;
  const StepInput& u_;
  SensitivityOptions options_;
  Workspace own_ws_;  // when the caller passes none
  // The calling thread's frozen model (its storage reused from step to step; FreezeInto).
  internal::ScratchLease<std::unique_ptr<StepModel>> frozen_lease_;
  std::unique_ptr<StepModel>& frozen_ = frozen_lease_.get();
  VectorXd z_;
  // At z_: values and [z, θ] Jacobians (by rows), in the calling thread's storage.
  internal::ScratchLease<ValsStorage> vals_lease_;
  StepResiduals& vals_ = vals_lease_.get().r;
  internal::SparseJacobians& jac_ = vals_lease_.get().J;
  MatrixXd d_eq_x_, d_a_x_, d_b_x_;  // ∂r/∂x_ℓ (full state only)
  // The calling thread's linearization storage (scratch_lease.h), recomputed for this step.
  internal::ScratchLease<Linearization> lin_lease_;
  Linearization* lin_ = &lin_lease_.get();
  bool lin_computed_ = false;
  bool ok_ = false, contact_set_changed_ = false;
  bool explicit_start_ = false;  // the end state depends on x_ℓ explicitly (GI)
  std::string message_;
};

}  // namespace

namespace internal {

void CheckSelection(const Simulator& sim, const ParamSelection& selection) {
  const ParamTable& table = sim.scene().param_table();
  for (int index : selection.indices()) {
    if (index < 0 || index >= table.size())
      throw std::invalid_argument("sensitivity: parameter index out of range");
    const ParamInfo& info = table.info(index);
    if (!info.differentiable && !IsMotionKind(info.kind))
      throw std::invalid_argument("sensitivity: parameter '" + info.name +
                                  "' is neither differentiable nor a motion parameter (sizes and "
                                  "poses move the contact set); expected one of: " +
                                  JoinNames(SensitivityParameterNames(table)));
  }
}

SensitivityStatus Classify(bool failed, bool changed, int degenerate) {
  if (failed) return SensitivityStatus::kFailed;
  if (changed) return SensitivityStatus::kModeChange;
  if (degenerate > 0) return SensitivityStatus::kDegenerate;
  return SensitivityStatus::kExact;
}

void Count(SensitivityStatus s, int* exact, int* degenerate, int* mode_change, int* failed) {
  switch (s) {
    case SensitivityStatus::kExact:
      ++*exact;
      break;
    case SensitivityStatus::kDegenerate:
      ++*degenerate;
      break;
    case SensitivityStatus::kModeChange:
      ++*mode_change;
      break;
    case SensitivityStatus::kFailed:
      ++*failed;
      break;
  }
}
}  // namespace internal

using internal::CheckSelection;
using internal::Classify;
using internal::Count;

namespace {

std::string Describe(const StepDifferentiator& d, int unsolved, int kinks) {
  std::string m;
  if (d.degenerate() > 0)
    m += std::to_string(d.degenerate()) + " degenerate pair(s) (one-sided derivative)";
  if (d.contact_set_changed()) m += std::string(m.empty() ? "" : "; ") + "contact set changed";
  if (unsolved > 0)
    m += std::string(m.empty() ? "" : "; ") + std::to_string(unsolved) +
         " column(s) with an unsolved sensitivity LCP";
  if (kinks > 0)
    m += std::string(m.empty() ? "" : "; ") + std::to_string(kinks) +
         " column(s) whose active set holds only within a perturbation below 1e-6 (near-singular "
         "active block: the derivative of the step's own branch)";
  if (d.feature_kinks() > 0)
    m += std::string(m.empty() ? "" : "; ") + std::to_string(d.feature_kinks()) +
         " contact(s) at a feature switch (a vertex on another polytope's face edge or vertex: "
         "the derivative of the features found at x_l, held)";
  return m;
}

}  // namespace

const char* SensitivityStatusName(SensitivityStatus status) {
  switch (status) {
    case SensitivityStatus::kExact:
      return "exact";
    case SensitivityStatus::kDegenerate:
      return "degenerate";
    case SensitivityStatus::kModeChange:
      return "mode_change";
    case SensitivityStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

std::vector<std::string> SensitivityParameterNames(const ParamTable& table) {
  std::vector<std::string> names;
  for (int i = 0; i < table.size(); ++i) {
    const ParamInfo& info = table.info(i);
    if (info.differentiable || IsMotionKind(info.kind)) names.push_back(info.name);
  }
  return names;
}

StepSensitivity StepDerivatives(const Simulator& sim, const Params& params,
                                const ParamSelection& selection, const State& x, const StepInput& u,
                                const State& next, bool with_state,
                                const SensitivityOptions& options, Workspace* ws) {
  CheckSelection(sim, selection);
  const int nx = static_cast<int>(x.q.size() + x.v.size());
  StepSensitivity out;
  if (options.lcp_basis) {
    // On the step LCP's basis: the parameters' columns without a carried sensitivity, then the
    // state's unit directions.
    const int p = selection.size();
    MatrixXd S = MatrixXd::Zero(nx, p + (with_state ? nx : 0)), S_next;
    if (with_state) S.rightCols(nx).setIdentity();
    if (internal::PropagateOnLcpBasis(sim, params, selection, x, u, next, S, &S_next, options, ws,
                                      &out)) {
      out.d_theta = S_next.leftCols(p);
      if (with_state) out.d_x = S_next.rightCols(nx);
      return out;
    }
  }
  StepDifferentiator d(sim, params, selection, x, u, next, options, with_state, ws);
  if (!d.ok()) {
    out.status = SensitivityStatus::kFailed;
    out.message = d.message();
    out.d_theta = MatrixXd::Constant(nx, selection.size(), kNaN);
    if (with_state) out.d_x = MatrixXd::Constant(nx, nx, kNaN);
    return out;
  }
  bool failed = false, changed = d.contact_set_changed();
  int unsolved = 0, kinks = 0;
  out.d_theta.resize(nx, selection.size());
  const VectorXd theta = selection.Get(params);
  for (int j = 0; j < selection.size(); ++j) {
    const ResidualColumn r = d.ParamColumn(j);
    changed = changed || r.contact_set_changed;
    bool uns = false, f = false, k = false;
    out.d_theta.col(j) = d.EndStateDerivative(r, VectorXd(), std::abs(theta[j]), &uns, &f, &k);
    unsolved += uns;
    kinks += k;
    failed = failed || (f && !r.contact_set_changed);
  }
  if (with_state) {
    out.d_x.resize(nx, nx);
    const int nq = static_cast<int>(x.q.size());
    for (int i = 0; i < nx; ++i) {
      bool uns = false, f = false, k = false;
      const double xi = std::abs(i < nq ? x.q[i] : x.v[i - nq]);
      out.d_x.col(i) =
          d.EndStateDerivative(d.StateColumn(i), VectorXd::Unit(nx, i), xi, &uns, &f, &k);
      unsolved += uns;
      kinks += k;
      failed = failed || f;
    }
  }
  out.degenerate_pairs = d.degenerate();
  out.unsolved_columns = unsolved;
  out.near_kink_columns = kinks;
  out.contact_set_changed = changed;
  out.feature_kink_contacts = d.feature_kinks();
  out.status = Classify(failed, changed, d.degenerate() + kinks + d.feature_kinks());
  out.message = failed ? "the active system is inconsistent along some column (NaN)"
                       : Describe(d, unsolved, kinks);
  return out;
}

StepSensitivity PropagateStep(const Simulator& sim, const Params& params,
                              const ParamSelection& selection, const State& x, const StepInput& u,
                              const State& next, const MatrixXd& S, MatrixXd* S_next,
                              const SensitivityOptions& options, Workspace* ws) {
  CheckSelection(sim, selection);
  const int nx = static_cast<int>(x.q.size() + x.v.size());
  const int p = selection.size(), ncols = static_cast<int>(S.cols());
  if (S.rows() != nx || ncols < p)
    throw std::invalid_argument("PropagateStep: S is " + std::to_string(S.rows()) + " × " +
                                std::to_string(ncols) + "; expected " + std::to_string(nx) +
                                " rows and at least " + std::to_string(p) + " columns");
  // Many columns: one full state Jacobian is cheaper than a directional difference per column.
  const bool full_state = ncols > nx;
  StepSensitivity st;
  if (!full_state && options.lcp_basis &&
      internal::PropagateOnLcpBasis(sim, params, selection, x, u, next, S, S_next, options, ws,
                                    &st))
    return st;
  StepDifferentiator d(sim, params, selection, x, u, next, options, full_state, ws);
  *S_next = MatrixXd::Constant(nx, ncols, kNaN);
  if (!d.ok()) {
    st.status = SensitivityStatus::kFailed;
    st.message = d.message();
    return st;
  }
  bool failed = false, changed = d.contact_set_changed();
  int unsolved = 0, kinks = 0;
  const VectorXd theta = selection.Get(params);
  for (int c = 0; c < ncols; ++c) {
    ResidualColumn r;
    if (full_state) {
      r = c < p ? d.ParamColumn(c) : d.ZeroColumn();
      for (int i = 0; i < nx; ++i) {
        const double s = S(i, c);
        if (s == 0.0) continue;
        const ResidualColumn ri = d.StateColumn(i);
        r.eq += s * ri.eq;
        r.a += s * ri.a;
        r.b += s * ri.b;
      }
    } else {
      r = d.StateDirection(S.col(c));
      if (c < p) r = StepDifferentiator::Add(std::move(r), d.ParamColumn(c));
    }
    changed = changed || r.contact_set_changed;
    bool uns = false, f = false, k = false;
    S_next->col(c) =
        d.EndStateDerivative(r, S.col(c), c < p ? std::abs(theta[c]) : 1.0, &uns, &f, &k);
    unsolved += uns;
    kinks += k;
    failed = failed || (f && !r.contact_set_changed);
  }
  st.degenerate_pairs = d.degenerate();
  st.unsolved_columns = unsolved;
  st.near_kink_columns = kinks;
  st.contact_set_changed = changed;
  st.feature_kink_contacts = d.feature_kinks();
  st.status = Classify(failed, changed, d.degenerate() + kinks + d.feature_kinks());
  st.message = failed ? "the active system is inconsistent along some column (NaN)"
                      : Describe(d, unsolved, kinks);
  return st;
}

}  // namespace vinci::sim
