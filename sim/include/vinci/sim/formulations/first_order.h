// The first-order (damping-dominated) model, docs/formulations.md §8.
//
// For slow pushing on a surface with viscous-like resistance the inertia is negligible and
// the velocity is set by a damping law. Per step, for a fixed contact set found at q_ℓ:
//
//   C ν_ℓ+1 = (G_n p_n + G_f p_f + G_b p_b)/h + F_ext
//   0 = G_bᵀ ν_ℓ+1 + ψ_b/h + ∂ψ_b/∂t
//   0 ≤ p_n ⊥ G_nᵀ ν_ℓ+1 + ψ_n/h + ∂ψ_n/∂t ≥ 0
//   0 ≤ p_f ⊥ G_fᵀ ν_ℓ+1 + E σ + ∂ψ_f/∂t ≥ 0
//   0 ≤ σ   ⊥ U p_n − Eᵀ p_f ≥ 0
//   q_ℓ+1 = q_ℓ + h G(q_ℓ) ν_ℓ+1
//
// (plus the corner rows of stewart_trinkle.h for concave polygons). C = blockdiag(C_b) from
// Body::damping (symmetric positive definite; planar 3×3 on (vx, vy, ω), spatial 6×6 on
// (v_W, ω_B); N·s/m and N·m·s/rad); F_ext = m g (bodies with gravity) + applied force/torque +
// StepInput::generalized_force. Impulses p keep the units of the other steppers (N·s), so a
// contact force is p/h. Multiplying the first equation by h gives the Stewart–Trinkle
// equations with M → h C and M ν_ℓ → 0: the same LCP, Lemke as reference solver. Without
// contact, ν = C⁻¹ F_ext exactly. Evaluate()'s dynamics rows are h C ν_ℓ+1 − G_n p_n − G_f p_f
// − G_b p_b − h F_ext (h times the first equation); its layout is the Stewart–Trinkle one.
// Each dynamic body needs a damping matrix (Scene::Finalize checks); the scene file's
// `damping` field (docs/scene-format.md).
#pragma once

#include <memory>

#include "vinci/sim/formulations/formulation.h"

namespace vinci::sim {

/// The first-order stepper for `options` (options.formulation must be kFirstOrder): a
/// StewartTrinkle in first-order mode, named "first-order". Throws std::invalid_argument for
/// an unknown solver name or another formulation type.
std::unique_ptr<Formulation> MakeFirstOrder(const StepperOptions& options);

}  // namespace vinci::sim
