// Convex hull of a polyhedron's points, the Polytope view used by the narrow phase, and
// PrepareShape.
#include <libqhull_r/qhull_ra.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "collision_internal.h"

namespace vinci::sim {
namespace collision_internal {
namespace {

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

// Indices of the points without repeats: a point within tol of an earlier one is dropped (only
// the first copy takes part). A hash grid of cell tol keeps this O(n).
std::vector<int> UniquePoints(const std::vector<Vector3d>& points, const Vector3d& centroid,
                              double tol) {
  struct KeyHash {
    std::size_t operator()(const std::array<long long, 3>& k) const {
      return std::hash<long long>()(k[0] * 73856093LL ^ k[1] * 19349663LL ^ k[2] * 83492791LL);
    }
  };
  std::unordered_map<std::array<long long, 3>, std::vector<int>, KeyHash> grid;
  std::vector<int> unique;
  for (int i = 0; i < static_cast<int>(points.size()); ++i) {
    // |p − centroid| ≤ scale = tol / kRelTol, so the cell indices stay below 1e9 + 1.
    const Vector3d c = ((points[i] - centroid) / tol).array().floor();
    const std::array<long long, 3> key = {static_cast<long long>(c.x()),
                                          static_cast<long long>(c.y()),
                                          static_cast<long long>(c.z())};
    bool repeat = false;
    for (int dx = -1; dx <= 1 && !repeat; ++dx)
      for (int dy = -1; dy <= 1 && !repeat; ++dy)
        for (int dz = -1; dz <= 1 && !repeat; ++dz) {
          const auto it = grid.find({key[0] + dx, key[1] + dy, key[2] + dz});
          if (it == grid.end()) continue;
          for (int j : it->second) repeat = repeat || (points[i] - points[j]).norm() <= tol;
        }
    if (repeat) continue;
    grid[key].push_back(i);
    unique.push_back(i);
  }
  return unique;
}

// One qhull facet: outward unit normal, offset (normal · p = offset on it), vertex indices into
// the caller's points, and the indices of the neighbouring facets.
struct QhullFacet {
  Vector3d normal;
  double offset = 0.0;
  std::vector<int> vertices;
  std::vector<int> neighbors;
};

// The facets of the hull of points[unique] by qhull (default options: facets coplanar within
// roundoff are merged). Throws std::invalid_argument(`coplanar`) when qhull finds no volume.
std::vector<QhullFacet> QhullFacets(const std::vector<Vector3d>& points,
                                    const std::vector<int>& unique, const Vector3d& centroid,
                                    const std::string& coplanar) {
  std::vector<coordT> coords;
  coords.reserve(3 * unique.size());
  for (int i : unique)
    for (int k = 0; k < 3; ++k) coords.push_back(points[i][k] - centroid[k]);
  // qhull reports its errors on a stream; keep them out of the user's terminal.
  char* err_text = nullptr;
  std::size_t err_size = 0;
  FILE* err = open_memstream(&err_text, &err_size);
  qhT qh_storage;
  qhT* qh = &qh_storage;
  qh_zero(qh, err);
  char options[] = "qhull";
  const int status = qh_new_qhull(qh, 3, static_cast<int>(unique.size()), coords.data(), False,
                                  options, nullptr, err);
  std::vector<QhullFacet> out;
  if (status == 0) {
    std::unordered_map<unsigned, int> index;  // qhull facet id → position in out
    facetT* facet;
    FORALLfacets {
      index[facet->id] = static_cast<int>(out.size());
      QhullFacet f;
      f.normal = Vector3d(facet->normal[0], facet->normal[1], facet->normal[2]);
      f.normal.normalize();
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) {
        f.vertices.push_back(unique[qh_pointid(qh, vertex->point)]);
      }
      f.offset = -kInf;
      for (int i : f.vertices) f.offset = std::max(f.offset, f.normal.dot(points[i]));
      out.push_back(std::move(f));
    }
    FORALLfacets {
      facetT *neighbor, **neighborp;
      std::vector<int>& nb = out[index[facet->id]].neighbors;
      FOREACHneighbor_(facet) nb.push_back(index[neighbor->id]);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong = 0, totlong = 0;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::fclose(err);
  std::free(err_text);
  if (status != 0) throw std::invalid_argument(coplanar);
  return out;
}

}  // namespace

// Qhull (libqhull_r, Debian's libqhull-dev) gives the hull's facets in O(n log n); qhull merges
// only facets coplanar within its roundoff, so adjacent facets whose vertices lie within `tol`
// of one plane are grouped into one face here, and each face's corners are ordered by
// PlanarHull (which drops points on an edge). The faces are those of the former O(n⁴)
// all-triples search: the supporting planes holding ≥ 3 points, vertices within tol of each.
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
    centroid += p / n;  // divided first: a sum of large coordinates must not overflow
  }
  double scale = 0.0;
  for (const Vector3d& p : points) scale = std::max(scale, (p - centroid).norm());
  if (!(scale > 0.0) || !std::isfinite(scale))
    throw std::invalid_argument(scale > 0.0 ? "convex polyhedron: vertex coordinates too large"
                                            : "convex polyhedron: all vertices coincide");
  const double tol = kRelTol * scale;
  const std::vector<int> unique = UniquePoints(points, centroid, tol);
  const std::string coplanar =
      "convex polyhedron: vertices are coplanar (or collinear); a polyhedron needs volume";
  if (unique.size() < 4) throw std::invalid_argument(coplanar);
  const std::vector<QhullFacet> facets = QhullFacets(points, unique, centroid, coplanar);

  // Group adjacent facets lying on one plane (within tol) by union-find.
  const int nf = static_cast<int>(facets.size());
  std::vector<int> parent(nf);
  for (int f = 0; f < nf; ++f) parent[f] = f;
  const auto find = [&](int f) {
    while (parent[f] != f) f = parent[f] = parent[parent[f]];
    return f;
  };
  const auto on_plane_of = [&](const QhullFacet& a, const QhullFacet& b) {
    for (int i : b.vertices)
      if (std::abs(a.normal.dot(points[i]) - a.offset) > tol) return false;
    return true;
  };
  for (int f = 0; f < nf; ++f)
    for (int g : facets[f].neighbors)
      if (g > f && on_plane_of(facets[f], facets[g]) && on_plane_of(facets[g], facets[f]))
        parent[find(g)] = find(f);
  std::vector<std::vector<int>> group_vertices(nf);
  for (int f = 0; f < nf; ++f) {
    std::vector<int>& gv = group_vertices[find(f)];
    gv.insert(gv.end(), facets[f].vertices.begin(), facets[f].vertices.end());
  }
  for (int f = 0; f < nf; ++f) {
    std::vector<int>& gv = group_vertices[f];
    if (gv.empty()) continue;
    std::sort(gv.begin(), gv.end());
    gv.erase(std::unique(gv.begin(), gv.end()), gv.end());
    const Vector3d normal = facets[f].normal;
    double offset = -kInf;
    for (int i : gv) offset = std::max(offset, normal.dot(points[i]));
    // An in-plane direction (any unit vector orthogonal to the normal).
    const Vector3d u = normal.unitOrthogonal();
    HullFace face;
    face.normal_S = normal;
    face.offset = offset;
    face.vertices = PlanarHull(points, std::move(gv), u, normal.cross(u), tol);
    if (face.vertices.size() >= 3) faces->push_back(std::move(face));
  }
  if (faces->size() < 4) throw std::invalid_argument(coplanar);
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
    if (!shape->polygon_checked) collision_internal::CheckSimplePolygon(*shape);
    shape->polygon_checked = true;
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
