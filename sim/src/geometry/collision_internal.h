// Private helpers shared by the narrow phase (collision.cc, collision_polytope.cc,
// collision_planar.cc), the convex
// hull (convex_hull.cc) and the mass properties (mass_properties.cc). Not installed.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "vinci/sim/geometry/shape.h"

namespace vinci::sim::collision_internal {

// Relative tolerance (times a shape size) under which two points coincide, two support values
// tie, or a point lies on a plane.
inline constexpr double kRelTol = 1e-9;
// Segment parameters in (kParamEps, 1 − kParamEps) are "interior" (edge–edge, vertex–segment).
inline constexpr double kParamEps = 1e-9;
// Polytope edges whose directions have |sin angle| below this are parallel (no edge–edge
// contact; the vertex–face contacts cover them).
inline constexpr double kEdgeParallelSin = 1e-6;
// Capsules / rounded segments whose axes have |sin angle| below this and whose projections
// overlap get two contacts at the overlap ends instead of one at the closest points.
inline constexpr double kAxisParallelSin = 1e-3;

inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// "kBox", "kDisc", ... for error messages.
const char* ShapeTypeName(ShapeType t);

/// Parameter t ∈ [0, 1] of the point of segment [a, b] closest to x.
template <class V>
double ClosestParamOnSegment(const V& a, const V& b, const V& x) {
  const V d = b - a;
  const double dd = d.squaredNorm();
  if (dd <= std::numeric_limits<double>::min()) return 0.0;
  return std::clamp(d.dot(x - a) / dd, 0.0, 1.0);
}

/// Closest points p1 + s (q1 − p1) and p2 + t (q2 − p2) of two segments (Ericson, Real-Time
/// Collision Detection §5.1.9). For parallel segments one of the closest pairs is returned.
template <class V>
void ClosestSegmentSegment(const V& p1, const V& q1, const V& p2, const V& q2, double* s,
                           double* t) {
  constexpr double kTiny = std::numeric_limits<double>::min();
  const V d1 = q1 - p1;
  const V d2 = q2 - p2;
  const V r = p1 - p2;
  const double a = d1.squaredNorm();
  const double e = d2.squaredNorm();
  const double f = d2.dot(r);
  if (a <= kTiny && e <= kTiny) {
    *s = *t = 0.0;
    return;
  }
  if (a <= kTiny) {
    *s = 0.0;
    *t = std::clamp(f / e, 0.0, 1.0);
    return;
  }
  const double c = d1.dot(r);
  if (e <= kTiny) {
    *t = 0.0;
    *s = std::clamp(-c / a, 0.0, 1.0);
    return;
  }
  const double b = d1.dot(d2);
  const double denom = a * e - b * b;
  double ss = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
  double tt = (b * ss + f) / e;
  if (tt < 0.0) {
    tt = 0.0;
    ss = std::clamp(-c / a, 0.0, 1.0);
  } else if (tt > 1.0) {
    tt = 1.0;
    ss = std::clamp((b - c) / a, 0.0, 1.0);
  }
  *s = ss;
  *t = tt;
}

/// A unit vector perpendicular to the unit vector u (deterministic).
Vector3d AnyPerpendicular(const Vector3d& u);

/// Brute-force convex hull of `points` (O(n⁴) worst case; fine for a few dozen points).
/// Faces are maximal (coplanar triangles merged), their vertex loops counter-clockwise about
/// the outward normal and free of collinear points. Throws std::invalid_argument if the points
/// do not span a volume.
void ComputeConvexHull(const std::vector<Vector3d>& points, std::vector<HullFace>* faces,
                       std::vector<int>* hull_vertices);

/// Hull storage for a polyhedron that was not prepared by PrepareShape.
struct HullScratch {
  std::vector<HullFace> faces;
  std::vector<int> hull_vertices;
};

/// Box faces in the order +x, −x, +y, −y, +z, −z; corner i has coordinate signs
/// (bit 0 → x, bit 1 → y, bit 2 → z). Loops are counter-clockwise about the outward normal.
inline constexpr int kBoxFaceLoops[6][4] = {{1, 3, 7, 5}, {0, 4, 6, 2}, {2, 6, 7, 3},
                                            {0, 1, 5, 4}, {4, 5, 7, 6}, {0, 2, 3, 1}};

/// Read-only view of a convex polytope in its shape frame: a box (8 corners, 6 faces, from
/// static tables, no allocation) or a polyhedron's hull.
class Polytope {
 public:
  explicit Polytope(const Vector3d& half_extents);
  Polytope(const std::vector<Vector3d>& vertices, const std::vector<int>& hull_vertices,
           const std::vector<HullFace>& faces);

  int num_vertices() const { return is_box_ ? 8 : static_cast<int>(hull_vertices_->size()); }
  Vector3d vertex(int i) const {
    return is_box_ ? box_vertices_[i] : (*vertices_)[(*hull_vertices_)[i]];
  }
  int num_faces() const { return is_box_ ? 6 : static_cast<int>(faces_->size()); }
  Vector3d face_normal(int f) const {
    if (!is_box_) return (*faces_)[f].normal_S;
    Vector3d n = Vector3d::Zero();
    n[f / 2] = (f % 2 == 0) ? 1.0 : -1.0;
    return n;
  }
  double face_offset(int f) const { return is_box_ ? h_[f / 2] : (*faces_)[f].offset; }
  int face_size(int f) const {
    return is_box_ ? 4 : static_cast<int>((*faces_)[f].vertices.size());
  }
  Vector3d face_vertex(int f, int k) const {
    return is_box_ ? box_vertices_[kBoxFaceLoops[f][k]] : (*vertices_)[(*faces_)[f].vertices[k]];
  }
  /// max over the polytope of d · x.
  double MaxDot(const Vector3d& d) const {
    if (is_box_) return h_.dot(d.cwiseAbs());
    double m = -kInf;
    for (int i : *hull_vertices_) m = std::max(m, d.dot((*vertices_)[i]));
    return m;
  }
  /// True for a box: corners ±half_extents(), face normals ±e_k, edges along the axes.
  bool is_box() const { return is_box_; }
  /// A box's half extents (m); zero for a polyhedron.
  const Vector3d& half_extents() const { return h_; }
  /// Radius of a ball about the frame origin that contains the polytope (m).
  double radius() const { return radius_; }

  /// Calls fn(x0, x1) once per edge.
  template <class Fn>
  void ForEachEdge(Fn&& fn) const {
    if (is_box_) {
      for (int bit = 1; bit <= 4; bit <<= 1) {
        for (int i = 0; i < 8; ++i) {
          if ((i & bit) == 0) fn(box_vertices_[i], box_vertices_[i | bit]);
        }
      }
      return;
    }
    // Every hull edge is traversed once in each direction by its two faces; keep i < j.
    for (const HullFace& face : *faces_) {
      const int n = static_cast<int>(face.vertices.size());
      for (int k = 0; k < n; ++k) {
        const int i = face.vertices[k];
        const int j = face.vertices[(k + 1) % n];
        if (i < j) fn((*vertices_)[i], (*vertices_)[j]);
      }
    }
  }

 private:
  bool is_box_ = true;
  Vector3d h_ = Vector3d::Zero();
  std::array<Vector3d, 8> box_vertices_;
  const std::vector<Vector3d>* vertices_ = nullptr;
  const std::vector<int>* hull_vertices_ = nullptr;
  const std::vector<HullFace>* faces_ = nullptr;
  double radius_ = 0.0;
};

/// Polytope view of a box or polyhedron shape; an unprepared polyhedron's hull is computed
/// into `scratch`, which must outlive the view.
Polytope MakePolytope(const Shape& shape, HullScratch* scratch);

/// Swaps the roles of A and B in out[begin, end): witnesses swapped, normal negated.
void FlipContacts(std::vector<ContactPoint>* out, std::size_t begin);

/// Removes contacts of out[begin, end) whose two witness points both coincide (within tol)
/// with those of an earlier contact of that range. Keeps the order of the others.
void RemoveDuplicateContacts(std::vector<ContactPoint>* out, std::size_t begin, double tol);

/// Throws std::invalid_argument unless the shape's vertices form a simple polygon,
/// counter-clockwise, with at least 3 distinct vertices (collision_concave.cc).
void CheckSimplePolygon(const Shape& s);

/// Narrow phase for a pair with at least one kConcavePolygon (collision_concave.cc), either
/// order; a vertex near a convex corner of a polygon gives a corner contact.
void CollideConcave(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                    double envelope, std::vector<ContactPoint>* out);

/// Closest points p0 + s d and q0 + t e of two non-parallel lines.
inline void LineLineParams(const Vector3d& p0, const Vector3d& d, const Vector3d& q0,
                           const Vector3d& e, double* s, double* t) {
  const Vector3d r = p0 - q0;
  const double aa = d.dot(d), ee = e.dot(e), bb = d.dot(e), cc = d.dot(r), ff = e.dot(r);
  const double denom = aa * ee - bb * bb;
  *s = (bb * ff - cc * ee) / denom;
  *t = (aa * ff - bb * cc) / denom;
}

/// A segment parameter in (kParamEps, 1 − kParamEps).
inline bool Interior(double t) { return t > kParamEps && t < 1.0 - kParamEps; }

/// The edge–edge contact of A's edge a0 + s da and B's edge b0 + t db (both in B's frame;
/// X_BA = (R_ABᵀ, p_BA); c = da × db, c_norm = |c|) at their closest points, s and t interior:
/// appends the first of the normals ±c/|c| (the separating one first) whose gap lies in
/// [min(0, face_sep − support_tol), envelope] and at which both closest points are support
/// points within support_tol. Shared by PolytopePolytope and BoxBox, so their edge contacts
/// have the same bits.
inline void EdgeEdgeContact(const Polytope& A, const Polytope& B, const Matrix3d& R_AB,
                            const Vector3d& p_BA, const Isometry3d& X_WB, const Vector3d& a0,
                            const Vector3d& da, double s, const Vector3d& b0, const Vector3d& db,
                            double t, const Vector3d& c, double c_norm, double envelope,
                            double face_sep, double support_tol, std::vector<ContactPoint>* out) {
  const Vector3d pa = a0 + s * da;
  const Vector3d pb = b0 + t * db;
  const Vector3d axis = c / c_norm;
  const double sep = axis.dot(pa - pb);
  for (const double sign : {sep >= 0.0 ? 1.0 : -1.0, sep >= 0.0 ? -1.0 : 1.0}) {
    const Vector3d n = sign * axis;
    const double gap = sign * sep;
    if (gap > envelope || (gap < 0.0 && gap < face_sep - support_tol)) continue;
    if (B.MaxDot(n) - n.dot(pb) > support_tol) continue;
    const double min_a = -A.MaxDot(-(R_AB * n)) + n.dot(p_BA);
    if (n.dot(pa) - min_a > support_tol) continue;
    out->push_back({X_WB * pa, X_WB * pb, X_WB.linear() * n, gap});
    return;
  }
}

/// The vertex-feature passes' emission (VertexFeatures, BoxVertexFeatures): the contact between
/// x on P and y on Q with normal n, all in Q's frame, put in the world as (a, b) = (P, Q) if
/// p_is_a, else (Q, P) with the normal reversed.
inline void EmitQFrameContact(const Isometry3d& X_WQ, bool p_is_a, const Vector3d& x,
                              const Vector3d& y, const Vector3d& n, double gap,
                              std::vector<ContactPoint>* out) {
  const Vector3d n_W = X_WQ.linear() * n;
  if (p_is_a) {
    out->push_back({X_WQ * x, X_WQ * y, n_W, gap});
  } else {
    out->push_back({X_WQ * y, X_WQ * x, -n_W, gap});
  }
}

/// Box or polyhedron A against box or polyhedron B: vertex–face, vertex–edge/vertex and
/// edge–edge contacts within the envelope, duplicates removed (collision_polytope.cc).
void PolytopePolytope(const Polytope& A, const Isometry3d& X_WA, const Polytope& B,
                      const Isometry3d& X_WB, double envelope, std::vector<ContactPoint>* out);

/// PolytopePolytope for two boxes: the same contacts, bit for bit, with fewer features formed
/// (collision_box.cc). Falls back to PolytopePolytope for a polyhedron, a degenerate box or a
/// non-finite pose or envelope.
void BoxBox(const Polytope& A, const Isometry3d& X_WA, const Polytope& B, const Isometry3d& X_WB,
            double envelope, std::vector<ContactPoint>* out);

/// Narrow phase for two planar shapes (collision_planar.cc).
void CollidePlanar(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                   double envelope, std::vector<ContactPoint>* out);

}  // namespace vinci::sim::collision_internal
