// The Stewart–Trinkle time-stepper (linearized friction cone, an LCP) and its Anitescu–Potra
// variant.
//
// Discrete equations (docs/formulations.md §1; Stewart & Trinkle, IJNME 39, 1996; Anitescu & Potra,
// Nonlinear Dynamics 14, 1997), contacts found at q_ℓ within the envelope ε:
//
//   M ν_ℓ+1 = M ν_ℓ + G_n p_n + G_f p_f + G_b p_b + p_ext + p_vp
//   0 = G_bᵀ ν_ℓ+1 + ψ_b/h + ∂ψ_b/∂t
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ψ_n/h + ∂ψ_n/∂t ≥ 0      (Anitescu–Potra: without ψ_n/h)
//   0 ≤ p_f ⊥ G_fᵀ ν_ℓ+1 + E σ + ∂ψ_f/∂t ≥ 0
//   0 ≤ σ   ⊥ U p_n − Eᵀ p_f ≥ 0
//   q_ℓ+1 = q_ℓ + h G(q_ℓ) ν_ℓ+1
//
// with p_ext = h (m g + F_applied + u) and p_vp = −h ω × (I ω) (spatial, body frame).
// Planar friction uses n_d = 2 (d = ±t, exact); spatial n_d equally spaced directions.
// ∂ψ/∂t of a prescribed body uses StepperOptions::prescribed_velocity (secant by default).
// The step is solved as a standard LCP in z = [p_n; p_f; σ; p_s; σ_s; c] by the scene's LCP
// solver after eliminating (ν, p_b) (joints through the Schur complement G_bᵀ M⁻¹ G_b);
// State::warm_start holds the previous z. Assemble() also builds the following (NCP and the
// quasistatic steppers reuse it; docs/formulations.md §13 says which rows they keep):
// - quasi-rigid contact (docs/formulations.md §4): a compliant pair's normal row is the
//   compliance law's velocity form (compliance.h), in both variants;
// - corner contacts of concave polygons (docs/formulations.md §7): one unknown c_k (m/s) and
//   one row per corner, position-level in both variants; StepperOptions::nonconvex_corners =
//   false gives two per-edge contacts instead;
// - 2.5D support friction (docs/formulations.md §6, support.h): −G_s p_s in the dynamics and
//   the linearized disk rows; scenes without supports build exactly the LCP above;
// - with options.formulation = kFirstOrder the first-order model (docs/formulations.md §8,
//   first_order.h): M → h C, ν_ℓ → 0, p_vp → 0, everything else unchanged.
// The LCP matrix, the corner and support rows and the edge choice at a corner are in
// docs/formulations.md §1, §6, §7.
#pragma once

#include <Eigen/Cholesky>
#include <memory>

#include "vinci/sim/formulations/block_diagonal.h"
#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/support_rows.h"

namespace vinci::sim {

class LemkeSolver;

class StewartTrinkle final : public Formulation {
 public:
  StewartTrinkle(StepperOptions options, std::shared_ptr<const LcpSolver> solver);
  std::string_view name() const override;
  FormulationCapabilities capabilities() const override {
    return CapabilitiesOf(options_.formulation);
  }
  void Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws, State* next,
            StepInfo* info) const override;
  StepResiduals Evaluate(const Scene& model, const Params& params, const State& x,
                         const StepInput& u, const VectorXd& z) const override;
  StepLayout Layout(const Scene& model, const State& x) const override;

  /// The step's matrices at x (exposed for tests, benchmarks and the solver library).
  struct Assembly {
    std::vector<Contact> contacts;
    int nd = 0;
    /// M and M⁻¹ (nv × nv), one block per dynamic body (first order: h C and (h C)⁻¹).
    BlockDiagonal M, M_inv;
    SparseMatrixd G_n, G_f, G_b;  ///< nv × nc, nv × nc·nd, nv × nb (≤ 2 body blocks a column)
    VectorXd psi_n, dpsi_n;       ///< ψ_n, ∂ψ_n/∂t (nc)
    VectorXd dpsi_f;              ///< ∂ψ_f/∂t (nc·nd)
    VectorXd psi_b, dpsi_b;       ///< ψ_b, ∂ψ_b/∂t (nb)
    VectorXd mu;                  ///< μ per contact
    VectorXd p_ext;               ///< h (forces) + p_vp (nv)
    /// Per contact: the pair's linearized quasi-rigid law (compliance.h); compliant == false for
    /// rigid pairs, whose rows are unchanged. A compliant normal row is
    /// G_nᵀν + ∂ψ_n/∂t + vel_psi ψ_n + vel_diagonal p_n + vel_constant (both formulations).
    std::vector<CompliantNormalRow> compliance;
    /// Corner contacts: contacts[corner_contact[k]] is corner k; its G_n, G_f columns and ψ_n
    /// are edge 2 (the force edge), G_1 and ψ_1 edge 1.
    std::vector<int> corner_contact;  ///< nk
    SparseMatrixd G_1;                ///< nv × nk
    VectorXd psi_1, dpsi_1;           ///< ψ_1, ∂ψ_1/∂t (nk)
    SupportRows support;  ///< 2.5D support friction, linearized (empty without supports)
  };
  Assembly Assemble(const Scene& model, const State& x, const StepInput& u) const;
  /// Assemble() into *a, reusing its storage (every field is overwritten; same result): a step
  /// whose contact count and structure did not change allocates nothing here.
  void AssembleInto(const Scene& model, const State& x, const StepInput& u, Assembly* a) const;
  /// Assemble() with the contact list given instead of found at x (the frozen step model,
  /// step_model.h: contacts found once at x_ℓ, moved with their bodies). With
  /// `select_corner_edges` false each corner contact keeps the edge order it arrives with
  /// (Assemble()'s choice at the freeze), so the rows stay the same functions of x.
  Assembly AssembleAt(const Scene& model, const State& x, const StepInput& u,
                      std::vector<Contact> contacts, bool select_corner_edges) const;
  /// AssembleAt() of the contacts already in a->contacts, into *a (its storage reused; every
  /// field is overwritten, same result).
  void AssembleAtInto(const Scene& model, const State& x, const StepInput& u,
                      bool select_corner_edges, Assembly* a) const;
  /// The step layout of an assembly (its contacts, joint rows, corners and support points).
  static StepLayout LayoutOf(const Scene& model, const Assembly& a);
  /// Evaluate() for an assembly made at x (Evaluate = EvaluateAssembly(Assemble(x))).
  /// `jacobians` false: the values only (the d_ matrices left empty).
  StepResiduals EvaluateAssembly(const Scene& model, const Params& params, const Assembly& a,
                                 const State& x, const VectorXd& z, bool jacobians = true) const;
  /// The Schur-complement pieces of the joint elimination (empty without joints).
  struct JointElimination {
    MatrixXd MinvGb;          ///< M⁻¹ G_b
    Eigen::LDLT<MatrixXd> S;  ///< S = G_bᵀ M⁻¹ G_b
  };
  /// How the LCP unknowns are grouped into LcpProblem::blocks for block-iterative solvers
  /// (projected Gauss–Seidel, pgs.h). Direct solvers ignore the blocks.
  enum class LcpBlocking {
    /// One block per contact patch (BuildLcp's choice): every contact between the same two
    /// bodies — the rows (p_n, p_f,1..n_d, σ[, c]) of each — in one block, in contact order;
    /// and one block per body with support points (the rows (p_s, σ_s) of all its points).
    /// Patches of more than kMaxPatchContacts contacts (points) are split into consecutive
    /// chunks of at most that many, to bound the block solves' cost (Lemke, O(rows³)). A patch
    /// solved as one block transmits a load through a stack within a sweep (per-contact blocks
    /// stall on stacks: bench/README.md, vinci_vs_siconos: PGS).
    kContactPatch,
    /// One friction-cone block per contact, (p_n, p_f,1..n_d, σ[, c]), and one per support
    /// point, (p_s, σ_s): the smallest blocks the σ rows (zero diagonal) allow. Kept for
    /// comparison (tests/sim/pgs_test.cc); no stepper uses it.
    kContact,
  };
  /// Largest number of contacts (or support points) in one kContactPatch block.
  static constexpr int kMaxPatchContacts = 8;
  /// The blocks of BuildLcp's unknown layout z = [p_n; p_f; σ; p_s; σ_s; c] for `a` (a
  /// partition of the LCP's indices), blocks in order of their first contact. If `parts` is
  /// given it receives LcpProblem::block_parts: where each contact's (support point's) rows
  /// begin in its block.
  static std::vector<std::vector<int>> LcpBlocks(const Assembly& a, LcpBlocking blocking,
                                                 std::vector<std::vector<int>>* parts = nullptr);
  /// LcpBlocks into *blocks (and *parts if non-null), reusing the storage of their vectors.
  static void LcpBlocksInto(const Assembly& a, LcpBlocking blocking,
                            std::vector<std::vector<int>>* blocks,
                            std::vector<std::vector<int>>* parts);
  /// The LCP of the step in (p_n, p_f, σ[, p_s, σ_s][, c]) after eliminating ν and p_b; *v_star is
  /// ν_ℓ+1 for zero contact impulses. Its blocks are LcpBlocks(a, LcpBlocking::kContactPatch).
  LcpProblem BuildLcp(const Scene& model, const Assembly& a, const VectorXd& v, VectorXd* v_star,
                      JointElimination* joints) const;
  /// BuildLcp into *lcp, reusing its storage (M, q, blocks): the same numbers, and no
  /// allocation when the sizes did not change (per-thread buffers, *joints' storage reused).
  void BuildLcpInto(const Scene& model, const Assembly& a, const VectorXd& v, VectorXd* v_star,
                    JointElimination* joints, LcpProblem* lcp) const;
  /// ν_ℓ+1 = ν* + W G_c p_c for the LCP solution z.
  VectorXd VelocityAfter(const Assembly& a, const VectorXd& v_star, const VectorXd& z,
                         const JointElimination& joints) const;
  /// VelocityAfter into *v1 (its intermediate vectors in per-thread storage): the same numbers,
  /// no allocation when the sizes did not change. v1 must not alias the inputs.
  void VelocityAfterInto(const Assembly& a, const VectorXd& v_star, const VectorXd& z,
                         const JointElimination& joints, VectorXd* v1) const;

  const StepperOptions& options() const { return options_; }

 private:
  // AssembleAt's work on a->contacts, into *a (storage reused). `kinematics_ready`: the calling
  // thread's assembly kinematics already hold x's (AssembleInto computed them for FindContacts).
  void Fill(const Scene& model, const State& x, const StepInput& u, bool select_corner_edges,
            Assembly* a, bool kinematics_ready = false) const;
  StepperOptions options_;
  std::shared_ptr<const LcpSolver> solver_;
  bool velocity_level_;  // Anitescu–Potra
  bool first_order_;     // FormulationType::kFirstOrder (first_order.h): M → h C, no ν_ℓ
  // solver_ if it is a LemkeSolver (the warm-basis path), else null.
  const LemkeSolver* lemke_;
};

}  // namespace vinci::sim
