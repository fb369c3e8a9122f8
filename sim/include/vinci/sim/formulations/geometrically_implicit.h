// The geometrically implicit (GI) time-stepper for convex bodies given as intersections of
// convex implicit functions (docs/formulations.md §3; N. Chakraborty, S. Berard, S. Akella,
// J. Trinkle, "An implicit time-stepping method for multibody systems with intermittent
// contact", RSS 2007, and IJRR 33(3), 2014).
//
// Collision detection is part of the step: the contact points at the END of the step are
// unknowns, so a convex body never penetrates at ℓ+1 and a smooth body (disc, sphere, ellipse)
// rolls without the faceting losses of a polygonal approximation.
//
// Discrete equations, as implemented (all quantities at ℓ+1 unless marked ℓ; d = 2 planar, 3
// spatial; the world frame is used for all points and vectors):
//
// Per dynamic body (pose unknowns; body origin = centre of mass):
//   planar:  q⁺ = (x, y, θ),        0 = q⁺ − q_ℓ − h ν                               (3 rows)
//   spatial: q⁺ = (p, φ),           0 = p − p_ℓ − h v,  0 = φ − h ω_B                 (6 rows)
//            with R⁺ = R_ℓ Exp(φ): φ is the body-frame rotation vector of the step, so the
//            quaternion update is exactly IntegratePosition's Q_ℓ ⊗ exp(h ω_B / 2). Using the
//            rotation vector instead of the quaternion as the unknown keeps the system square
//            and free of the unit-norm constraint; geometry derivatives use the SO(3) right
//            Jacobian J_r(φ) (δω_W = R⁺ J_r(φ) δφ).
//   0 = M (ν − ν_ℓ) − p_ext − Σ_pairs Vᵀ W                                             (nv rows)
//   with p_ext = h (m g + F_applied + u) − h ω_ℓ × I ω_ℓ (gyroscopic term explicit, as in the
//   Stewart–Trinkle stepper), W = [P; (a − c⁺) × P] the world contact wrench at ℓ+1 on the
//   body (c⁺ its centre at ℓ+1, a its contact point), and V the map ν → (v_W, ω_W) of the body
//   (spatial: ω_W = R_ℓ ω_B; since R⁺ = R_ℓ Exp(h ω_B), R_ℓ ω_B = R⁺ ω_B for the solved ω_B).
//
// Per candidate pair (shape A with functions f_i, i = 1..m_A, on body A; shape B with g_j on
// body B; A is the dynamic one), unknowns a_1, a_2 ∈ R^d, l_1, l_2, λ ∈ R^{m_A} if m_A > 1,
// μ ∈ R^{m_B} if m_B > 1, p_n, p_t (d − 1), σ:
//   n_A = Σ_i λ_i ∇f_i(a_1),  n_B = Σ_j μ_j ∇g_j(a_2)  (λ ≡ 1 / μ ≡ 1 for a single function)
//   0 = a_1 − a_2 + l_1 n_A                                  (d)   a_2 on A's outward normal
//   0 = n_A + l_2 n_B                                         (d)   anti-parallel normals
//   single function:  0 = f(a_1)                              (1)
//   intersection:     0 = Σ_i λ_i − 1,  0 ≤ λ_i ⊥ −f_i(a_1) ≥ 0                    (1 + m_A)
//   (same for B with μ_j, g_j, a_2)
//   0 ≤ p_n ⊥ ψ = l_1 ‖n_A‖ ≥ 0                               the signed distance ‖a_2 − a_1‖
// The intersection treatment is the symmetric form of §3's "∇f_k + Σ_{i≠k} l_i ∇f_i with
// f_k(a_1) = 0": the normal is any convex combination of the gradients of the functions that
// vanish at a_1 (divide by λ_k > 0 to get §3's form), so no "primary" function has to be chosen
// and a contact may move from a face onto an edge or the next face inside one step.
// The contact normal (B → A, A pushed along +n) is n = −n_A/‖n_A‖, tangents t = ẑ × n
// (planar) or t_1 = (n × e)/‖n × e‖, t_2 = n × t_1 (spatial; e the coordinate axis least
// aligned with the pair's normal at ℓ, fixed for the step). The impulse on A at a_1 is
// P = n p_n + T p_t, on B at a_2 it is −P. The relative velocity at ℓ+1 is
// v_rel = v_A(a_1) − v_B(a_2), v_t = Tᵀ v_rel (non-dynamic bodies: pose at t+h, secant velocity
// over the step as in the Stewart–Trinkle stepper, which is their ∂ψ/∂t).
// Friction is §2's quadratic cone (planar: |p_t| ≤ μ p_n, exact):
//   0 = μ p_n v_t + σ p_t,   0 ≤ σ ⊥ μ² p_n² − ‖p_t‖² ≥ 0
// These are the rows Evaluate() reports. The solver uses an equivalent semismooth form that
// stays non-degenerate when p_n = 0 (where §2's σ is not unique and its rows lose rank):
//   0 = p_t − Π_{μ p_n}(p_t − r v_t),   0 = r σ − (‖p_t − r v_t‖ − μ p_n)₊
// with Π_ρ the projection onto the disc ‖·‖ ≤ ρ and r > 0 a scale (kg; the smaller dynamic
// mass of the pair). For p_n > 0 its solutions are exactly those of §2 (σ is the slip speed);
// for p_n = 0 it picks p_t = 0 and σ = ‖v_t‖ among §2's solutions.
//
// Solver-form details. Evaluate() reports the rows above (§2's friction, not the projection
// form) with the same three small terms as the solver (compliances and tie-breaker; they vanish
// with κ), so a simulated trajectory satisfies them to solver tolerance:
// - Row scaling: the kinematics, geometry (separation, normals, sides, −f_i, −g_j) and ψ rows
//   are divided by h, i.e. expressed as velocities. A pose change is h Δν, so without this a
//   force split that trades against a tiny velocity change looks singular to Newton.
// - Tiny compliances: v_t is replaced by v_t + (κ_t/r) p_t and ψ by ψ + (h κ_n/r) p_n with
//   κ_t = 1e-5, κ_n = 1e-8: a tangential creep below ~3e-8 m/s while sticking (p_t ≤ μ m g h,
//   h = 1e-3) and an overlap of 1e-11 m per N·s of normal impulse. They make statically
//   indeterminate contacts (a sphere resting on two spheres has a one-parameter family of
//   normal/friction splits) non-singular; κ_t ≫ κ_n selects the split with the least friction.
// - Contact-point tie-breaker: the separation row is a_1 − a_2 + l_1 n_A + κ_a (a_1 − a_1,start)
//   with κ_a = 1e-8 and a_1,start the step's starting guess. Where the closest points are not
//   unique (a flat face parallel to another, unloaded) it picks the one nearest the guess; with
//   p_n > 0 the torque balance fixes a_1 (the centre of pressure of a resting face) and the
//   term moves a_2 by at most κ_a ‖a_1 − a_1,start‖. New face-on-face pairs start below A's
//   centre instead of at ClosestPoints' vertex.
//
// Quasi-rigid contact (docs/formulations.md §4): a pair with a compliant body (Body::compliance)
// imposes compliance.h's position form, exact in ψ = ψ_n(q_ℓ+1):
//   0 ≤ p_n ⊥ ψ + a p_n + b ψ_ℓ + e ≥ 0
// with a = pos_diagonal, b = pos_psi0, e = pos_constant of
// LinearizeNormalLaw(CombineCompliance(A, B), ψ_ℓ, h), ψ_ℓ the pair's signed distance at q_ℓ
// (ClosestPoints); rigid pairs have a = b = e = 0. The solver row (÷ h, with the tiny κ_n term)
// and Evaluate()'s (p_n, ψ) complementarity pair both carry these terms. The end-of-step
// penetration check allows a compliant pair the law's overlap a p_n + b ψ_ℓ + e (plus 1e-6 m);
// max_penetration (start of step) applies to every pair, as in the other steppers.
//
// Spurious branches: the contact equations also hold for parallel normals (l_2 < 0: a box
// below a floor touching it with its top face), so the solver bounds l_2 ≥ 0 (l_2 = 0 is never a
// solution). After a converged solve each pair's distance at ℓ+1 is re-checked with
// ClosestPoints; deeper than 1e-6 m (beyond a compliant law's overlap) fails the step. A solve that
// fails from the warm start is retried once from a cold start (closest points at ℓ), e.g. for a
// rocking box landing flat.
//
// The whole step is one mixed NCP solved by McpSolver with an analytic Jacobian. Count check
// (planar, one dynamic disc on a fixed half-plane): ν 3 + q 3 + a_1 2 + a_2 2 + l 2 +
// (p_n, p_t, σ) 3 = 15 unknowns = 15 rows.
//
// Candidate pairs (broad phase at q_ℓ): shape pairs of different bodies (at least one dynamic,
// not connected by a joint) whose distance at ℓ (ClosestPoints) is within the envelope plus a
// motion bound 2h(‖v‖ + ‖ω‖ ρ) per body + h²(‖g‖ + ‖F/m‖) (ρ: bounding radius), pre-filtered
// by bounding spheres. Every shape must have an implicit form (MakeImplicitSet).
//
// Warm start (State::warm_start): [n_pairs, then per pair: body_a, shape_a, body_b, shape_b,
// m_A, m_B, p_n, p_t (2), σ, a_1 (3), a_2 (3), l_1, l_2, λ (m_A), μ (m_B)]; pairs found again
// start from their record, new pairs from ClosestPoints at q_ℓ; ν starts at ν_ℓ.
//
// Limitations: joints are not supported and shapes without an implicit form (capsule,
// segment, polyhedron) are rejected (std::invalid_argument from Step/Layout/Evaluate); one
// contact point per convex pair means no torsional friction (a box spinning flat on a floor
// keeps spinning; docs/formulations.md §2's optional p_r is not implemented).
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

  const StepperOptions& options() const { return options_; }
  const McpOptions& mcp_options() const { return mcp_; }

 private:
  StepperOptions options_;
  McpOptions mcp_;
};

}  // namespace vinci::sim
