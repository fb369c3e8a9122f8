// Convex bodies as intersections of convex implicit functions, for the geometrically implicit
// (GI) stepper (docs/formulations.md §3): values, analytic gradients and Hessians, the implicit
// form of every scene shape that has one, and closest points of two such bodies.
#pragma once

#include <vector>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/types.h"

namespace vinci::sim {

/// Kinds of convex implicit function f(ξ) ≤ 0 (inside), ξ = p_F the point in the function
/// frame F. The forms are chosen so that near the surface ‖∇f‖ is of order one and f is
/// smooth (polynomial where possible: no singular gradient at a centre, no vanishing
/// gradient on the surface). With ρ a length scale (below), the forms are:
///   kHalfspace     f = z                                     ∇f = e_z, ∇²f = 0
///   kSphere        f = (‖ξ‖² − r²) / (2r)                    r = radii.x();  ‖∇f‖ = 1 on the
///                                                            surface, f ≈ signed distance
///   kEllipsoid     f = (ρ/2) (Σ (ξ_i/a_i)² − 1)              a = radii, ρ = (a_x a_y a_z)^{1/3};
///                                                            ‖∇f‖ ∈ [ρ/a_max, ρ/a_min] on it
///   kSuperquadric  f = (ρ/e) (Σ |ξ_i/a_i|^e − 1), e ≥ 2      e = exponent, a, ρ as above
///                                                            (e = 2 is the ellipsoid). On the
///                                                            surface ‖∇f‖ ∈
///                                                            [ρ/(a_max·3^{(e−2)/2e}) , ρ/a_min];
///                                                            C² for e ≥ 2.
///   kCylinderSide  f = (ξ_x² + ξ_y² − r²) / (2r)             infinite cylinder along F's z
/// Planar kinds (functions of (x, y) only; z-derivatives are zero, callers use the xy block):
///   kHalfPlane     f = y
///   kDisc          f = (ξ_x² + ξ_y² − r²) / (2r)             r = radii.x()
///   kEllipse       f = (ρ/2) ((ξ_x/a_x)² + (ξ_y/a_y)² − 1)   ρ = (a_x a_y)^{1/2}
///   kSuperellipse  f = (ρ/e) (|ξ_x/a_x|^e + |ξ_y/a_y|^e − 1) e ≥ 2, ρ as for the ellipse
/// All forms are convex on all of R³ (R²), so a sublevel set {f ≤ 0} is convex.
enum class ImplicitType {
  kHalfspace,
  kSphere,
  kEllipsoid,
  kSuperquadric,
  kCylinderSide,  ///< infinite cylinder along z
  kHalfPlane,
  kDisc,
  kEllipse,
  kSuperellipse,
};

/// True for the planar kinds (functions of x, y only).
constexpr bool IsPlanar(ImplicitType t) {
  return t == ImplicitType::kHalfPlane || t == ImplicitType::kDisc || t == ImplicitType::kEllipse ||
         t == ImplicitType::kSuperellipse;
}

/// One convex implicit function f(ξ) ≤ 0 inside, in a shape frame; ξ ∈ R³. Planar shapes are
/// functions of (x, y) only: their z-derivatives are zero and callers use the xy block.
/// Value/Gradient/Hessian take the point in the SHAPE frame S and return the gradient and
/// Hessian with respect to p_S (the function frame F is placed in S by X_SF).
struct ImplicitFunction {
  ImplicitType type = ImplicitType::kSphere;
  Isometry3d X_SF = Isometry3d::Identity();  ///< function frame in shape frame (planar: about z)
  Vector3d radii = Vector3d::Ones();         ///< m; r = radii.x() for sphere/disc/cylinder
  double exponent = 2.0;                     ///< superquadric/superellipse exponent e ≥ 2

  double Value(const Vector3d& p_S) const;
  Vector3d Gradient(const Vector3d& p_S) const;
  Matrix3d Hessian(const Vector3d& p_S) const;
  /// Any of f, grad, hess may be null.
  void Evaluate(const Vector3d& p_S, double* f, Vector3d* grad, Matrix3d* hess) const;
};

/// A convex body: the intersection of convex implicit functions (box = 6 half-spaces,
/// cylinder = infinite cylinder ∩ 2 half-spaces, lens = ∩ of 2 spheres, polygon = ∩ half-planes).
/// A single half-space/half-plane set is unbounded (bounding_radius = +infinity).
struct ImplicitSet {
  Dim dim = Dim::kSpatial;
  std::vector<ImplicitFunction> functions;
  double bounding_radius = 0.0;  ///< m; about the shape origin; +infinity if unbounded
  /// m; a point inside the set (shape frame; the centroid for the scene shapes, the origin for
  /// a half-space), used to start closest-point searches.
  Vector3d center_S = Vector3d::Zero();
  /// m; the corners (shape frame) when every function is a half-space/half-plane (box,
  /// polygon, polyhedron), else empty. ClosestPoints uses them for exact support points.
  std::vector<Vector3d> vertices_S;
  /// The scene shape kind MakeImplicitSet built the set from (closed-form support points for
  /// cylinder and lens); sets assembled by hand leave `from_shape` false.
  bool from_shape = false;
  ShapeType shape_type = ShapeType::kSphere;

  /// max_k f_k(p_S) (≤ 0 inside the set) and the index of the maximizing function.
  double Value(const Vector3d& p_S, int* active = nullptr) const;
  /// True if every f_k(p_S) ≤ tol.
  bool Contains(const Vector3d& p_S, double tol = 0.0) const;
};

/// The implicit form of a scene Shape (in the shape's own frame; Shape::X_BS places it in the
/// body): half-space, sphere, box (6 half-spaces), disc, polygon (one half-plane per edge),
/// half-plane, and the GI-only kinds (ellipsoid, superquadric, cylinder, lens, ellipse,
/// superellipse) once shape.h has them. Throws std::invalid_argument for shapes without one
/// (capsule, segment, polyhedron) naming the shape.
ImplicitSet MakeImplicitSet(const Shape& shape);

/// Closest points of two implicit sets posed in the world (for initial guesses of GI contacts
/// and for tests). Witness points a1_W ∈ A, a2_W ∈ B (world), signed distance (negative if
/// overlapping: best effort, the penetration depth along n), unit normal n from B to A
/// (a1 − a2 = distance · n when separated), and the index of the active function on each set
/// (the one whose surface holds the witness; for edges/corners the one with the largest
/// multiplier). ok = false if the solver did not converge (outputs are then the last iterate).
/// Planar sets give z = 0 outputs. Throws std::invalid_argument for two unbounded sets or sets
/// of different dimensions.
/// Method: closed forms (iterations = 0) for sphere/disc pairs and for a half-space/half-plane
/// against a set with a closed-form support point (sphere, ellipsoid, superquadric, disc,
/// ellipse, superellipse, cylinder, lens, or a polytope with vertices_S); otherwise two Newton
/// (MCP) phases with proximal re-centring: the convex distance problem from the centres, then the
/// common-normal system −u ∈ ∂A-normal cone at a1, u at a2, a1 − a2 = s u, ‖u‖ = 1, which stays
/// well posed when touching or overlapping (s < 0). Known limit of the Newton path: a nearly
/// (not exactly) flat contact whose support point sits on an edge with a tiny multiplier (a
/// cylinder lying almost flat) is solved to a natural residual of 1e-8 (scaled by the larger
/// bounding radius) only, and in deep overlap may fail (ok = false).
struct ImplicitProximity {
  bool ok = false;
  Vector3d a1_W = Vector3d::Zero();
  Vector3d a2_W = Vector3d::Zero();
  Vector3d n_W = Vector3d::UnitZ();
  double distance = 0.0;  ///< m
  int active_a = -1;      ///< index into a.functions
  int active_b = -1;      ///< index into b.functions
  int iterations = 0;     ///< Newton iterations used
};
ImplicitProximity ClosestPoints(const ImplicitSet& a, const Isometry3d& X_WA, const ImplicitSet& b,
                                const Isometry3d& X_WB);

}  // namespace vinci::sim
