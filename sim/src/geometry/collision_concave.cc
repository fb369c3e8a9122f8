// Narrow phase for simple (possibly non-convex) polygons, ShapeType::kConcavePolygon, against
// every planar kind (docs/formulations.md §7).
//
// Features, all in world coordinates:
//  * a vertex x of the other shape (polygon vertices; convex vertices only for a non-convex
//    polygon) against polygon P: every edge e of P with s_e = n_e·(x − v_e) ≤ ε, s_e ≥
//    min(d, 0) − ε (d: exact signed distance of x to P) and whose projection of x lies on the
//    edge grown by ε at both ends is a candidate. Two candidates that are the edges of a CONVEX
//    corner of P (interior angle < π) become ONE corner contact (ContactPoint::corner): x is
//    free iff max(s_1, s_2) ≥ 0, which a pair of per-edge constraints gets wrong (the snag on the
//    extended edge line). The other candidates are plain vertex–edge contacts. If no edge
//    qualifies but d ≤ ε (a vertex deep in P near a reflex corner), the edge with the largest
//    s_e among the nearest segments gives a plain contact.
//  * a disc centre (or a rounded segment's end disc) against P: each edge whose segment is
//    within ε of the disc, exact distance to the closest point of the segment (inside P: the
//    edge's normal, gap −distance − r, nearest edges only). No corner contacts: the distance to
//    a corner point is smooth.
//  * P's convex vertices against a half-plane, a convex polygon (the first rule, with that
//    polygon's corners), a rounded segment (closest axis point, when the vertex supports P
//    towards it) — the usual vertex features.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_internal.h"

namespace vinci::sim::collision_internal {
namespace {

using Contacts = std::vector<ContactPoint>;

Vector3d To3(const Vector2d& v) { return Vector3d(v.x(), v.y(), 0.0); }

// A polygon in world coordinates: vertices, outward edge normals (edge i: v_i → v_i+1) and
// which vertices are convex.
struct WorldPolygon {
  std::vector<Vector2d> v, n;
  std::vector<char> convex;
  double size = 0.0;  // max |v_i − v_0|, for tolerances
  int count() const { return static_cast<int>(v.size()); }
  Vector2d edge(int i) const { return v[(i + 1) % count()] - v[i]; }
};

double SignedTwiceArea(const std::vector<Vector3d>& v) {
  double a2 = 0.0;
  const int n = static_cast<int>(v.size());
  for (int i = 0; i < n; ++i) a2 += Cross2(Vector2d(v[i].head<2>()), v[(i + 1) % n].head<2>());
  return a2;
}

// Into *out, reusing its vectors' storage.
void MakeWorldPolygon(const Shape& s, const Isometry3d& X_WS, WorldPolygon* out) {
  if (s.type == ShapeType::kConcavePolygon && !s.polygon_checked) CheckSimplePolygon(s);
  const int n = static_cast<int>(s.vertices.size());
  if (n < 3) {
    throw std::invalid_argument("polygon shape '" + s.name + "': needs at least 3 vertices, got " +
                                std::to_string(n));
  }
  const double sign = SignedTwiceArea(s.vertices) >= 0.0 ? 1.0 : -1.0;  // kPolygon: either way
  const Eigen::Matrix2d R = X_WS.linear().topLeftCorner<2, 2>();
  const Vector2d p = X_WS.translation().head<2>();
  WorldPolygon& P = *out;
  P.v.clear();
  P.n.clear();
  P.convex.clear();
  P.size = 0.0;
  for (int i = 0; i < n; ++i) P.v.push_back(R * s.vertices[i].head<2>() + p);
  for (int i = 0; i < n; ++i) {
    const Vector2d e = P.edge(i);
    P.n.push_back(sign * Vector2d(e.y(), -e.x()) / e.norm());
    P.size = std::max(P.size, (P.v[i] - P.v[0]).norm());
  }
  for (int i = 0; i < n; ++i) {
    const Vector2d e_in = P.edge((i + n - 1) % n), e_out = P.edge(i);
    P.convex.push_back(sign * Cross2(e_in, e_out) > 0.0 ? 1 : 0);
  }
}

bool Inside(const WorldPolygon& P, const Vector2d& x) {
  bool in = false;  // crossing number
  for (int i = 0, j = P.count() - 1; i < P.count(); j = i++) {
    const Vector2d& a = P.v[i];
    const Vector2d& b = P.v[j];
    if ((a.y() > x.y()) != (b.y() > x.y()) &&
        x.x() < (b.x() - a.x()) * (x.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      in = !in;
    }
  }
  return in;
}

// Distance from x to edge i's segment and the closest point.
double SegmentDistance(const WorldPolygon& P, int i, const Vector2d& x, Vector2d* closest) {
  const Vector2d a = P.v[i], b = P.v[(i + 1) % P.count()];
  *closest = a + ClosestParamOnSegment(a, b, x) * (b - a);
  return (x - *closest).norm();
}

// Emits a contact between a point x on the "point" shape and y on polygon P's shape, normal n
// from P toward the point; `point_is_a` orients it (A is pushed along +n).
void Emit(const Vector2d& x, const Vector2d& y, const Vector2d& n, double gap, bool point_is_a,
          Contacts* out) {
  ContactPoint c;
  c.p_A_W = To3(point_is_a ? x : y);
  c.p_B_W = To3(point_is_a ? y : x);
  c.n_W = To3(point_is_a ? n : Vector2d(-n));
  c.gap = gap;
  out->push_back(c);
}

// A polygon vertex x against P (see the file comment, first rule).
void VertexVsPolygon(const Vector2d& x, const WorldPolygon& P, double envelope, bool point_is_a,
                     Contacts* out) {
  const int n = P.count();
  double dist = kInf;
  Vector2d y;
  for (int i = 0; i < n; ++i) dist = std::min(dist, SegmentDistance(P, i, x, &y));
  const double d = Inside(P, x) ? -dist : dist;
  if (d > envelope) return;
  thread_local std::vector<char> candidate;
  thread_local std::vector<double> s;
  candidate.assign(static_cast<std::size_t>(n), 0);
  s.resize(static_cast<std::size_t>(n));
  bool any = false;
  for (int i = 0; i < n; ++i) {
    s[i] = P.n[i].dot(x - P.v[i]);
    const Vector2d e = P.edge(i);
    const double len = e.norm();
    const double along = e.dot(x - P.v[i]) / len;
    if (s[i] <= envelope && s[i] >= std::min(d, 0.0) - envelope && along >= -envelope &&
        along <= len + envelope) {
      candidate[i] = 1;
      any = true;
    }
  }
  if (!any) {  // deep near a reflex corner: push out through the best of the nearest edges
    const double tol = kRelTol * P.size + 1e-12;
    int best = -1;
    for (int i = 0; i < n; ++i) {
      if (SegmentDistance(P, i, x, &y) <= dist + tol && (best < 0 || s[i] > s[best])) best = i;
    }
    if (best < 0) return;
    candidate[best] = 1;
  }
  // Merge the two edges of each convex corner into one corner contact.
  for (int k = 0; k < n; ++k) {
    const int e1 = (k + n - 1) % n, e2 = k;
    if (!P.convex[k] || !candidate[e1] || !candidate[e2]) continue;
    candidate[e1] = candidate[e2] = 0;
    ContactPoint c;
    Emit(x, x - s[e1] * P.n[e1], P.n[e1], s[e1], point_is_a, out);
    c = out->back();
    out->pop_back();
    Emit(x, x - s[e2] * P.n[e2], P.n[e2], s[e2], point_is_a, out);
    c.corner = true;
    c.p2_A_W = out->back().p_A_W;
    c.p2_B_W = out->back().p_B_W;
    c.n2_W = out->back().n_W;
    c.gap2 = out->back().gap;
    out->back() = c;
  }
  for (int i = 0; i < n; ++i) {
    if (candidate[i]) Emit(x, x - s[i] * P.n[i], P.n[i], s[i], point_is_a, out);
  }
}

// A disc (centre x, radius r ≥ 0) against P (second rule).
void DiscVsPolygon(const Vector2d& x, double r, const WorldPolygon& P, double envelope,
                   bool point_is_a, Contacts* out) {
  const int n = P.count();
  const bool inside = Inside(P, x);
  const double tiny = kRelTol * (P.size + r);
  double dmin = kInf;
  Vector2d y;
  for (int i = 0; i < n; ++i) dmin = std::min(dmin, SegmentDistance(P, i, x, &y));
  for (int i = 0; i < n; ++i) {
    const double dist = SegmentDistance(P, i, x, &y);
    if (inside) {
      if (dist > dmin + envelope) continue;
      const Vector2d x_r = x - r * P.n[i];
      Emit(x_r, y, P.n[i], P.n[i].dot(x_r - y), point_is_a, out);
      continue;
    }
    if (dist - r > envelope) continue;
    const Vector2d nrm = dist > tiny ? Vector2d((x - y) / dist) : P.n[i];
    Emit(x - r * nrm, y, nrm, dist - r, point_is_a, out);
  }
}

// A vertex x of polygon P (convex there) against a half-plane with outward normal m through o.
void VertexVsHalfPlane(const Vector2d& x, const Vector2d& o, const Vector2d& m, double envelope,
                       bool point_is_a, Contacts* out) {
  const double gap = m.dot(x - o);
  if (gap <= envelope) Emit(x, x - gap * m, m, gap, point_is_a, out);
}

// P's convex vertices against a rounded segment [s0, s1] of radius r: the closest interior axis
// point, when P is supported at the vertex towards it.
void VerticesVsSegment(const WorldPolygon& P, const Vector2d& s0, const Vector2d& s1, double r,
                       double envelope, bool polygon_is_a, Contacts* out) {
  const double tiny = kRelTol * (P.size + (s1 - s0).norm() + r);
  for (int k = 0; k < P.count(); ++k) {
    if (!P.convex[k]) continue;
    const Vector2d& v = P.v[k];
    const double t = ClosestParamOnSegment(s0, s1, v);
    if (t <= kParamEps || t >= 1.0 - kParamEps) continue;  // the end discs cover it
    const Vector2d c = s0 + t * (s1 - s0);
    const double dist = (c - v).norm();
    if (dist - r > envelope || dist <= tiny) continue;
    const Vector2d nrm = (c - v) / dist;  // from P toward the segment
    const int n = P.count();
    if (nrm.dot(P.v[(k + 1) % n] - v) > envelope + tiny ||
        nrm.dot(P.v[(k + n - 1) % n] - v) > envelope + tiny) {
      continue;
    }
    // The segment's point is the "point" side; P is the edge side.
    Emit(c - r * nrm, v, nrm, dist - r, !polygon_is_a, out);
  }
}

// Removes contacts of out[begin, end) equal to an earlier one: same witnesses (within tol) and
// same normals. A vertex exactly on a vertex keeps both corner contacts (each polygon's corner
// against the other's vertex): their normals differ and each may carry the support.
void RemoveDuplicates(Contacts* out, std::size_t begin, double tol) {
  const auto same = [tol](const ContactPoint& a, const ContactPoint& b) {
    const auto near = [tol](const Vector3d& x, const Vector3d& y) { return (x - y).norm() <= tol; };
    if (!near(a.p_A_W, b.p_A_W) || !near(a.p_B_W, b.p_B_W) || a.corner != b.corner) return false;
    if (!a.corner) return (a.n_W - b.n_W).norm() <= 1e-9;
    return ((a.n_W - b.n_W).norm() <= 1e-9 && (a.n2_W - b.n2_W).norm() <= 1e-9) ||
           ((a.n_W - b.n2_W).norm() <= 1e-9 && (a.n2_W - b.n_W).norm() <= 1e-9);
  };
  std::size_t kept = begin;
  for (std::size_t i = begin; i < out->size(); ++i) {
    bool duplicate = false;
    for (std::size_t j = begin; j < kept && !duplicate; ++j) duplicate = same((*out)[i], (*out)[j]);
    if (duplicate) continue;
    if (kept != i) (*out)[kept] = (*out)[i];
    ++kept;
  }
  out->resize(kept);
}

}  // namespace

void CheckSimplePolygon(const Shape& s) {
  const int n = static_cast<int>(s.vertices.size());
  const auto bad = [&](const std::string& what) {
    throw std::invalid_argument("concave_polygon shape '" + s.name + "': " + what);
  };
  if (n < 3) bad("needs at least 3 vertices, got " + std::to_string(n));
  double size = 0.0;
  for (int i = 0; i < n; ++i) {
    if (!s.vertices[i].head<2>().allFinite()) bad("vertex " + std::to_string(i) + " not finite");
    size = std::max(size, (s.vertices[i] - s.vertices[0]).head<2>().norm());
  }
  for (int i = 0; i < n; ++i) {
    if ((s.vertices[i] - s.vertices[(i + 1) % n]).head<2>().norm() <= kRelTol * size) {
      bad("vertices " + std::to_string(i) + " and " + std::to_string((i + 1) % n) + " coincide");
    }
  }
  // No two non-adjacent edges may touch; adjacent edges may not fold back onto each other.
  for (int i = 0; i < n; ++i) {
    const Vector2d a0 = s.vertices[i].head<2>(), a1 = s.vertices[(i + 1) % n].head<2>();
    for (int j = i + 1; j < n; ++j) {
      const Vector2d b0 = s.vertices[j].head<2>(), b1 = s.vertices[(j + 1) % n].head<2>();
      const bool adjacent = j == i + 1 || (i == 0 && j == n - 1);
      if (adjacent) {
        const Vector2d ea = a1 - a0, eb = b1 - b0;
        if (std::abs(Cross2(ea, eb)) <= kRelTol * ea.norm() * eb.norm() && ea.dot(eb) < 0.0) {
          bad("edges " + std::to_string(i) + " and " + std::to_string(j) + " fold back");
        }
        continue;
      }
      double t, u;
      ClosestSegmentSegment(a0, a1, b0, b1, &t, &u);
      if ((a0 + t * (a1 - a0) - (b0 + u * (b1 - b0))).norm() <= kRelTol * size) {
        bad("edges " + std::to_string(i) + " and " + std::to_string(j) +
            " intersect (not a simple polygon)");
      }
    }
  }
  if (!(SignedTwiceArea(s.vertices) > 0.0)) {
    bad("vertices must be counter-clockwise (signed area " +
        std::to_string(0.5 * SignedTwiceArea(s.vertices)) + ", expected > 0)");
  }
}

void CollideConcave(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                    double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  // Orient so that `p` is a concave polygon (if both are, a).
  const bool swap = a.type != ShapeType::kConcavePolygon;
  const Shape& p = swap ? b : a;
  const Shape& o = swap ? a : b;
  const Isometry3d& X_WP = swap ? X_WB : X_WA;
  const Isometry3d& X_WO = swap ? X_WA : X_WB;
  // Per-thread polygons (storage reuse; this function does not recurse).
  thread_local WorldPolygon P_buffer, O_buffer;
  MakeWorldPolygon(p, X_WP, &P_buffer);
  const WorldPolygon& P = P_buffer;
  // p is shape A unless swapped.
  const bool p_is_a = !swap;
  double tie = kRelTol * P.size;
  switch (o.type) {
    case ShapeType::kPolygon:
    case ShapeType::kConcavePolygon: {
      MakeWorldPolygon(o, X_WO, &O_buffer);
      const WorldPolygon& O = O_buffer;
      tie += kRelTol * O.size;
      for (int k = 0; k < O.count(); ++k) {
        if (O.convex[k]) VertexVsPolygon(O.v[k], P, envelope, !p_is_a, out);
      }
      for (int k = 0; k < P.count(); ++k) {
        if (P.convex[k]) VertexVsPolygon(P.v[k], O, envelope, p_is_a, out);
      }
      break;
    }
    case ShapeType::kDisc:
      DiscVsPolygon(X_WO.translation().head<2>(), o.radius, P, envelope, !p_is_a, out);
      break;
    case ShapeType::kSegment: {
      const Vector2d c = X_WO.translation().head<2>();
      const Vector2d axis = X_WO.linear().col(0).head<2>() * o.half_length;
      DiscVsPolygon(c - axis, o.radius, P, envelope, !p_is_a, out);
      if (o.half_length > 0.0) {
        DiscVsPolygon(c + axis, o.radius, P, envelope, !p_is_a, out);
        VerticesVsSegment(P, c - axis, c + axis, o.radius, envelope, p_is_a, out);
      }
      tie += kRelTol * (o.half_length + o.radius);
      break;
    }
    case ShapeType::kHalfPlane: {
      const Vector2d origin = X_WO.translation().head<2>();
      const Vector2d m = X_WO.linear().col(1).head<2>();
      for (int k = 0; k < P.count(); ++k) {
        if (P.convex[k]) VertexVsHalfPlane(P.v[k], origin, m, envelope, p_is_a, out);
      }
      break;
    }
    default:
      throw std::invalid_argument(std::string("CollideShapes: cannot collide ") +
                                  ShapeTypeName(a.type) + " with " + ShapeTypeName(b.type));
  }
  RemoveDuplicates(out, begin, tie);
}

}  // namespace vinci::sim::collision_internal
