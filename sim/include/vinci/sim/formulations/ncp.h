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
// e_t = e_o = 1 is the isotropic cone, e_t ≠ e_o the elliptic one (Howe–Cutkosky, no
// torsion); planar scenes fix p_o = 0. Torsional friction (p_r) is not modelled.
//
// The step is solved as an MCP in z = [p_n (n_c); (p_t, p_o) per contact (2 n_c); σ (n_c)]
// (p_n, σ ≥ 0; p_t, p_o free) after eliminating ν and p_b as in the Stewart–Trinkle LCP, by
// McpSolver, with three tiny regularizations (ε_n, ε_t, ε_σ: NcpOptions) and, by default, rows
// and unknowns nondimensionalized by the step's impulse and velocity scales P and V.
// Evaluate() checks the exact equations above. Starts, in order: the previous step's solution
// (State::warm_start, if its size matches), the free-slip start, the Stewart–Trinkle LCP
// solution of the step (LCP solver named by the scene); a failed attempt is retried with the
// unloaded contacts frictionless ("polish"). The first converged attempt is accepted
// (SolverReport::message lists the failed ones); if all fail, StepInfo::ok = false with every
// reason. Details and the regularizations' values: docs/formulations.md §2; why the scaling and
// McpSolver's Levenberg–Marquardt step are needed: bench/README.md, vinci_ncp_bench.
// Scenes with 2.5D support friction or concave-polygon corner contacts are rejected
// (capabilities(); docs/formulations.md §13).
#pragma once

#include <memory>

#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {

namespace internal {
struct NcpData;  // the MCP function's numbers (ncp.cc)
}  // namespace internal

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
  bool scale_rows = true;  ///< nondimensionalize the MCP by P and V (docs/formulations.md §2)
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
  /// Evaluate() for an assembly of assembler() made at x (Evaluate = EvaluateAssembly(
  /// assembler().Assemble(x))).
  StepResiduals EvaluateAssembly(const Scene& model, const Params& params,
                                 const StewartTrinkle::Assembly& a, const State& x,
                                 const VectorXd& z) const;
  /// EvaluateAssembly's layout for the assembly `a` (its contacts and joint rows), nd = 2.
  static StepLayout LayoutOfAssembly(const Scene& model, const StewartTrinkle::Assembly& a);
  /// The Stewart–Trinkle stepper (n_d = 4) that assembles this stepper's contact rows.
  const StewartTrinkle& assembler() const { return st_; }

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
  // Build's problem into *sp and *d (storage reused; the MCP's evaluate and sparse_jacobian are
  // left for the caller to bind to *d, and d->A_sparse is not formed).
  void BuildInto(const Scene& model, const State& x, const StepInput& u, StepProblem* sp,
                 internal::NcpData* d) const;
  StepperOptions options_;
  NcpOptions ncp_;
  StewartTrinkle st_;  // assembly and the fallback LCP (n_d = 4)
  std::shared_ptr<const LcpSolver> lcp_solver_;
  McpSolver mcp_, mcp_sparse_;  // dense / sparse Newton systems
};

}  // namespace vinci::sim
