// The NCP time-stepper with the quadratic (isotropic or elliptic) friction cone, solved as a
// box-constrained MCP by the semismooth Newton solver (mcp.h).
//
// Discrete equations (docs/formulations.md §2; Trinkle, Pang, Sudarsky, Lo, ZAMM 77, 1997; Trinkle,
// Tzitzouris, Pang, Phil. Trans. R. Soc. A 359, 2001), contacts found at q_ℓ within the envelope
// ε, per contact an orthonormal tangent pair (t, o) ⟂ n (the first two Stewart–Trinkle
// directions of n_d = 4; planar: t only):
//
//   M ν_ℓ+1 = M ν_ℓ + G_n p_n + G_t p_t + G_o p_o + G_b p_b + p_ext + p_vp
//   0 = G_bᵀ ν_ℓ+1 + ψ_b/h + ∂ψ_b/∂t
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ψ_n/h + ∂ψ_n/∂t ≥ 0          (compliant pairs: compliance.h row)
//   0 = e_t² μ p_n (G_tᵀ ν_ℓ+1 + ∂ψ_t/∂t) + p_t σ
//   0 = e_o² μ p_n (G_oᵀ ν_ℓ+1 + ∂ψ_o/∂t) + p_o σ
//   0 ≤ σ ⊥ μ² p_n² − p_t²/e_t² − p_o²/e_o² ≥ 0
//   q_ℓ+1 = q_ℓ + h G(q_ℓ) ν_ℓ+1
//
// e_t = e_o = 1 is the isotropic (quadratic) cone: a sliding contact has slip speed σ and
// friction μ p_n exactly opposite the slip, in any direction. e_t ≠ e_o gives the elliptic cone
// (Howe–Cutkosky limit surface without torsion). Planar scenes use the same equations with p_o
// fixed at 0 (the cone is |p_t| ≤ μ p_n and the step equals the LCP's for point contacts).
// Torsional friction (p_r) is not modelled.
//
// The MCP: ν and p_b are eliminated exactly as in the Stewart–Trinkle LCP (joints through the
// Schur complement), leaving F(z), z = [p_n (n_c); (p_t, p_o) per contact (2 n_c); σ (n_c)]
// with p_n, σ ∈ [0, ∞) and p_t, p_o free. To keep the Newton matrix regular where the step is
// degenerate (p_n = 0: σ undetermined; redundant contacts of a box: p_n not unique) the solver
// adds three tiny terms, reported in NcpOptions: ε_n p_n to each normal row, ε_t p_t (ε_o p_o) to
// the friction rows and ε_σ σ to the cone row. They bias the solution by at most ε_n p_n (normal
// velocity), a sticking creep ≤ ε_t (m/s) and a relative friction-magnitude error ε_σ σ/(μ p_n)²;
// the slip direction is exact. Evaluate() checks the exact equations above.
//
// Scaling (NcpOptions::scale_rows, on by default): the MCP is solved in dimensionless unknowns
// p̂ = p/P, σ̂ = σ/V with rows F̂_n = u_n/V, F̂_f = F_f/(P V), F̂_σ = F_σ/P², where
// P = max(‖p_ext‖_∞, max_c (−b_n,c)/W_cc, 1e-6 N·s) (the step's impulse scale: external impulse
// or the impulse that stops the fastest free approach) and V = max(P max_c W_cc, ‖b‖_∞,
// 1e-9 m/s) (its velocity scale: the velocity change P causes, or the fastest free contact
// velocity), W the Delassus matrix and b the free contact velocities. The solver's tolerance
// (1e-10) is then relative: normal velocities to 1e-10 V, slip rows to 1e-10 P V, cone rows to
// 1e-10 P². Unscaled, a light part's rows differ by orders of magnitude (box on the vibrating
// plate, P = 4e-5 N·s: u_n ~ 1e-4 m/s, friction rows ~ 1e-7, cone rows ~ 1e-12, i.e. below the
// absolute tolerance, so σ was unconstrained) and the merit ½‖Φ‖² saw only the normal rows; the
// Newton iterates ended at p_t = σ = 0 with the box sliding, a stationary point of the merit
// (the σ p_t product has a saddle there). With scaling ε_t stays a creep speed (m/s) and
// ε_σ = cone_regularization · P²/V; without it (scale_rows = false) the rows are as above in
// SI units and ε_σ = cone_regularization · p_ref².
//
// Robustness: the MCP starts from the previous step's (p_n, p_t, p_o, σ) (State::warm_start,
// when its size matches the contact set); if that fails (or there is none) from the free-slip
// start (impulses 0, σ_c the slip speed of contact c at zero impulse, which keeps Newton off the
// p_t = σ = 0 saddle of a sliding contact); then from
// the Stewart–Trinkle LCP solution of the same step (n_d = 4, LCP solver named by the scene)
// mapped to (p_t, p_o). After a failed attempt the solve is "polished": contacts whose p_n
// is below 1e-6 p_ref (unloaded: the squared cone's apex is degenerate, resolving p_t only to
// √(tol p_ref)) get p_t = p_o = σ = 0 fixed, the reduced MCP is solved from the attempt's best
// point, and the result is accepted only if it solves the FULL MCP to tolerance. The first
// converged attempt is accepted (SolverReport::message lists the failed ones); if all fail the
// step returns StepInfo ok = false with every reason.
// Redundant contacts (a box on four corners: p_n, and while it sticks p_t, not unique) leave
// the Newton matrix with singular values ~ε near the solution; McpSolver's Levenberg–Marquardt
// step (mcp.h) crosses these nearly flat directions where the Newton step fails its descent
// test (measured: the box on the vibrating plate, docs/field.md).
#pragma once

#include <memory>

#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {

struct NcpOptions {
  double e_t = 1.0;  ///< elliptic-cone ratio along t (1: isotropic); > 0
  double e_o = 1.0;  ///< elliptic-cone ratio along o; > 0
  McpOptions mcp;    ///< the semismooth Newton solver's options
  /// ε_n relative to the largest diagonal entry of the Delassus matrix G_nᵀ W G_n (rigid
  /// normal rows only; compliant rows are regular).
  double normal_regularization = 1e-10;
  double tangent_regularization = 1e-10;  ///< ε_t = ε_o (m/s)
  /// Scaled: ε̂_σ = this, i.e. ε_σ = this · P²/V; unscaled: ε_σ = this · p_ref² (N²·s³/m),
  /// p_ref = max(‖p_ext‖_∞, 1e-6 N·s).
  double cone_regularization = 1e-10;
  bool scale_rows = true;  ///< nondimensionalize the MCP by P and V (see the file comment)
  /// Steps with at least this many contacts use the sparse Jacobian (McpProblem::sparse_jacobian,
  /// SparseLU); smaller ones the dense one.
  int sparse_min_contacts = 16;
};

class NcpStepper final : public Formulation {
 public:
  /// Throws std::invalid_argument for an unknown options.solver (the fallback LCP solver) or
  /// non-positive ellipticities.
  explicit NcpStepper(StepperOptions options, NcpOptions ncp = {});
  std::string_view name() const override { return "ncp"; }
  FormulationCapabilities capabilities() const override {
    return CapabilitiesOf(options_.formulation);
  }
  void Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws, State* next,
            StepInfo* info) const override;
  /// The equations in the file comment, z in StepLayout order with nd = 2, p_f = (p_t, p_o) per
  /// contact. Equalities: [dynamics (nv); kinematics (nq); joints (nb); friction (2 nc: t, o per
  /// contact; planar o row is p_o = 0)]. Complementarity: [(p_n, normal row) (nc); (σ, cone)
  /// (nc)].
  StepResiduals Evaluate(const Scene& model, const Params& params, const State& x,
                         const StepInput& u, const VectorXd& z) const override;
  StepLayout Layout(const Scene& model, const State& x) const override;

  /// One step's MCP and what is needed to recover ν_ℓ+1 from its solution.
  struct StepProblem {
    StewartTrinkle::Assembly assembly;  ///< n_d = 4 (planar 2): columns 0, 1 of each contact
    LcpProblem lcp;                     ///< the Stewart–Trinkle LCP of the same step
    VectorXd v_star;
    StewartTrinkle::JointElimination joints;
    McpProblem mcp;  ///< size 4 n_c, analytic dense and sparse Jacobians, unknowns z ⊘ scale
    VectorXd scale;  ///< (P (3 n_c), V (n_c)); all ones without NcpOptions::scale_rows
  };
  /// Builds the step's problem at x (exposed for tests and benchmarks).
  StepProblem Build(const Scene& model, const State& x, const StepInput& u) const;
  /// ν_ℓ+1 for an MCP solution z (size 4 n_c).
  VectorXd VelocityAfter(const StepProblem& sp, const VectorXd& z) const;
  /// The MCP start (p_n, p_t, p_o, σ) equivalent to a Stewart–Trinkle LCP solution.
  VectorXd FromLcpSolution(const StepProblem& sp, const VectorXd& z_lcp) const;

  /// The free-slip start: impulses 0, σ_c the slip speed of contact c without contact impulses.
  VectorXd FreeSlipStart(const StepProblem& sp) const;

  const NcpOptions& ncp_options() const { return ncp_; }

 private:
  StepperOptions options_;
  NcpOptions ncp_;
  StewartTrinkle st_;  // assembly and the fallback LCP (n_d = 4)
  std::shared_ptr<const LcpSolver> lcp_solver_;
  McpSolver mcp_, mcp_sparse_;  // dense / sparse Newton systems
};

}  // namespace vinci::sim
