// The rate of change of a contact's witness points, normal and gap when its two bodies move
// (the analytic form of re-running CollideShapes at a moved pose, to first order), for the shape
// pairs where it has a closed form. Used by the step sensitivities' derivative along a state
// direction (formulations/step_model.h), which re-collides the other pairs.
#pragma once

#include "vinci/sim/geometry/shape.h"

namespace vinci::sim {

/// A body's rigid motion rate in world: the velocity of its origin o_W (m/s, or m per unit of
/// the direction) and its angular velocity (rad/s).
struct BodyRate {
  Vector3d o_W = Vector3d::Zero();  ///< the body origin (m): where v_W is taken
  Vector3d v_W = Vector3d::Zero();  ///< velocity of the body origin
  Vector3d w_W = Vector3d::Zero();  ///< angular velocity
  /// Velocity of the material point at p_W.
  Vector3d PointVelocity(const Vector3d& p_W) const { return v_W + w_W.cross(p_W - o_W); }
};

/// d/dt of ContactPoint's p_A_W, p_B_W, n_W and gap.
struct ContactPointRate {
  Vector3d p_A_W = Vector3d::Zero();
  Vector3d p_B_W = Vector3d::Zero();
  Vector3d n_W = Vector3d::Zero();
  double gap = 0.0;
};

/// The rate of contact `c` (as CollideShapes(a, ·, b, ·) reports it, a ordered first) when the
/// bodies carrying a and b move at rates `ra` and `rb`. Closed forms (c's features stay the
/// same):
/// - a ball of radius r (sphere, disc, a capsule's or segment's end; r = 0: a vertex of a box,
///   polyhedron or polygon) against a half-space/half-plane (either order): the ball's centre
///   x = p_A + r n is a material point of A and n is B's face normal, so
///   ṅ = ω_B × n, ψ̇ = n·(ẋ − v_B(p_B)), ṗ_A = ẋ − r ṅ, ṗ_B = ẋ − (ψ + r) ṅ − ψ̇ n;
/// - sphere–sphere, disc–disc (centres c_A, c_B at distance d > 0): ṅ = (I − n nᵀ)(ċ_A − ċ_B)/d,
///   ψ̇ = n·(ċ_A − ċ_B), ṗ_A = ċ_A − r_A ṅ, ṗ_B = ċ_B + r_B ṅ.
/// Returns false (out untouched) for other pairs and for corner contacts: the caller re-collides.
bool ContactRate(const Shape& a, const Shape& b, const ContactPoint& c, const BodyRate& ra,
                 const BodyRate& rb, ContactPointRate* out);

/// Which body carries the vertex of a polytope–polytope (box, polyhedron) vertex–face contact.
enum class VertexSide : signed char {
  kNone,  ///< not a vertex–face contact of two polytopes (edge–edge, corner, other shapes)
  kA,     ///< p_A is a vertex of a, n is (the world image of) a face normal of b
  kB,     ///< p_B is a vertex of b, −n is a face normal of a
};

/// A polytope–polytope contact's features at the shape poses X_WA, X_WB (world).
struct PolytopeFeature {
  VertexSide side = VertexSide::kNone;
  /// The witness on the face lies within `near` (m) of that face's boundary (an edge or vertex
  /// of the face-carrying body): moving the bodies by more than that can switch the features
  /// the collision routine reports (flush equal boxes: a vertex of a on a vertex of b, where
  /// "a's vertex on b's face" and "b's vertex on a's face" coincide) — a kink of the contact
  /// geometry in the poses.
  bool near_face_boundary = false;
  /// Edge–edge (side kNone): p_A interior to an edge of a with unit direction e_A_W, p_B
  /// interior to an edge of b with direction e_B_W, not parallel.
  bool edge_edge = false;
  Vector3d e_A_W = Vector3d::Zero(), e_B_W = Vector3d::Zero();
};

/// Boxes and convex polyhedra: the shapes whose contacts have vertex / edge / face features.
bool IsPolytopeType(ShapeType t);

/// Classifies contact `c` of shapes a (pose X_WA) and b (X_WB) as CollideShapes(a, ·, b, ·)
/// reports it. A vertex of a is preferred where both sides fit (the collision routine emits
/// a's vertices first and drops the later duplicate). Tolerance for "is a vertex" / "is a face
/// normal": 1e-9 of the shapes' size.
PolytopeFeature ClassifyPolytopeContact(const Shape& a, const Isometry3d& X_WA, const Shape& b,
                                        const Isometry3d& X_WB, const ContactPoint& c, double near);

/// The rate of a polytope vertex–face contact (side kA: a's vertex on b's face; kB: b's vertex
/// on a's face) with its features held: the ball-on-half-space form above with r = 0 and the
/// face's plane moving with its body. False for side kNone or corner contacts.
bool VertexFaceRate(VertexSide side, const ContactPoint& c, const BodyRate& ra, const BodyRate& rb,
                    ContactPointRate* out);

/// The rate of a polytope edge–edge contact (f.edge_edge) with its edges held: the edges turn
/// with their bodies (ė_A = ω_A × e_A, ė_B = ω_B × e_B), n = ±(e_A × e_B)/|e_A × e_B| (the sign
/// of c.n_W), so ṅ = (I − n nᵀ) ±(ė_A × e_B + e_A × ė_B)/|e_A × e_B|; the witnesses slide along
/// their edges, p_A = a + s e_A, p_B = b + t e_B with p_A − p_B = ψ n, so
/// [e_A, −e_B, −n] (ṡ, ṫ, ψ̇) = ψ ṅ − v_A(p_A) + v_B(p_B) and ṗ_A = v_A(p_A) + ṡ e_A,
/// ṗ_B = v_B(p_B) + ṫ e_B. False if !f.edge_edge or c is a corner contact.
bool EdgeEdgeRate(const PolytopeFeature& f, const ContactPoint& c, const BodyRate& ra,
                  const BodyRate& rb, ContactPointRate* out);

}  // namespace vinci::sim
