// Quasistatic time-steppers Model-DLC and Model-DQC (docs/formulations.md §5; Pang, Trinkle & Lo,
// ZAMM 76, 1996; Tzitzouris & Pang, Phil. Trans. R. Soc. A 360, 2002), planar scenes.
//
// Inertia is dropped: position-controlled (prescribed) bodies drive the motion through ∂ψ/∂t
// and the dynamic bodies move so that the impulses balance in every step. The unknown ν_ℓ+1 is
// the displacement of the step divided by h. Contacts are found at q_ℓ within the envelope ε:
//
//   0 = ε_M M ν_ℓ+1 − (G_n p_n + G_f p_f + G_b p_b + G_s p_s + p_ext)
//   0 = G_bᵀ ν_ℓ+1 + ψ_b/h + ∂ψ_b/∂t
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ψ_n/h + ∂ψ_n/∂t ≥ 0
//   0 ≤ p_f ⊥ G_fᵀ ν_ℓ+1 + E σ + ∂ψ_f/∂t ≥ 0
//   0 ≤ σ   ⊥ U p_n − Eᵀ p_f ≥ 0
//   support friction (docs/formulations.md §6): DLC the linearized rows, DQC the exact disks
//   q_ℓ+1 = q_ℓ + h ν_ℓ+1
//
// with p_ext = h (m g + F_applied + u). Planar contact friction (d = ±t) is exact, so DLC and
// DQC differ only in the support disks. ε_M = kQuasistaticRegularization is a vanishing
// inertia that keeps the step well posed when a body's motion is not determined by its
// constraints (a disc free to spin about its only support point). The step is an MCP in
// y = [ν; p_n; p_f; σ; p_b; p_s; σ_s]: DLC's (linear) is solved as an LCP by the scene's LCP
// solver after splitting the free unknowns, DQC's by McpSolver from the previous step's y, then
// from the DLC solution of the step. Planar scenes only (std::invalid_argument otherwise).
// State::v after a step is ν_ℓ+1 (the mean velocity over the step); State::warm_start holds y.
//
// The same class provides "dynamic-dqc" (FormulationType::kDynamicDqc): the Stewart–Trinkle
// dynamics with the EXACT support-friction disks, an NCP solved by McpSolver — the first line
// above becomes 0 = M (ν_ℓ+1 − ν_ℓ) − (G_n p_n + G_f p_f + G_b p_b + G_s p_s + p_ext).
// Scenes with compliance or concave-polygon corner contacts are rejected (capabilities();
// docs/formulations.md §13).
#pragma once

#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {

/// ε_M, relative to the mass matrix (see the file comment).
inline constexpr double kQuasistaticRegularization = 1e-10;

class Quasistatic final : public Formulation {
 public:
  /// options.formulation must be kQuasistaticDlc, kQuasistaticDqc or kDynamicDqc.
  explicit Quasistatic(StepperOptions options, McpOptions mcp = {});
  std::string_view name() const override;
  FormulationCapabilities capabilities() const override {
    return CapabilitiesOf(options_.formulation);
  }
  void Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws, State* next,
            StepInfo* info) const override;
  /// Layout: StepLayout with p_s of n_d columns per point (DLC) or 2 (DQC, the x and y
  /// components). Residuals: equality = [impulse balance (nv); kinematics (nq); joints (nb);
  /// DQC support rows (nps)], pairs = [(p_n, ·), (p_f, ·), (σ, ·), DLC: (p_s, ·), (σ_s, ·)].
  StepResiduals Evaluate(const Scene& model, const Params& params, const State& x,
                         const StepInput& u, const VectorXd& z) const override;
  StepLayout Layout(const Scene& model, const State& x) const override;

  /// Evaluate() for an assembly made at x by AssembleAt() (or the stepper's own assembly).
  StepResiduals EvaluateAssembly(const Scene& model, const Params& params,
                                 const StewartTrinkle::Assembly& a, const State& x,
                                 const VectorXd& z) const;
  /// The step's assembly at x for a given contact list (the frozen step model, step_model.h):
  /// corner edges as given, DQC support disks exact.
  StewartTrinkle::Assembly AssembleAt(const Scene& model, const State& x, const StepInput& u,
                                      std::vector<Contact> contacts) const;
  /// The contact detection this stepper uses (Assemble's, at the stepper's options).
  const StewartTrinkle& assembler() const { return assembler_; }

  bool quadratic() const { return quadratic_; }

  /// The MCP of a step at x over y = z without q_ℓ+1 (exposed for tests and benchmarks).
  /// *layout receives the step layout.
  McpProblem BuildMcp(const Scene& model, const State& x, const StepInput& u,
                      StepLayout* layout) const;

 private:
  StewartTrinkle::Assembly Assemble(const Scene& model, const State& x, const StepInput& u,
                                    bool quadratic) const;
  /// *contacts (if non-null) receives the assembly's contacts.
  McpProblem MakeMcp(const Scene& model, const State& x, const StepInput& u, bool quadratic,
                     StepLayout* layout, std::vector<Contact>* contacts = nullptr) const;
  /// Solves the DLC step by the split LCP (warm-started from *warm if it has the MCP's size);
  /// *y receives the MCP unknowns.
  SolverReport SolveDlc(const McpProblem& mcp, const VectorXd* warm, VectorXd* y) const;
  /// MakeMcp for a given assembly (EvaluateAssembly).
  McpProblem MakeMcpFrom(const Scene& model, const State& x, StewartTrinkle::Assembly a,
                         bool quadratic, StepLayout* layout) const;

  StepperOptions options_;
  McpSolver solver_;
  std::shared_ptr<const LcpSolver> lcp_solver_;
  StewartTrinkle assembler_;  // builds the contact, joint and force blocks
  bool quadratic_;
  bool dynamic_;  // dynamic-dqc
};

}  // namespace vinci::sim
