// Collision geometry attached to bodies.
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/types.h"

namespace vinci::sim {

/// Shape kinds. Spatial scenes use kHalfSpace…kPolyhedron and kEllipsoid…kLens, planar scenes
/// kHalfPlane…kSegment, kEllipse, kSuperellipse and kConcavePolygon. All shapes but
/// kConcavePolygon are convex; a non-convex spatial part is a body with several shapes. The smooth
/// kinds from kEllipsoid on have no polygonal/analytic contact in CollideShapes: they need the
/// geometrically implicit stepper (formulation: gi), which uses their implicit form
/// (implicit_surface.h).
enum class ShapeType {
  kHalfSpace,   ///< {z ≤ 0} in the shape frame; outward normal +z. Usually on a static body.
  kSphere,      ///< radius
  kBox,         ///< half_extents (x, y, z)
  kCapsule,     ///< segment from −half_length to +half_length along shape z, swept by radius
  kPolyhedron,  ///< convex hull of `vertices` (shape frame)
  kHalfPlane,   ///< {y ≤ 0} in the planar shape frame; outward normal +y
  kDisc,        ///< radius
  kPolygon,     ///< convex polygon, `vertices` counter-clockwise (only x, y used)
  kSegment,     ///< segment from −half_length to +half_length along shape x, swept by radius
                ///< (radius 0 gives a bare segment)
  /// Semi-axes `half_extents` (x, y, z).
  kEllipsoid,
  /// |x/a|^e + |y/b|^e + |z/c|^e ≤ 1 with (a, b, c) = half_extents, e = exponent ≥ 2.
  kSuperquadric,
  /// radius; axis along shape z from −half_length to +half_length.
  kCylinder,
  /// Intersection of two spheres of `radius` R, symmetric about the shape xy plane, thickness
  /// 2·half_length (0 < half_length ≤ R; = R is a sphere): sphere centres at z = ±(R −
  /// half_length).
  kLens,
  /// Planar; semi-axes half_extents.x, half_extents.y.
  kEllipse,
  /// Planar; |x/a|^e + |y/b|^e ≤ 1 with (a, b) = half_extents.xy, e = exponent ≥ 2.
  kSuperellipse,
  /// Simple (possibly non-convex) polygon, `vertices` counter-clockwise (only x, y used); its
  /// convex corners give corner contacts (docs/formulations.md §7).
  kConcavePolygon,
};

/// True for the planar shape kinds.
constexpr bool IsPlanar(ShapeType t) {
  return t == ShapeType::kHalfPlane || t == ShapeType::kDisc || t == ShapeType::kPolygon ||
         t == ShapeType::kSegment || t == ShapeType::kEllipse || t == ShapeType::kSuperellipse ||
         t == ShapeType::kConcavePolygon;
}

/// True for the smooth kinds that only the geometrically implicit stepper can collide
/// (CollideShapes throws std::invalid_argument for them).
constexpr bool RequiresImplicitContact(ShapeType t) {
  return t == ShapeType::kEllipsoid || t == ShapeType::kSuperquadric || t == ShapeType::kCylinder ||
         t == ShapeType::kLens || t == ShapeType::kEllipse || t == ShapeType::kSuperellipse;
}

/// The scene-file keyword of a shape kind ("sphere", "ellipsoid", "halfplane", ...).
const char* ShapeKeyword(ShapeType t);

/// One face of a convex polyhedron's hull (see PrepareShape).
struct HullFace {
  Vector3d normal_S = Vector3d::UnitZ();  ///< outward unit normal, shape frame
  double offset = 0.0;                    ///< m; the face plane is normal_S · x = offset
  std::vector<int> vertices;  ///< indices into Shape::vertices, counter-clockwise about normal_S
};

/// Convex collision shape, expressed in its own frame S, attached to a body B at X_BS.
struct Shape {
  ShapeType type = ShapeType::kSphere;
  std::string name;  ///< unique within the body ("s0", "s1", ... by default)
  Isometry3d X_BS = Isometry3d::Identity();  ///< pose of S in the body frame (planar: about z)
  double radius = 0.0;                       ///< m; sphere, capsule, disc, segment
  Vector3d half_extents = Vector3d::Zero();  ///< m; box
  double half_length = 0.0;                  ///< m; capsule, segment
  std::vector<Vector3d> vertices;            ///< m; polyhedron, polygon (z ignored for polygons)
  int material = 0;                          ///< index into Scene::materials
  // The smooth kinds reuse the fields above: `radius` and `half_length` for cylinder and lens,
  // `half_extents` as the semi-axes of ellipsoid, superquadric, ellipse and superellipse (z
  // unused in 2D).
  double exponent = 2.0;  ///< superquadric/superellipse exponent e ≥ 2
  /// Polyhedron only, filled by PrepareShape(): the hull's faces, and the indices of the points
  /// of `vertices` that are hull corners (points inside the hull or inside a hull face or edge
  /// are left out). While empty, CollideShapes/ComputeUnitMassProperties compute the hull on
  /// every call (correct, but O(n log n) and allocating each time). Re-run PrepareShape after
  /// editing `vertices`.
  std::vector<HullFace> faces;
  std::vector<int> hull_vertices;  ///< see `faces`
  /// Concave polygon only: set by PrepareShape() once `vertices` passed the simple-polygon check
  /// (O(n²)), which collision and mass properties then skip; they run it on every call while it
  /// is false. Clear it (or re-run PrepareShape) after editing `vertices` other than by a
  /// uniform scaling.
  bool polygon_checked = false;
};

/// Precomputes derived collision data once per shape (the scene builder calls it): for a
/// polyhedron, its convex hull (`faces`, `hull_vertices`); other kinds are left unchanged.
/// Throws std::invalid_argument if a polyhedron has fewer than four non-coplanar vertices, or
/// if a concave polygon is not simple and counter-clockwise.
void PrepareShape(Shape* shape);

/// One contact between two shapes, found within the envelope.
/// The normal points from shape B toward shape A; A is pushed along +n.
/// gap = n · (p_A − p_B): > 0 apart, < 0 penetrating.
struct ContactPoint {
  Vector3d p_A_W = Vector3d::Zero();  ///< witness point on A, world frame (m)
  Vector3d p_B_W = Vector3d::Zero();  ///< witness point on B, world frame (m)
  Vector3d n_W = Vector3d::UnitZ();   ///< unit normal from B to A, world frame
  double gap = 0.0;                   ///< signed distance (m)
  /// Corner contact (docs/formulations.md §7; only from a kConcavePolygon pair): a vertex near a
  /// convex corner of a polygon, where the vertex is free iff max(gap, gap2) ≥ 0. The fields
  /// above are the first edge's vertex–edge contact, the fields below the second edge's (same
  /// vertex witness). false: an ordinary contact and the fields below are unused.
  bool corner = false;
  Vector3d p2_A_W = Vector3d::Zero();  ///< second edge: witness on A (m)
  Vector3d p2_B_W = Vector3d::Zero();  ///< second edge: witness on B (m)
  Vector3d n2_W = Vector3d::UnitZ();   ///< second edge: unit normal from B to A
  double gap2 = 0.0;                   ///< second edge: signed distance to its line (m)
};

/// Appends to `out` every contact between shape a (at X_WA) and shape b (at X_WB)
/// whose gap is ≤ envelope. X_WA/X_WB are the world poses of the *shape* frames.
/// A box face on a half-space gives its four corners; all contacts of a pair are
/// reported, not only the deepest. Throws std::invalid_argument for a pair of kinds
/// that cannot collide (planar with spatial) or two half-spaces/half-planes.
/// Either argument order works; swapping a and b swaps the witnesses and negates n.
/// Planar shapes use only x, y (poses rotate about +z); their outputs have z = 0.
///
/// Method per pair (exact = gap is the signed distance):
/// - half-space/half-plane vs anything: each vertex, or each end sphere/disc, or the sphere/disc.
/// - sphere/disc vs sphere, disc, box, capsule, segment, polyhedron, polygon: one contact, exact
///   (inside a polytope: the nearest face).
/// - capsule–capsule, segment–segment: closest points of the axes, exact; axes within ~0.06°
///   of parallel whose projections overlap give two contacts at the overlap ends. Planar axes
///   that cross are pushed apart along one axis' normal by the nearer end of the other.
/// - capsule/segment vs box/polyhedron/polygon: the two end spheres (exact signed distance),
///   each vertex and edge of the polytope whose closest axis point is interior and which
///   supports the polytope towards that point, and, if the axis passes through the polytope
///   with both ends outside, the middle of the part inside pushed out through its nearest face.
///   Exact when separated.
/// - box/polyhedron pairs, polygon pairs: vertex–face (vertex–edge in 2D) both ways — for each
///   vertex no face plane separates by more than the envelope, the most separating face among
///   those within the envelope of the largest separation for which the vertex is a lowest point
///   of its shape along the face normal (else the plain most separating face); the vertex and
///   its projection, kept if the projection lies within the face grown by the envelope. Plus,
///   when separated, vertex–edge and vertex–vertex pairs that support both shapes, and (3D)
///   edge–edge contacts between non-parallel edges with interior closest points whose cross
///   product supports both shapes; a penetrating edge–edge contact is kept only if it is no
///   deeper than the separation along every face normal (least-penetration axis). Contacts
///   whose two witnesses coincide within 1e-9·size are reported once. Exact when separated
///   (the closest pair is among the contacts; vertex–face contacts near a face boundary may
///   underestimate the gap by up to the envelope). Deep interpenetration with no vertex inside
///   the other shape (two thin bars crossed like a "+") yields no contact.
/// - concave polygon vs any planar kind (collision_concave.cc): the other shape's vertices
///   (convex ones) against the polygon's edges, the polygon's convex vertices against the other
///   shape, discs by exact distance to each edge segment. A vertex within ε of both edges of a
///   convex corner gives ONE corner contact (`corner`: free iff max(gap, gap2) ≥ 0,
///   docs/formulations.md §7) instead of two vertex–edge contacts. Edges closer than ε to a vertex
///   from behind (walls thinner than ε) can give spurious contacts.
/// Allocation-free apart from appending to `out`, except for a polyhedron not yet prepared by
/// PrepareShape (its hull is then computed per call).
/// The smooth GI-only kinds (RequiresImplicitContact) throw std::invalid_argument
/// ("shape type ellipsoid requires formulation: gi").
void CollideShapes(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                   double envelope, std::vector<ContactPoint>* out);

/// Whether the envelope only filters CollideShapes' contacts for shapes of kinds a and b (either
/// order): every contact is computed without the envelope, which only drops those with
/// gap > envelope. So the contacts at an envelope e are exactly, in order, those at any E ≥ e
/// whose gap is not above e. True for a sphere against any spatial kind CollideShapes takes and
/// for a capsule, box or polyhedron against a half-space; false otherwise.
bool EnvelopeOnlyFilters(ShapeType a, ShapeType b);

/// Mass properties of a shape of unit density: volume (area in 2D) and the inertia
/// about the shape's centroid in the shape frame (planar: only (2,2) is used).
/// Half-spaces/half-planes have infinite extent and throw std::invalid_argument.
/// `volume` is m³ for sphere, box, capsule (cylinder + two hemispheres) and polyhedron (its
/// convex hull); m² for disc, polygon and segment (a stadium: rectangle 2·half_length × 2·radius
/// plus two half discs); for a radius-0 segment, a thin rod, it is the length 2·half_length
/// (a line density). Planar shapes carry the inertia of a thin lamina (rod) in the xy-plane:
/// (0,0) = ∫y², (1,1) = ∫x², (0,1) = (1,0) = −∫xy and (2,2) = ∫(x² + y²), per unit mass about
/// the centroid. Non-positive sizes, degenerate polygons and flat polyhedra throw
/// std::invalid_argument naming the shape and field.
struct UnitMassProperties {
  double volume = 0.0;
  Vector3d centroid_S = Vector3d::Zero();
  Matrix3d inertia_per_mass_S = Matrix3d::Zero();  ///< inertia / mass about centroid
};
UnitMassProperties ComputeUnitMassProperties(const Shape& shape);

/// Axis-aligned bounding box of the shape in world frame (for the broad phase), tight for
/// every kind. Half-spaces/half-planes return an infinite box (±infinity), bounded on one side
/// only along a coordinate axis their normal is exactly aligned with. Planar shapes have the
/// z range [0, 0].
struct Aabb {
  Vector3d lo, hi;
  bool Overlaps(const Aabb& o, double margin) const {
    return (lo.array() - margin <= o.hi.array()).all() &&
           (o.lo.array() - margin <= hi.array()).all();
  }
};
Aabb ComputeAabb(const Shape& shape, const Isometry3d& X_WS);

}  // namespace vinci::sim
