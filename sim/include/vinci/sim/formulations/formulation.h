// The time-stepping formulation interface. A Formulation has two faces: it solves one step,
// and it evaluates the same step equations as residuals + complementarity pairs (with
// Jacobians) so that an estimator imposing them as constraints cannot drift from the simulator.
#pragma once

#include <memory>
#include <string_view>
#include <vector>

#include "vinci/sim/formulations/capabilities.h"
#include "vinci/sim/formulations/contact.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"
#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim {

/// The unknowns of one step for a fixed contact set (found at x_ℓ), stacked in this order:
///   z = [q_ℓ+1 (nq); ν_ℓ+1 (nv); p_n (nc); p_f (nc·nd); σ (nc); p_b (nb);
///        p_s (nps); σ_s (ns); c (nk)],
/// p_s, σ_s being the 2.5D support friction (support.h: ns support points with nps friction
/// columns in all; both 0 in scenes without supports) and c the corner unknowns of the nk corner
/// contacts (docs/formulations.md §7, in contact order; see stewart_trinkle.h; nk = 0 for scenes
/// without concave polygons).
struct StepLayout {
  int nq = 0, nv = 0, nc = 0, nd = 0, nb = 0;
  int ns = 0, nps = 0;  ///< support points, support friction columns
  int nk = 0;           ///< corner contacts
  int q1() const { return 0; }
  int v1() const { return nq; }
  int pn() const { return nq + nv; }
  int pf() const { return pn() + nc; }
  int sigma() const { return pf() + nc * nd; }
  int pb() const { return sigma() + nc; }
  int ps() const { return pb() + nb; }
  int sigma_s() const { return ps() + nps; }
  int corner() const { return sigma_s() + ns; }
  int size() const { return corner() + nk; }
};

/// Step equations at a point: equality = 0 and 0 ≤ comp_a ⊥ comp_b ≥ 0 (componentwise).
/// Jacobians are with respect to [z; θ_d]: the layout.size() step unknowns followed by the
/// differentiable scene parameters θ_d listed in `param_columns` (indices into the scene's
/// ParamTable: every friction coefficient, support friction μ_s and mass). Geometry-size and motion
/// parameters have no column (the contact set and ∂ψ/∂t depend on them non-smoothly); difference
/// them through the simulator if needed.
struct StepResiduals {
  StepLayout layout;
  std::vector<int> param_columns;
  VectorXd equality;
  VectorXd comp_a, comp_b;
  MatrixXd d_equality, d_comp_a, d_comp_b;
  /// max(|equality|_∞, |min(comp_a, comp_b)|_∞)
  double Violation() const;
};

/// Derivatives of the step equations with respect to the start-of-step state x_ℓ = (q_ℓ, ν_ℓ)
/// (columns: [q_ℓ (nq); ν_ℓ (nv)]), for estimators whose unknowns include the states.
struct StateJacobians {
  MatrixXd d_equality, d_comp_a, d_comp_b;
  /// false if a perturbation of x_ℓ changed the contact set (a point on the envelope boundary):
  /// the columns are then one-sided across a discontinuity and should not be trusted.
  bool contact_set_stable = true;
};

/// Reusable per-thread scratch: one per thread, never shared. Holds the params-resolved scene.
struct Workspace {
  Params resolved_for;
  std::shared_ptr<const Scene> model;  ///< scene with `resolved_for` applied
  std::vector<Contact> contacts;  ///< the contacts of the last successful step (for inspection)
  /// `model` with the last step input's motions applied (Simulator::Step, motion_input.h).
  std::shared_ptr<const Scene> motion_base, motion_model;
  std::vector<MotionInput> motions_for;
};

class Formulation {
 public:
  virtual ~Formulation() = default;
  virtual std::string_view name() const = 0;
  /// The scene features this formulation implements (capabilities.h); the Simulator rejects a
  /// scene that uses any other.
  virtual FormulationCapabilities capabilities() const = 0;
  /// One step from x to *next. `model` is the scene with params applied. Never throws on
  /// numerical trouble: info->ok = false with a reason, *next then equals x.
  virtual void Step(const Scene& model, const State& x, const StepInput& u, Workspace* ws,
                    State* next, StepInfo* info) const = 0;
  /// Evaluates the step equations from x (contacts found at x) for the unknowns z.
  /// `params` must be the vector `model` was built from (for the θ columns).
  virtual StepResiduals Evaluate(const Scene& model, const Params& params, const State& x,
                                 const StepInput& u, const VectorXd& z) const = 0;
  /// The layout Evaluate expects from x (contact set at x).
  virtual StepLayout Layout(const Scene& model, const State& x) const = 0;

  /// ∂(step equations)/∂x_ℓ by central differences of Evaluate (step `eps` relative to
  /// max(1, |x_i|)), with collision detection re-run at each perturbed x_ℓ — the exact derivative
  /// of the discrete equations the simulator solves, as long as the contact set is stable.
  StateJacobians EvaluateStateJacobians(const Scene& model, const Params& params, const State& x,
                                        const StepInput& u, const VectorXd& z,
                                        double eps = 1e-7) const;
};

/// The formulation selected by the scene's options (Stewart–Trinkle, Anitescu–Potra or first
/// order, first_order.h) and
/// solver (by name). Throws std::invalid_argument for an unknown solver name.
std::unique_ptr<Formulation> MakeFormulation(const StepperOptions& options);

}  // namespace vinci::sim
