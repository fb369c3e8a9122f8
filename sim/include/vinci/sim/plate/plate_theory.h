// Cycle-averaged theory of a point part on a vibrating plate (applications.md §C; Vose,
// Umbanhowar & Lynch, IJRR 2009). An independent code path: it never runs the simulator.
//
// For a high frequency the part's velocity v hardly changes within a cycle, so the cycle-averaged
// in-plane force on it vanishes:
//
//   ∫₀ᵀ [ −μ N(t) (v − v_p(t)) / |v − v_p(t)| + F_t(t) ] dt = 0,
//   N(t) = max(0, m (a_p(t) − g)·n(t))   (= m (g cos θ + a_n), zero while the part flies),
//   F_t(t) = m (g − (g·n) n) in the plate plane,
//
// with v_p, a_p the velocity and acceleration of the plate's material point under the part and
// n(t) the plate normal. The left side is −∇Φ of the convex function
//   Φ(v) = ∫ μ N |v − v_p| dt − v·∫ F_t dt,
// so v is Φ's minimizer: a weighted geometric median with a linear term. It exists iff
// |∫F_t| < ∫μN (otherwise the part slides away). The integral is a midpoint rule over the cycle,
// the minimization Newton's method with a backtracking line search on a smoothed
// |d| ≈ √(|d|² + ε²), with ε driven from 1e-3 to 1e-12 of the plate's speed scale.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/motion.h"
#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// The plate and the cycle: everything the theory needs, nothing of the simulator.
struct PlateTheoryInput {
  PrescribedMotion motion;                    ///< the plate's prescription
  Isometry3d X_WP0 = Isometry3d::Identity();  ///< the plate's initial pose
  bool planar = false;  ///< planar: the plate surface is body y = 0, in-plane axis body x
  Vector3d gravity_W = Vector3d(0, 0, -9.81);  ///< m/s²
  double mu = 0.5;                             ///< part–plate friction coefficient
  double period = 0.0;                         ///< T (s), one cycle of the plate motion
  int samples = 4096;                          ///< quadrature points per cycle
};

/// The asymptotic velocity of a point part at one plate point.
struct PointTheoryResult {
  bool ok = false;
  std::string failure;  ///< why not ok
  /// In-plane velocity in the plate frame (m/s): spatial (along body x, body y); planar
  /// (along body x, 0).
  Vector2d v = Vector2d::Zero();
  double contact_fraction = 0.0;  ///< fraction of the cycle with N > 0
  double residual = 0.0;          ///< |cycle-averaged force| / cycle-averaged μN
  int iterations = 0;             ///< Newton iterations, all ε stages
};

/// Solves the force balance for a point part resting at r_P = (x, y) of the plate surface
/// (plate body frame; planar: y ignored). Throws std::invalid_argument for a bad input
/// (period or samples ≤ 0, μ < 0).
PointTheoryResult SolvePointVelocity(const PlateTheoryInput& in, const Vector2d& r_P);

/// Builds the input from a scene: the plate body's motion and pose, the scene's gravity, μ of
/// the first shape pair of the plate and the part, and the period 1/frequency.
PlateTheoryInput PlateTheoryFromScene(const Scene& scene, int plate, int part, double frequency);

}  // namespace vinci::sim
