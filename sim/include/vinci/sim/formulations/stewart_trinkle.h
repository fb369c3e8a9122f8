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
// The mixed LCP with joints is solved by eliminating (ν, p_b) through the Schur complement
// S = G_bᵀ M⁻¹ G_b, leaving a standard LCP in (p_n, p_f, σ) with matrix
// A = [[G_nᵀWG_n, G_nᵀWG_f, 0], [G_fᵀWG_n, G_fᵀWG_f, E], [U, −Eᵀ, 0]],
// W = M⁻¹ − M⁻¹G_b S⁻¹ G_bᵀ M⁻¹ (= M⁻¹ without joints).
// Planar friction uses n_d = 2 (d = ±t, exact); spatial uses n_d equally spaced directions.
// ∂ψ/∂t of a prescribed body uses its secant velocity over the step, (pose(t+h) − pose(t))/h,
// so that the linearized end-of-step gap moves exactly with a translating floor or pusher, or,
// with StepperOptions::prescribed_velocity = kExact, its exact velocity at t + h.
// Quasi-rigid contact (docs/formulations.md §4): a pair with a compliant body replaces its normal
// row by the compliance law's velocity form (compliance.h),
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ∂ψ_n/∂t + β ψ_n + γ p_n + ε ≥ 0   (Kelvin–Voigt, c = 0: β = 1/h,
//   γ = 1/(h² k), ε = 0, i.e. ψ_n(q_ℓ+1) + p_n/(h k) ≥ 0 linearized), in both variants.
//
// Corner contacts (docs/formulations.md §7; ContactPoint::corner, from concave polygons): a vertex
// at a convex corner of edges 1 and 2 is free iff max(ψ_1, ψ_2) ≥ 0. Linearized over the step
// like the other normal rows, with ψ_i⁺/h = ψ_i/h + G_iᵀ ν_ℓ+1 + ∂ψ_i/∂t the end-of-step gap
// over h, each corner k adds one unknown c_k (m/s) and the rows
//   0 ≤ c_k ⊥ c_k − (ψ_1⁺ − ψ_2⁺)/h ≥ 0          so c_k = max(ψ_1⁺ − ψ_2⁺, 0)/h,
//   0 ≤ p_n ⊥ ψ_2⁺/h + c_k ≥ 0                    (= max(ψ_1⁺, ψ_2⁺)/h)
// (Anitescu–Potra too: a velocity-level corner row, max(ψ_1⁺, ψ_2⁺) ≥ ψ_2, would stop a vertex
// whose larger gap shrinks to the smaller one's as it passes the corner — the snag again). The
// impulse p_n and the friction impulses act along edge 2's normal and tangent, so
// edge 2 must be the edge the vertex will be against: Assemble() takes as edge 2 the edge with
// the larger predicted gap ψ_i + h (G_iᵀ ν_ℓ + ∂ψ_i/∂t) (first order: ν_ℓ → 0) — when the two
// agree to a relative 1e-9 (the vertex reaches the corner point exactly at the end of the
// step), the edge with the smaller |ψ_i|, the one the vertex slides along now — and stores it
// as the contact's `point` (its column of G_n, G_f, ψ_n); edge 1 is G_1, ψ_1. c enters only its
// own row and its contact's normal row; it carries no force. In the LCP the c_k are the last
// unknowns, z = [p_n; p_f; σ; p_s; σ_s; c]; the c rows are −(G_1 − G_2)ᵀ W G_c in the (p_n, p_f,
// p_s) columns and 1 on the diagonal, and c_k joins the friction-cone block of its contact. With
// StepperOptions::nonconvex_corners = false the narrow phase's corners arrive as two ordinary
// contacts instead (per-edge constraints).
//
// With options.formulation = kFirstOrder the same class steps the first-order model (see
// first_order.h): M is replaced by h C (C the bodies' damping matrices), ν_ℓ by 0 and p_vp by 0;
// everything else, including the corner rows, is unchanged.
//
// 2.5D support friction (docs/formulations.md §6, support.h): planar bodies with support points add
// −G_s p_s to the dynamics and the rows 0 ≤ p_s ⊥ G_sᵀ ν_ℓ+1 + E_s σ_s ≥ 0,
// 0 ≤ σ_s ⊥ h μ_s N − E_sᵀ p_s ≥ 0; the LCP unknowns become (p_n, p_f, σ, p_s, σ_s). Scenes
// without supports build exactly the LCP above.
#pragma once

#include <Eigen/Cholesky>
#include <memory>

#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/formulations/support_rows.h"

namespace vinci::sim {

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
    MatrixXd M, M_inv;       ///< nv × nv
    MatrixXd G_n, G_f, G_b;  ///< nv × nc, nv × nc·nd, nv × nb
    VectorXd psi_n, dpsi_n;  ///< ψ_n, ∂ψ_n/∂t (nc)
    VectorXd dpsi_f;         ///< ∂ψ_f/∂t (nc·nd)
    VectorXd psi_b, dpsi_b;  ///< ψ_b, ∂ψ_b/∂t (nb)
    VectorXd mu;             ///< μ per contact
    VectorXd p_ext;          ///< h (forces) + p_vp (nv)
    /// Per contact: the pair's linearized quasi-rigid law (compliance.h); compliant == false for
    /// rigid pairs, whose rows are unchanged. A compliant normal row is
    /// G_nᵀν + ∂ψ_n/∂t + vel_psi ψ_n + vel_diagonal p_n + vel_constant (both formulations).
    std::vector<CompliantNormalRow> compliance;
    /// Corner contacts: contacts[corner_contact[k]] is corner k; its G_n, G_f columns and ψ_n
    /// are edge 2 (the force edge), G_1 and ψ_1 edge 1.
    std::vector<int> corner_contact;  ///< nk
    MatrixXd G_1;                     ///< nv × nk
    VectorXd psi_1, dpsi_1;           ///< ψ_1, ∂ψ_1/∂t (nk)
    SupportRows support;  ///< 2.5D support friction, linearized (empty without supports)
  };
  Assembly Assemble(const Scene& model, const State& x, const StepInput& u) const;
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
    /// solved as one block transmits a load through the stack within a sweep: on the 10-box
    /// stack cold PGS converges in 585 sweeps with patch blocks, while per-contact blocks stall
    /// at a residual of ~1e-5 after 1000 (pgs.h).
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
  /// The LCP of the step in (p_n, p_f, σ[, p_s, σ_s][, c]) after eliminating ν and p_b; *v_star is
  /// ν_ℓ+1 for zero contact impulses. Its blocks are LcpBlocks(a, LcpBlocking::kContactPatch).
  LcpProblem BuildLcp(const Scene& model, const Assembly& a, const VectorXd& v, VectorXd* v_star,
                      JointElimination* joints) const;
  /// ν_ℓ+1 = ν* + W G_c p_c for the LCP solution z.
  VectorXd VelocityAfter(const Assembly& a, const VectorXd& v_star, const VectorXd& z,
                         const JointElimination& joints) const;

  const StepperOptions& options() const { return options_; }

 private:
  StepperOptions options_;
  std::shared_ptr<const LcpSolver> solver_;
  bool velocity_level_;  // Anitescu–Potra
  bool first_order_;     // FormulationType::kFirstOrder (first_order.h): M → h C, no ν_ℓ
};

}  // namespace vinci::sim
