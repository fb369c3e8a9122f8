// The frozen, sparse step model: one step's equations with the contact set found once at x_ℓ,
// for estimators and sensitivity checks (docs/formulations.md; issue 12 item 5).
//
// Formulation::Evaluate re-detects contacts at its x, so the number of unknowns changes as an
// optimizer moves the states. Freeze() finds the contact set (GI: the candidate pairs) once at
// x_ℓ; StepModel::Evaluate then evaluates the formulation's own step equations — through the
// same assembly and residual code as Formulation::Evaluate, which the simulator's Step solves —
// with that set held fixed while the step unknowns z, the parameters θ and the start state x_ℓ
// move. At x_ℓ = the freeze state (bitwise q and t) the equations are exactly
// Formulation::Evaluate's.
//
// Moving x_ℓ with the contact set fixed (Stewart–Trinkle, Anitescu–Potra, first order, NCP,
// quasistatic): each contact keeps its bodies, shapes and (corner) edge choice; its witness
// points and normal are those the collision routine finds at x for the same pair of shapes,
// nearest the rigidly moved ones (so a rolling disc's contact point stays at its bottom and a
// normal follows the face that carries it; rigidly moved — points with their bodies, normal(s)
// with body B — for corner contacts and where no such contact is found; a polytope vertex–face
// contact, e.g. box on box, keeps its vertex: only candidates at that rigidly moved vertex are
// taken, so flush boxes, where "a's vertex on b's face" and "b's vertex on a's face" coincide,
// do not switch features with the direction of the move), and its gap becomes
//   ψ(x) = ψ_ℓ + n(x)·(p_A(x) − p_B(x)) − n_ℓ·(p_A,ℓ − p_B,ℓ),
// which has the exact first derivative of the signed distance for any contact whose features
// stay active. The contact Jacobians G(x) then have the derivatives of the re-detected ones.
// GI: the pairs, their closest points at the freeze (tangent reference, compliant law constant)
// and the solver form's tie-breaker reference stay fixed; the contact points are GI unknowns
// anyway.
//
// Jacobian columns (all sparse, Eigen column-major): z (layout().size()), θ (the differentiable
// parameters param_columns(): friction coefficients, support friction μ_s, masses; analytic, as
// Formulation::Evaluate), x_ℓ = [q_ℓ (nq of the State); ν_ℓ (nv)] (central differences of the
// frozen equations, step StepModelOptions::state_step · max(1, |x_i|): exact to ~1e-8 relative
// since the frozen equations are smooth in x_ℓ; the ν_ℓ columns of the Stewart–Trinkle family in
// closed form: only the dynamics rows M(ν_ℓ+1 − ν_ℓ) − p_ext read ν_ℓ, so ∂/∂ν_ℓ = −M and, for a
// spatial body's angular rows, + h ∂(ω × Iω)/∂ω = h([ω]× I − [Iω]×) from the gyroscopic impulse;
// first order: 0) and the input u = StepInput::generalized_force (analytic: the dynamics rows
// carry −h u in every formulation).
#pragma once

#include <Eigen/SparseCore>
#include <memory>
#include <vector>

#include "vinci/sim/formulations/formulation.h"

namespace vinci::sim {

using SparseMatrixXd = Eigen::SparseMatrix<double>;

/// What StepModel::Evaluate computes besides the values.
struct StepModelOptions {
  bool jacobians = true;       ///< the z, θ and u blocks
  bool state_jacobian = true;  ///< the x_ℓ block (2 (nq + nv) extra evaluations); needs jacobians
  double state_step = 1e-7;    ///< relative central-difference step of the x_ℓ block; > 0
  /// The ν_ℓ columns of the x_ℓ block in closed form where the model has them (Stewart–Trinkle,
  /// Anitescu–Potra, first order: only the dynamics rows read ν_ℓ); false, or another model:
  /// central differences as for q_ℓ.
  bool closed_form_velocity = true;
};

/// One row group's derivatives, by column group.
struct StepModelJacobian {
  SparseMatrixXd d_z;      ///< rows × layout().size()
  SparseMatrixXd d_theta;  ///< rows × param_columns().size()
  SparseMatrixXd d_x;      ///< rows × (nq + nv) of the State: [q_ℓ; ν_ℓ]
  SparseMatrixXd d_u;      ///< rows × nv: StepInput::generalized_force
};

/// The step equations at a point: equality = 0 and 0 ≤ comp_a ⊥ comp_b ≥ 0 (the rows and pairs
/// of the formulation's Evaluate, documented in its header). Jacobian blocks are empty (0 × 0)
/// when not requested.
struct StepModelValues {
  VectorXd equality, comp_a, comp_b;
  StepModelJacobian d_equality, d_comp_a, d_comp_b;
  /// max(|equality|_∞, |min(comp_a, comp_b)|_∞)
  double Violation() const;
};

/// A step frozen at x_ℓ (make one with Freeze()). Immutable; Evaluate is const and thread-safe.
class StepModel {
 public:
  virtual ~StepModel() = default;

  /// Unknowns z of the frozen contact set (the formulation's StepLayout).
  const StepLayout& layout() const { return layout_; }
  /// ParamTable indices of the θ columns.
  const std::vector<int>& param_columns() const { return param_columns_; }
  /// The freeze state x_ℓ and input.
  const State& x_freeze() const { return x_; }
  const StepInput& input() const { return u_; }
  /// Contacts (GI: candidate pairs) held fixed.
  int num_contacts() const { return layout_.nc; }
  /// Frozen contacts at a feature switch of the contact geometry (Stewart–Trinkle family and
  /// NCP; 0 otherwise): polytope vertex–face contacts whose face witness lies within 1e-6 m of
  /// that face's boundary — e.g. flush equal boxes, a vertex of one on a vertex of the other.
  /// The frozen model holds each such contact's vertex (smooth in x_ℓ), but the collision
  /// routine at a moved x_ℓ may report other features there: the step is one-sided in x_ℓ.
  int feature_kinks() const { return feature_kinks_; }

  /// The step equations at (z, θ, x_ℓ) with the frozen input. Throws std::invalid_argument for
  /// sizes that do not match (z: layout().size(); θ: the scene's ParamTable; x: the scene's
  /// state), x.t ≠ x_freeze().t (time is not a variable: prescribed bodies stay where they are
  /// at the freeze) or an out-of-range θ. x.warm_start is ignored.
  StepModelValues Evaluate(const VectorXd& z, const Params& theta, const State& x,
                           const StepModelOptions& options = {}) const;
  /// Same with input u (empty = 0, else num_velocities() entries).
  StepModelValues Evaluate(const VectorXd& z, const Params& theta, const State& x,
                           const StepInput& u, const StepModelOptions& options = {}) const;
  /// Evaluate into *out, its storage (vectors and sparse matrices) reused: the same values and
  /// entries. Every field is overwritten.
  void EvaluateInto(const VectorXd& z, const Params& theta, const State& x, const StepInput& u,
                    const StepModelOptions& options, StepModelValues* out) const;

  /// The formulation's own residuals at (z, x_ℓ) with the freeze parameters θ and input u: the
  /// values and, if `jacobians`, the dense Jacobians with columns [z; θ] (StepResiduals, no
  /// x_ℓ block; the θ columns are param_columns()). Evaluate without the sparse conversion, for
  /// the step sensitivities. Throws std::invalid_argument for sizes that do not match, θ other
  /// than the freeze parameters or x.t ≠ x_freeze().t.
  StepResiduals EvaluateResiduals(const VectorXd& z, const Params& theta, const State& x,
                                  const StepInput& u, bool jacobians) const;

  /// ∂r/∂x_ℓ · s at (z, the freeze parameters, x_freeze(), u): central differences of the
  /// frozen equations along s = [q; ν] direction with step `step` (values only: the value fields
  /// of the result hold the derivative, the Jacobians are empty). Stewart–Trinkle family and
  /// NCP: contacts whose shape pair has a closed-form rate (geometry/contact_rate.h) move along
  /// it, c ± step ċ — the derivative of the re-collided contacts, to O(step²) — and are not
  /// re-collided; the others are, as in Evaluate. Throws std::invalid_argument for sizes that
  /// do not match or step ≤ 0.
  StepResiduals StateDirectionalDerivative(const VectorXd& z, const StepInput& u, const VectorXd& s,
                                           double step) const;

  /// ∂r/∂ν_ℓ in closed form at (the freeze parameters, x_freeze()), written into columns
  /// [col, col + nv) of *d_equality, *d_comp_a and *d_comp_b (zero there on entry), if the
  /// formulation has it (the Stewart–Trinkle family, as StepModelOptions::closed_form_velocity):
  /// else false (nothing written).
  bool FreezeVelocityColumns(int col, MatrixXd* d_equality, MatrixXd* d_comp_a,
                             MatrixXd* d_comp_b) const {
    return VelocityColumns(*model_, x_, col, d_equality, d_comp_a, d_comp_b);
  }

  /// The unknowns z of a step the simulator took from x_freeze() to `next` (read from next.q,
  /// next.v and next.warm_start, the step's solver solution; impulses the solver eliminates,
  /// the joint impulses p_b, are recovered from the dynamics rows by least squares). Throws
  /// std::invalid_argument if next does not fit this step (sizes, warm start of another
  /// contact set).
  VectorXd UnknownsFromStep(const State& next) const;
  /// The end-of-step state a step with unknowns z writes: t + h, q_ℓ+1, ν_ℓ+1 and the warm
  /// start (the solver's unknowns) — StateFromUnknowns(UnknownsFromStep(next)) reproduces next.
  State StateFromUnknowns(const VectorXd& z) const;
  /// The same with the start state x in place of x_freeze() (same sizes and time): GI writes a
  /// spatial body's orientation relative to R_ℓ (R_ℓ+1 = R_ℓ Exp(φ)), so its end state depends on
  /// x_ℓ explicitly; every other formulation's does not (x is ignored).
  State StateFromUnknowns(const VectorXd& z, const State& x) const;

 protected:
  StepModel(std::shared_ptr<const Scene> model, Params params, State x, StepInput u, double dt);
  /// Completes construction: layout and parameter columns from an evaluation at z = 0.
  void Init(int num_unknowns);
  /// Completes construction with a known layout and θ columns (no evaluation).
  void InitLayout(StepLayout layout, std::vector<int> param_columns);
  /// The formulation's residuals at x with the frozen contact set, on `model` (θ applied);
  /// `jacobians` false: the values are enough (a model may skip the Jacobians then).
  virtual StepResiduals Residuals(const Scene& model, const Params& theta, const State& x,
                                  const StepInput& u, const VectorXd& z, bool jacobians) const = 0;
  /// Residuals(model, θ, x, u, z, jacobians) into *out, its storage reused (default: a copy of
  /// Residuals'; a model may evaluate in place). The same numbers.
  virtual void ResidualsInto(const Scene& model, const Params& theta, const State& x,
                             const StepInput& u, const VectorXd& z, bool jacobians,
                             StepResiduals* out) const;
  /// ∂r/∂ν_ℓ in closed form at x on `model` (θ applied), written into columns [col, col + nv)
  /// of *d_equality, *d_comp_a and *d_comp_b (zero there on entry), if the model has it: else
  /// false (nothing written; Evaluate takes central differences). Default: false.
  virtual bool VelocityColumns(const Scene& model, const State& x, int col, MatrixXd* d_equality,
                               MatrixXd* d_comp_a, MatrixXd* d_comp_b) const;
  /// The residual values at x_freeze() + t s with the freeze θ (default: Residuals there).
  virtual StepResiduals ResidualsAlong(const VectorXd& z, const StepInput& u, const VectorXd& s,
                                       double t) const;
  /// x_freeze() + t s (s = [q; ν] direction).
  State StateAlong(const VectorXd& s, double t) const;
  virtual VectorXd Unknowns(const State& next) const = 0;
  virtual VectorXd WarmStart(const VectorXd& z) const = 0;
  /// ν_ℓ+1, q_ℓ+1 written from z with start state x (default: the z blocks; GI overrides).
  virtual State EndState(const VectorXd& z, const State& x) const;
  /// Recovers the p_b block of z from the dynamics rows (least squares through G_b).
  void RecoverJointImpulses(const MatrixXd& G_b, VectorXd* z) const;

  std::shared_ptr<const Scene> model_;  ///< scene with the freeze parameters applied
  Params params_;
  State x_;
  StepInput u_;
  double dt_ = 0.0;
  StepLayout layout_;
  std::vector<int> param_columns_;
  int feature_kinks_ = 0;
};

/// Freezes `formulation`'s step at x (contacts / GI pairs found once at x). `model` is the scene
/// with `params` applied (as for Formulation::Evaluate). Every formulation with an Evaluate is
/// supported: Stewart–Trinkle, Anitescu–Potra, first order, NCP, quasistatic DLC/DQC,
/// dynamic DQC and GI. The model keeps a reference to `formulation`, which must outlive it (a
/// Simulator's formulation() lives as long as the Simulator). Throws std::invalid_argument for
/// another Formulation, mismatched sizes or a scene the formulation rejects.
std::unique_ptr<StepModel> Freeze(const Formulation& formulation, const Scene& model,
                                  const Params& params, const State& x, const StepInput& u = {});
/// Freeze() sharing `model` (e.g. a Workspace's resolved scene) instead of copying it.
std::unique_ptr<StepModel> Freeze(const Formulation& formulation,
                                  std::shared_ptr<const Scene> model, const Params& params,
                                  const State& x, const StepInput& u = {});

}  // namespace vinci::sim
