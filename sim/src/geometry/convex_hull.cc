// Convex hull of a polyhedron's points, the Polytope view used by the narrow phase, and
// PrepareShape.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "collision_internal.h"

namespace vinci::sim {
namespace collision_internal {
namespace {

// Box faces in the order +x, −x, +y, −y, +z, −z; corner i has coordinate signs
// (bit 0 → x, bit 1 → y, bit 2 → z). Loops are counter-clockwise about the outward normal.
constexpr int kBoxFaceLoops[6][4] = {{1, 3, 7, 5}, {0, 4, 6, 2}, {2, 6, 7, 3},
                                     {0, 1, 5, 4}, {4, 5, 7, 6}, {0, 2, 3, 1}};

// Counter-clockwise 2D hull (Andrew's monotone chain) of the points `idx` with plane coordinates
// (u · p, v · p); collinear and duplicate points are dropped (tolerance `tol`, m).
std::vector<int> PlanarHull(const std::vector<Vector3d>& points, std::vector<int> idx,
                            const Vector3d& u, const Vector3d& v, double tol) {
  auto uv = [&](int i) { return Vector2d(u.dot(points[i]), v.dot(points[i])); };
  std::sort(idx.begin(), idx.end(), [&](int i, int j) {
    const Vector2d a = uv(i), b = uv(j);
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  // Left turn o → a → b by more than tol (distance of a from the line o b).
  auto left_turn = [&](int o, int a, int b) {
    const Vector2d po = uv(o), pa = uv(a), pb = uv(b);
    return Cross2(pa - po, pb - po) > tol * (pb - po).norm();
  };
  const int n = static_cast<int>(idx.size());
  std::vector<int> hull(2 * n);
  int k = 0;
  for (int i = 0; i < n; ++i) {  // lower chain
    while (k >= 2 && !left_turn(hull[k - 2], hull[k - 1], idx[i])) --k;
    hull[k++] = idx[i];
  }
  for (int i = n - 2, lower = k + 1; i >= 0; --i) {  // upper chain
    while (k >= lower && !left_turn(hull[k - 2], hull[k - 1], idx[i])) --k;
    hull[k++] = idx[i];
  }
  hull.resize(std::max(k - 1, 0));
  return hull;
}

}  // namespace

void ComputeConvexHull(const std::vector<Vector3d>& points, std::vector<HullFace>* faces,
                       std::vector<int>* hull_vertices) {
  faces->clear();
  hull_vertices->clear();
  const int n = static_cast<int>(points.size());
  if (n < 4) {
    throw std::invalid_argument("convex polyhedron: needs at least 4 vertices, got " +
                                std::to_string(n));
  }
  Vector3d centroid = Vector3d::Zero();
  for (const Vector3d& p : points) {
    if (!p.allFinite()) throw std::invalid_argument("convex polyhedron: non-finite vertex");
    centroid += p;
  }
  centroid /= n;
  double scale = 0.0;
  for (const Vector3d& p : points) scale = std::max(scale, (p - centroid).norm());
  if (!(scale > 0.0)) throw std::invalid_argument("convex polyhedron: all vertices coincide");
  const double tol = kRelTol * scale;
  // Repeated points: only the first copy takes part.
  std::vector<char> repeat(n, 0);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < i && !repeat[i]; ++j) {
      repeat[i] = !repeat[j] && (points[i] - points[j]).norm() <= tol;
    }
  }

  for (int i = 0; i < n; ++i) {
    if (repeat[i]) continue;
    for (int j = i + 1; j < n; ++j) {
      if (repeat[j]) continue;
      for (int k = j + 1; k < n; ++k) {
        if (repeat[k]) continue;
        const Vector3d& pi = points[i];
        const Vector3d& pj = points[j];
        const Vector3d& pk = points[k];
        // Skip triples already on a known face plane.
        bool known = false;
        for (const HullFace& f : *faces) {
          if (std::abs(f.normal_S.dot(pi) - f.offset) <= tol &&
              std::abs(f.normal_S.dot(pj) - f.offset) <= tol &&
              std::abs(f.normal_S.dot(pk) - f.offset) <= tol) {
            known = true;
            break;
          }
        }
        if (known) continue;
        Vector3d normal = (pj - pi).cross(pk - pi);
        const double longest =
            std::max({(pj - pi).squaredNorm(), (pk - pi).squaredNorm(), (pk - pj).squaredNorm()});
        const double len = normal.norm();
        // Poorly conditioned (sliver or collinear) triples: a better triple spans the face.
        if (!(len > 1e-6 * longest)) continue;
        normal /= len;
        bool above = false, below = false;
        for (const Vector3d& p : points) {
          const double s = normal.dot(p - pi);
          above = above || s > tol;
          below = below || s < -tol;
          if (above && below) break;
        }
        if (above == below) continue;  // not a supporting plane, or all points coplanar
        if (above) normal = -normal;
        double offset = -kInf;
        for (const Vector3d& p : points) offset = std::max(offset, normal.dot(p));
        std::vector<int> on_plane;
        for (int m = 0; m < n; ++m) {
          if (!repeat[m] && offset - normal.dot(points[m]) <= tol) on_plane.push_back(m);
        }
        const Vector3d u = (pj - pi).normalized();
        const Vector3d v = normal.cross(u);
        HullFace face;
        face.normal_S = normal;
        face.offset = offset;
        face.vertices = PlanarHull(points, std::move(on_plane), u, v, tol);
        if (face.vertices.size() >= 3) faces->push_back(std::move(face));
      }
    }
  }
  if (faces->size() < 4) {
    throw std::invalid_argument(
        "convex polyhedron: vertices are coplanar (or collinear); a polyhedron needs volume");
  }
  std::vector<char> used(n, 0);
  for (const HullFace& f : *faces) {
    for (int i : f.vertices) used[i] = 1;
  }
  for (int i = 0; i < n; ++i) {
    if (used[i]) hull_vertices->push_back(i);
  }
}

Polytope::Polytope(const Vector3d& half_extents) : is_box_(true), h_(half_extents) {
  for (int i = 0; i < 8; ++i) {
    box_vertices_[i] = Vector3d((i & 1) ? h_.x() : -h_.x(), (i & 2) ? h_.y() : -h_.y(),
                                (i & 4) ? h_.z() : -h_.z());
  }
  radius_ = h_.norm();
}

Polytope::Polytope(const std::vector<Vector3d>& vertices, const std::vector<int>& hull_vertices,
                   const std::vector<HullFace>& faces)
    : is_box_(false), vertices_(&vertices), hull_vertices_(&hull_vertices), faces_(&faces) {
  for (int i : hull_vertices) radius_ = std::max(radius_, vertices[i].norm());
}

Vector3d Polytope::face_normal(int f) const {
  if (!is_box_) return (*faces_)[f].normal_S;
  Vector3d n = Vector3d::Zero();
  n[f / 2] = (f % 2 == 0) ? 1.0 : -1.0;
  return n;
}

Vector3d Polytope::face_vertex(int f, int k) const {
  return is_box_ ? box_vertices_[kBoxFaceLoops[f][k]] : (*vertices_)[(*faces_)[f].vertices[k]];
}

double Polytope::MaxDot(const Vector3d& d) const {
  if (is_box_) return h_.dot(d.cwiseAbs());
  double m = -kInf;
  for (int i : *hull_vertices_) m = std::max(m, d.dot((*vertices_)[i]));
  return m;
}

Polytope MakePolytope(const Shape& shape, HullScratch* scratch) {
  if (shape.type == ShapeType::kBox) return Polytope(shape.half_extents);
  if (!shape.faces.empty() && !shape.hull_vertices.empty()) {
    return Polytope(shape.vertices, shape.hull_vertices, shape.faces);
  }
  ComputeConvexHull(shape.vertices, &scratch->faces, &scratch->hull_vertices);
  return Polytope(shape.vertices, scratch->hull_vertices, scratch->faces);
}

}  // namespace collision_internal

void PrepareShape(Shape* shape) {
  if (shape->type == ShapeType::kConcavePolygon) {
    collision_internal::CheckSimplePolygon(*shape);
    return;
  }
  if (shape->type != ShapeType::kPolyhedron) return;
  try {
    collision_internal::ComputeConvexHull(shape->vertices, &shape->faces, &shape->hull_vertices);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("shape '" + shape->name + "': " + e.what());
  }
}

}  // namespace vinci::sim
