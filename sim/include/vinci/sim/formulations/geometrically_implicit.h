// The geometrically implicit (GI) time-stepper for convex bodies given as intersections of
// convex implicit functions (docs/formulations.md §3; N. Chakraborty, S. Berard, S. Akella,
// J. Trinkle, "An implicit time-stepping method for multibody systems with intermittent
// contact", RSS 2007, and IJRR 33(3), 2014).
//
// Collision detection is part of the step: the contact points at the END of the step are
// unknowns, so a convex body never penetrates at ℓ+1 and a smooth body (disc, sphere, ellipse)
// rolls without the faceting losses of a polygonal approximation.
//
// Discrete equations (docs/formulations.md §3 gives them in full, with the solver form):
// per dynamic body the pose unknowns q⁺ (planar (x, y, θ); spatial (p, φ), φ the body-frame
// rotation vector of the step, R⁺ = R_ℓ Exp(φ)) with 0 = q⁺ − q_ℓ − h ν, and the impulse
// balance 0 = M (ν − ν_ℓ) − p_ext − Σ_pairs Vᵀ W with the contact wrenches W at ℓ+1. Per
// candidate pair (shape A with functions f_i on the dynamic body A, shape B with g_j) the
// unknowns a_1, a_2 (contact points at ℓ+1), l_1, l_2, the multipliers λ, μ of intersections,
// p_n, p_t, σ, and the rows
//   0 = a_1 − a_2 + l_1 n_A,  0 = n_A + l_2 n_B,  f(a_1) = 0 and g(a_2) = 0 (intersections:
//   Σ λ_i = 1, 0 ≤ λ_i ⊥ −f_i(a_1) ≥ 0, same for B),
//   0 ≤ p_n ⊥ ψ = l_1 ‖n_A‖ ≥ 0,  0 = μ p_n v_t + σ p_t,  0 ≤ σ ⊥ μ² p_n² − ‖p_t‖² ≥ 0,
// n_A = Σ λ_i ∇f_i(a_1), n_B = Σ μ_j ∇g_j(a_2). The contact normal (B → A) is −n_A/‖n_A‖.
// These are the rows Evaluate() reports. The step is one mixed NCP solved by McpSolver with an
// analytic Jacobian, in a solver form that stays regular (friction as a projection, rows ÷ h,
// tiny compliances κ_t = 1e-5, κ_n = 1e-8 and a contact-point tie-breaker κ_a = 1e-8, l_2 ≥ 0);
// Evaluate() carries the same small terms, so a simulated trajectory satisfies it to solver
// tolerance. Quasi-rigid pairs (docs/formulations.md §4, Body::compliance) use compliance.h's
// position form, exact in ψ_n(q_ℓ+1). Non-dynamic bodies: pose at t + h and secant velocity
// over the step. After a converged solve each pair's distance at ℓ+1 is re-checked; deeper than
// 1e-6 m (beyond a compliant law's overlap) fails the step as a spurious branch. A solve that
// fails from the warm start is retried once from a cold start.
//
// Candidate pairs (broad phase at q_ℓ): shape pairs of different bodies (at least one dynamic,
// not connected by a joint) whose distance at ℓ (ClosestPoints) is within the envelope plus a
// motion bound over the step. Every shape must have an implicit form (MakeImplicitSet).
//
// Warm start (State::warm_start): [n_pairs, then per pair: body_a, shape_a, body_b, shape_b,
// m_A, m_B, p_n, p_t (2), σ, a_1 (3), a_2 (3), l_1, l_2, λ (m_A), μ (m_B)]; pairs found again
// start from their record, new pairs from ClosestPoints at q_ℓ; ν starts at ν_ℓ.
//
// Limitations: joints are not supported and shapes without an implicit form (capsule,
// segment, polyhedron, concave polygon) are rejected (std::invalid_argument from
// Step/Layout/Evaluate); one contact point per convex pair means no torsional friction (a box
// spinning flat on a floor keeps spinning; docs/formulations.md §2's optional p_r is not
// implemented). Scenes with 2.5D support friction,
// `pose: integrated` or `prescribed_velocity: exact` are rejected (capabilities(); docs/
// formulations.md §13).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "vinci/sim/formulations/formulation.h"
#include "vinci/sim/geometry/implicit_surface.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {

/// One candidate pair of convex shapes for a GI step.
struct GiPair {
  int body_a = -1, shape_a = -1;  ///< the dynamic body (or the first dynamic one)
  int body_b = -1, shape_b = -1;
  int m_a = 1, m_b = 1;        ///< number of implicit functions of each shape
  double mu = 0.0;             ///< friction coefficient
  int mu_param = -1;           ///< index of μ's parameter in the scene's ParamTable
  Vector3d tangent_reference;  ///< e (spatial tangent basis), fixed for the step
  ImplicitProximity start;     ///< closest points at q_ℓ
  /// Geometric unknowns of the pair: a_1, a_2 (d each), l_1, l_2, λ (m_a if m_a > 1),
  /// μ (m_b if m_b > 1).
  int GeometrySize(Dim dim) const {
    const int d = dim == Dim::kPlanar ? 2 : 3;
    return 2 * d + 2 + (m_a > 1 ? m_a : 0) + (m_b > 1 ? m_b : 0);
  }
};

/// GI stepper. Layout() and Evaluate() use StepLayout with these meanings (the layout's
/// size() is the number of GI unknowns):
///   nq = pose unknowns (planar 3 per dynamic body; spatial 6: p and the rotation vector φ),
///   nv = velocities, nc = candidate pairs, nd = d − 1 tangential impulses per pair (the p_f
///   block holds p_t), σ one per pair, and the p_b block (nb) holds the pairs' geometric
///   unknowns [a_1, a_2, l_1, l_2, λ, μ] pair after pair (GiPair::GeometrySize each).
/// Evaluate() equality rows: [dynamics (nv); kinematics (nq); per pair: separation (d),
/// anti-parallel normals (d), A side (1), B side (1), friction μ p_n v_t + σ p_t (d − 1)];
/// complementarity pairs per pair: (p_n, ψ), (σ, μ² p_n² − ‖p_t‖²), (λ_i, −f_i(a_1)),
/// (μ_j, −g_j(a_2)). Parameter columns: every friction coefficient and every mass.
class GeometricallyImplicit final : public Formulation {
 public:
  explicit GeometricallyImplicit(StepperOptions options, McpOptions mcp = {});
  std::string_view name() const override { return "geometrically-implicit"; }
  FormulationCapabilities capabilities() const override {
    return CapabilitiesOf(options_.formulation);
  }
  void Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws, State* next,
            StepInfo* info) const override;
  StepResiduals Evaluate(const Scene& model, const Params& params, const State& x,
                         const StepInput& u, const VectorXd& z) const override;
  StepLayout Layout(const Scene& model, const State& x) const override;

  /// The candidate pairs at x. Throws std::invalid_argument for a shape without an implicit
  /// form or a scene with joints; *failure (if non-null) receives a closest-point failure, in
  /// which case the returned list is incomplete.
  std::vector<GiPair> Pairs(const Scene& model, const State& x, std::string* failure) const;

  /// The step's mixed NCP (the solver form described above) in the unknowns of Layout(), and
  /// in *z0 its starting point (warm start from x.warm_start). Exposed for tests (Jacobian vs
  /// finite differences) and benchmarks. Throws like Pairs().
  McpProblem StepProblem(const Scene& model, const State& x, const StepInput& u,
                         VectorXd* z0) const;

  /// The unknown vector z of Evaluate() that corresponds to a completed step x → next (read
  /// from next.v, next.q and next.warm_start). Throws std::invalid_argument if next was not
  /// produced by this stepper from x.
  VectorXd UnknownsFromStep(const Scene& model, const State& x, const State& next) const;

  /// The parts of a step fixed at x_ℓ by the frozen step model (step_model.h): the candidate
  /// pairs (with their closest points at x_ℓ, which also fix a compliant pair's law constant and
  /// the tangent reference) and the solver form's tie-breaker reference a_1,start (from
  /// x.warm_start, as in Step). Throws std::invalid_argument like Pairs() or on a closest-point
  /// failure.
  struct FrozenPairs {
    std::vector<GiPair> pairs;
    std::vector<Vector3d> a1_start;
    StepLayout layout;  ///< the step layout of these pairs
  };
  FrozenPairs FreezePairs(const Scene& model, const State& x) const;
  /// Evaluate() with the pairs and tie-breaker reference of `frozen` instead of those found at
  /// x; μ per pair is re-read from `model`. Evaluate(x) = EvaluateFrozen(FreezePairs(x), x).
  StepResiduals EvaluateFrozen(const Scene& model, const Params& params, const FrozenPairs& frozen,
                               const State& x, const StepInput& u, const VectorXd& z) const;
  /// UnknownsFromStep() for the frozen pairs.
  VectorXd UnknownsFromStep(const Scene& model, const FrozenPairs& frozen, const State& x,
                            const State& next) const;
  /// The end-of-step state (t + h, pose, ν, warm start) that a step with unknowns z writes.
  State StateFromUnknowns(const Scene& model, const FrozenPairs& frozen, const State& x,
                          const VectorXd& z) const;

  const StepperOptions& options() const { return options_; }
  const McpOptions& mcp_options() const { return mcp_; }

 private:
  StepperOptions options_;
  McpOptions mcp_;
};

}  // namespace vinci::sim
