// Private to the MPEC estimator (mpec_estimator.h): the problem's data (grid, step blocks,
// residual rows, scales, structure) shared by its assembly (mpec_problem_build.cc), evaluation
// (mpec_problem_eval.cc), covariance (mpec_covariance.cc) and driver (mpec_estimator.cc).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "estimation_internal.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/formulations/step_model.h"

namespace vinci::estimation {
namespace mpec_internal {

constexpr double kDefaultSigma = 1e-3;  // m, weighting when no noise is stated
constexpr double kInf = 1e20;
// Below this, an entry of a step's x_ℓ Jacobian block (central differences) is rounding noise.
constexpr double kStateJacobianNoise = 1e-7;
// A complementarity pair whose larger side is at most this (scaled unknowns) is biactive.
constexpr double kBiactive = 1e-6;

// A measurement residual r = Σ coef_k x[col_k] − y (m).
struct ResidualRow {
  int episode = 0;
  int n = 0;
  int col[4] = {0, 0, 0, 0};
  double coef[4] = {0, 0, 0, 0};
  double y = 0.0;
};

struct StepBlock {
  int episode = 0;
  double t = 0.0;
  std::unique_ptr<sim::StepModel> model;
  int nz = 0, neq = 0, ns = 0;
  int x_col = 0, z_col = 0, w_col = 0, s_col = 0;
  int row = 0;  // first constraint row: equality rows, then slack rows
  // Per comp row: its complementarity variable, and the slack index (−1: the row is z itself).
  std::vector<int> a_var, b_var, a_slack, b_slack;
  std::vector<int> theta_map;   // per param_columns() entry: chosen index or −1
  std::vector<long long> keys;  // sorted local (row, col) keys of the model's entries
  int jac_offset = 0;           // first global Jacobian entry (model entries, then slacks)
  sim::VectorXd z_guess;
};

using internal::ParallelFor;  // estimation_internal.h

/// Bootstrap standard errors over episodes (MpecOptions::bootstrap ≥ 1, ≥ 2 episodes): B
/// resamples of the episodes with replacement (seeded by options.bootstrap_seed), each estimated
/// by `estimate` with bootstrap and progress off; r->std_errors the converged resamples'
/// standard deviation (NaN with fewer than 2), r->std_error_method "bootstrap",
/// r->bootstrap_converged their count. Progress lines go to options.progress.
void BootstrapOverEpisodes(const sim::Simulator& simulator, const Log& log,
                           const MpecOptions& options,
                           const std::function<MpecEstimateResult(const sim::Simulator&, const Log&,
                                                                  const MpecOptions&)>& estimate,
                           MpecEstimateResult* r);

// An episode's MPEC with θ fixed (its bounds set to the given values; an empty theta leaves θ
// free) and a chosen start. With keep_active_set, the NLP of the start's active set instead (the
// polish NLP of mpec.h: no pairs; of every pair the smaller side at the start fixed at 0, the
// other ≥ 0).
class FixedThetaProblem final : public MpecProblem {
 public:
  FixedThetaProblem(const MpecEstimationProblem& p, const sim::VectorXd& theta,
                    const sim::VectorXd& start, bool keep_active_set = false)
      : p_(p), theta_(theta), start_(start), keep_(keep_active_set) {
    start_.head(theta.size()) = theta;
    if (keep_) {
      for (const auto& [a, b] : p.ComplementarityPairs()) {
        const int zero = start_[a] <= start_[b] ? a : b;
        zero_.push_back(zero);
        start_[zero] = 0.0;
      }
    }
  }
  int num_variables() const override { return p_.num_variables(); }
  int num_constraints() const override { return p_.num_constraints(); }
  void Bounds(sim::VectorXd* x_l, sim::VectorXd* x_u, sim::VectorXd* g_l,
              sim::VectorXd* g_u) const override {
    p_.Bounds(x_l, x_u, g_l, g_u);
    x_l->head(theta_.size()) = theta_;
    x_u->head(theta_.size()) = theta_;
    if (keep_) {
      for (const auto& [a, b] : p_.ComplementarityPairs()) {
        (*x_l)[a] = std::max((*x_l)[a], 0.0);
        (*x_l)[b] = std::max((*x_l)[b], 0.0);
      }
      for (int i : zero_) (*x_l)[i] = (*x_u)[i] = 0.0;
    }
  }
  sim::VectorXd StartingPoint() const override { return start_; }
  std::vector<std::pair<int, int>> ComplementarityPairs() const override {
    if (keep_) return {};
    return p_.ComplementarityPairs();
  }
  bool Objective(const sim::VectorXd& x, double* f) const override { return p_.Objective(x, f); }
  bool Gradient(const sim::VectorXd& x, sim::VectorXd* g) const override {
    return p_.Gradient(x, g);
  }
  bool Constraints(const sim::VectorXd& x, sim::VectorXd* g) const override {
    return p_.Constraints(x, g);
  }
  std::vector<Entry> JacobianStructure() const override { return p_.JacobianStructure(); }
  bool JacobianValues(const sim::VectorXd& x, sim::VectorXd* v) const override {
    return p_.JacobianValues(x, v);
  }
  bool has_hessian() const override { return p_.has_hessian(); }
  std::vector<Entry> HessianStructure() const override { return p_.HessianStructure(); }
  bool HessianValues(const sim::VectorXd& x, double obj_factor, const sim::VectorXd& lambda,
                     sim::VectorXd* values) const override {
    return p_.HessianValues(x, obj_factor, lambda, values);
  }

 private:
  const MpecEstimationProblem& p_;
  sim::VectorXd theta_, start_;
  bool keep_ = false;
  std::vector<int> zero_;  // keep_active_set: the sides fixed at 0
};

// The envelope gradient λᵀ ∂g/∂θ at a solution x with constraint multipliers lambda.
inline sim::VectorXd EnvelopeGradient(const MpecEstimationProblem& p, int ntheta,
                                      const sim::VectorXd& x, const sim::VectorXd& lambda) {
  sim::VectorXd grad = sim::VectorXd::Zero(ntheta);
  sim::VectorXd obj;
  if (p.Gradient(x, &obj)) grad = obj.head(ntheta);  // zero: the objective has no θ term
  sim::VectorXd J;
  if (!p.JacobianValues(x, &J)) return sim::VectorXd::Constant(ntheta, std::nan(""));
  const std::vector<Entry> s = p.JacobianStructure();
  for (std::size_t k = 0; k < s.size(); ++k)
    if (s[k].col < ntheta) grad[s[k].col] += lambda[s[k].row] * J[static_cast<int>(k)];
  return grad;
}

// The relaxation of the NLPs at fixed θ warm-started from a relaxed solution (the profile's
// points, a decomposed episode's next θ): ε at least this (the default homotopy's last stage).
// Below it the relaxation rows are relative (mpec.cc) and a fixed-θ NLP started 1–2 standard
// errors away must move pairs through the corner x_a x_b ≤ ε: measured on a 0.2 s block log
// at ε = 1e-11, 3 000 iterations without converging.
constexpr double kProfileEpsilon = 1e-8;

// The chosen parameters' covariance at a relaxed (unpolished) Scholtes solution `sol` of p
// (sol.relaxed set) from the curvature of the relaxed problem's profile
//
//   f(θ) = min over the other unknowns of the objective (χ², σ_R units) at fixed θ,
//
// at ε = max(sol.final_epsilon, 1e-8) (mpec_profile.cc), each point warm-started from sol:
// the diagonal of ∇²f by central differences of f at θ̂ and θ̂ ± δ_i e_i (δ_i 1% of max(|θ̂_i|, 0.01),
// within half the distance to θ's bounds, then rescaled once so that f rises by ~4, i.e. δ_i ~ 2
// standard errors), the off-diagonal entries from the envelope gradients at those points;
// covariance = 2 (∇²f)⁻¹, the Laplace approximation of the profile. Why: at a relaxed iterate every
// pair has a side near 0, and the reduced Hessian with those sides held can pin θ (measured on a
// tossed cube: s.e. 1e-7 against ~2e-3), while the profile lets the pairs change sides as θ
// moves. A θ at a bound has NaN rows. Returns false (with *why) if a fixed-θ NLP failed or the
// curvature is not positive; *iterations and *stages accumulate the NLPs'.
bool ProfileCovariance(const MpecEstimationProblem& p, const MpecSolution& sol,
                       const MpecSolverOptions& options, sim::MatrixXd* covariance, int* iterations,
                       int* stages, std::string* why);

// `covariance` (empty if none) times `scale` as a result's p × p covariance, and its diagonal's
// square roots in *std_errors; a parameter whose variance is not positive (or NaN) gets NaN in
// both (its row and column) — except an exactly zero variance when `zero_is_defined` (a
// bootstrap whose resamples all agree: standard error 0).
sim::MatrixXd CovarianceWithStdErrors(const sim::MatrixXd& covariance, Eigen::Index p, double scale,
                                      sim::VectorXd* std_errors, bool zero_is_defined = false);

// The reason's suffix for parameters whose Laplace standard error is NaN: each such parameter
// named, at a bound of its range [lower, upper] (an estimate within 1e-9 of it) or with a
// non-positive variance; or, without a covariance at all (every standard error NaN), the failed
// KKT solves. "" if every standard error is a number.
std::string MissingStdErrors(const std::vector<std::string>& names, const sim::VectorXd& estimates,
                             const sim::VectorXd& std_errors, const sim::VectorXd& lower,
                             const sim::VectorXd& upper, bool have_covariance);

// The least-squares fit of MpecOptions::least_squares_start.
LeastSquaresOptions StartFitOptions(const MpecOptions& o);

// The measured residuals' degrees of freedom: num_residuals − p, p = num_params + the observed
// dynamic bodies' initial-state components over the log's episodes.
int ResidualDof(const sim::Simulator& simulator, const Log& log, int num_params, int num_residuals);

// The σ an MPEC result's standard errors use (r->sigma), and whether its measurement residuals
// contradict a stated noise σ (> 0). ss = Σ r² over r->num_residuals measured residuals, with
// dof = r->num_residuals − p, p = num_params + the observed dynamic bodies' initial-state
// components over the log's episodes. Contradicted as internal::ResidualsContradictNoise decides
// (the least squares' test): r->reason gets the explanation, r->sigma is σ̂ = √(ss / dof), and
// the result is not converged (r->noise_contradicted if it was); otherwise r->sigma is the
// stated σ (σ̂ without one). The process noise w only lowers ss (it absorbs part of the
// residuals), so the test errs on the side of accepting.
void SetResidualSigma(const sim::Simulator& simulator, const Log& log, int num_params,
                      double stated_sigma, double ss, MpecEstimateResult* r);

}  // namespace mpec_internal

struct MpecEstimationProblem::Impl {
  using ResidualRow = mpec_internal::ResidualRow;
  using StepBlock = mpec_internal::StepBlock;
  using Params = sim::Params;
  using State = sim::State;
  using VectorXd = sim::VectorXd;

  const sim::Simulator& sim;
  const sim::Scene& scene;
  MpecOptions opts;
  double sigma = mpec_internal::kDefaultSigma, sigma_q = 1.0;
  double margin = 0.0;  // added to the envelope for the frozen contact sets
  sim::ParamSelection sel;
  Params base;
  int ntheta = 0, nq = 0, nv = 0, nx = 0;
  int n = 0, m = 0;
  int num_episodes = 0;
  std::vector<int> x0_col;                  // per episode
  std::vector<std::vector<double>> node_t;  // per episode, node times
  std::vector<std::vector<int>> node_col;   // per episode, node state columns
  std::vector<StepBlock> steps;
  std::vector<ResidualRow> residuals;
  std::vector<int> w_cols;  // first column of every w block
  // Quaternion-norm rows: (row, first column of the 4 quaternion entries).
  std::vector<std::pair<int, int>> quat_rows;
  int quat_jac_offset = 0;
  std::vector<std::pair<int, int>> pairs;
  VectorXd x_l, x_u, start;  // in the solver's (scaled) variables
  // Per unknown its typical magnitude: the solver's variables are y = x / scale (x physical).
  VectorXd scale;
  // Constant objective Hessian (lower triangle) and quaternion-row diagonal positions.
  std::vector<Entry> hess;
  VectorXd hess_obj;
  std::vector<std::pair<int, int>> hess_quat;  // (entry, constraint row)
  std::vector<Entry> jac;
  // Per-formulation cache for steps whose h differs from the scene's dt.
  struct Stepper {
    std::unique_ptr<sim::Formulation> formulation;
    std::shared_ptr<const sim::Scene> model;
  };
  std::map<double, Stepper> steppers;
  // The scene with base params (dt steps), shared by the steps' frozen models (one scene for
  // every step: StepModel's applied-parameter scene is then made once per θ, not once per step).
  std::shared_ptr<const sim::Scene> model_dt;
  // Evaluation caches.
  mutable VectorXd cache_g_x, cache_g, cache_j_x, cache_j;
  mutable bool cache_g_ok = false, cache_j_ok = false;
  mutable double max_dropped = 0.0;  // largest Jacobian entry outside the structure

  Impl(const sim::Simulator& s, const MpecOptions& o)
      : sim(s), scene(s.scene()), opts(o), sel(s.scene().param_table(), o.params) {}

  VectorXd Physical(const VectorXd& y) const { return y.cwiseProduct(scale); }

  Params Theta(const VectorXd& x) const {
    VectorXd th = x.head(ntheta);
    for (int i = 0; i < ntheta; ++i) th[i] = std::clamp(th[i], sel.lower()[i], sel.upper()[i]);
    return sel.Set(base, th);
  }

  State NodeState(const VectorXd& x, int col, double t) const {
    State st;
    st.t = t;
    st.q = x.segment(col, nq);
    st.v = x.segment(col + nq, nv);
    return st;
  }

  sim::StepModelValues EvaluateStep(const StepBlock& b, const VectorXd& x, const Params& theta,
                                    bool jacobians) const {
    sim::StepModelValues v;
    EvaluateStepInto(b, x, theta, jacobians, &v);
    return v;
  }
  // EvaluateStep into *out, its storage reused (the step's z, x_ℓ and input in the calling
  // thread's storage).
  void EvaluateStepInto(const StepBlock& b, const VectorXd& x, const Params& theta, bool jacobians,
                        sim::StepModelValues* out) const {
    struct Arguments {
      sim::StepInput u;
      State x;
      VectorXd z;
    };
    thread_local Arguments a;
    a.u.generalized_force = x.segment(b.w_col, nv);
    a.x.t = b.t;
    a.x.q = x.segment(b.x_col, nq);
    a.x.v = x.segment(b.x_col + nq, nv);
    a.z = x.segment(b.z_col, b.nz);
    sim::StepModelOptions so;
    so.jacobians = jacobians;
    so.state_jacobian = jacobians;
    // The ν_ℓ columns by central differences, as before the closed form: with the closed form
    // (the same Jacobian to ~3e-11 relative) the penalty NLP of the noise-free planar block
    // (mpec_test) ends its ρ = 10 solve in Ipopt's restoration failure at an essentially
    // converged point (inf_pr 8e-15, complementarity 1e-12), which the homotopy rejects, and the
    // restart from ρ = 100 ends at a worse point (rms residual 6.7e-5).
    so.closed_form_velocity = false;
    b.model->EvaluateInto(a.z, theta, a.x, a.u, so, out);
  }

  // Visits the model's Jacobian entries of one step as (local row, local col, value); comp rows
  // that are pure variables are skipped. Local columns: z | θ (chosen) | x | w.
  template <class F>
  void ForEachEntry(const StepBlock& b, const sim::StepModelValues& v, const F& f) const {
    const int oz = 0, ot = b.nz, ox = b.nz + ntheta, ow = b.nz + ntheta + nx;
    auto group = [&](const sim::StepModelJacobian& J, auto row_of, double sign) {
      auto block = [&](const sim::SparseMatrixXd& M, int off, bool theta) {
        for (int c = 0; c < M.outerSize(); ++c) {
          int lc = off + c;
          if (theta) {
            const int k = b.theta_map[c];
            if (k < 0) continue;
            lc = ot + k;
          }
          for (sim::SparseMatrixXd::InnerIterator it(M, c); it; ++it) {
            const int lr = row_of(static_cast<int>(it.row()));
            if (lr >= 0) f(lr, lc, sign * it.value());
          }
        }
      };
      block(J.d_z, oz, false);
      block(J.d_theta, 0, true);
      block(J.d_x, ox, false);
      block(J.d_u, ow, false);
    };
    group(
        v.d_equality, [](int r) { return r; }, 1.0);
    group(
        v.d_comp_a, [&](int r) { return b.a_slack[r] < 0 ? -1 : b.neq + b.a_slack[r]; }, -1.0);
    group(
        v.d_comp_b, [&](int r) { return b.b_slack[r] < 0 ? -1 : b.neq + b.b_slack[r]; }, -1.0);
  }

  bool IsStateColumn(const StepBlock& b, int lc) const {
    return lc >= b.nz + ntheta && lc < b.nz + ntheta + nx;
  }
  int GlobalCol(const StepBlock& b, int lc) const {
    if (lc < b.nz) return b.z_col + lc;
    lc -= b.nz;
    if (lc < ntheta) return lc;
    lc -= ntheta;
    if (lc < nx) return b.x_col + lc;
    return b.w_col + (lc - nx);
  }
  long long Key(const StepBlock& b, int lr, int lc) const {
    return static_cast<long long>(lr) * (b.nz + ntheta + nx + nv) + lc;
  }

  const sim::Formulation& FormulationFor(double h, std::shared_ptr<const sim::Scene>* model) {
    if (h == scene.options.dt && margin == 0.0) {
      *model = model_dt;
      return sim.formulation();
    }
    // Intervals equal to 1e-9 relative (a log's times accumulate rounding) share one stepper.
    auto it = steppers.lower_bound(h * (1 - 1e-9));
    if (it == steppers.end() || it->first > h * (1 + 1e-9)) {
      sim::Scene s = scene;
      s.options.dt = h;
      s.options.envelope += margin;
      Stepper st;
      st.formulation = sim::MakeFormulation(s.options);
      st.model = std::make_shared<const sim::Scene>(s.ApplyParams(base));
      it = steppers.emplace(h, std::move(st)).first;
    }
    *model = it->second.model;
    return *it->second.formulation;
  }

  void Build(const Log& log);
  // MpecOptions::tracking_guess: replaces guess[1..] by a simulation from guess[0] tracking the
  // observed bodies' guessed poses; returns each step's tracking force (the guess of w). A
  // failed step ends the tracking there (the later nodes keep their guess, their w is 0).
  std::vector<VectorXd> TrackGuess(const Episode& ep, const std::vector<double>& step_h,
                                   std::vector<State>* guess);
  // MpecOptions::start_states: replaces the guess by the model's rollout from x0 (w = 0); a
  // failed step ends it there (the later nodes keep the log's poses).
  void RolloutGuess(const State& x0, const std::vector<double>& step_h, std::vector<State>* guess);
  void BuildStructure();
};

}  // namespace vinci::estimation
