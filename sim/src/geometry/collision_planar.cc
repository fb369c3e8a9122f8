// Narrow phase for the planar kinds (half-plane, disc, polygon, rounded segment). Shapes live
// in the world xy-plane; only the x, y components of poses and polygon vertices are used and
// every output has z = 0. Pair functions take their shapes in canonical order (lower
// PlanarRank first); CollidePlanar flips the contacts when it swapped.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "collision_internal.h"

namespace vinci::sim::collision_internal {
namespace {

using Contacts = std::vector<ContactPoint>;
using Eigen::Matrix2d;

// Planar pose: x_W = R x_S + p.
struct Frame2 {
  Matrix2d R;
  Vector2d p;
  Vector2d operator*(const Vector2d& x) const { return R * x + p; }
};

Frame2 ToFrame2(const Isometry3d& X) {
  return {X.linear().topLeftCorner<2, 2>(), X.translation().head<2>()};
}

// Pose of frame b in frame a: X_ab = X_Wa⁻¹ X_Wb.
Frame2 Relative(const Frame2& X_Wa, const Frame2& X_Wb) {
  return {X_Wa.R.transpose() * X_Wb.R, X_Wa.R.transpose() * (X_Wb.p - X_Wa.p)};
}

Vector3d To3(const Vector2d& v) { return Vector3d(v.x(), v.y(), 0.0); }

// Counter-clockwise perpendicular.
Vector2d Perp(const Vector2d& v) { return Vector2d(-v.y(), v.x()); }

void Push(const Vector2d& p_A, const Vector2d& p_B, const Vector2d& n, double gap, Contacts* out) {
  out->push_back({To3(p_A), To3(p_B), To3(n), gap});
}

[[noreturn]] void ThrowPair(const Shape& a, const Shape& b, const char* why) {
  throw std::invalid_argument(std::string("CollideShapes: cannot collide ") +
                              ShapeTypeName(a.type) + " with " + ShapeTypeName(b.type) + " (" +
                              why + ")");
}

// Two discs (centres cA, cB); `fallback_n` is used when the centres coincide within `tiny`.
void AddDiscPair(const Vector2d& cA, double rA, const Vector2d& cB, double rB,
                 const Vector2d& fallback_n, double tiny, double envelope, Contacts* out) {
  const Vector2d d = cA - cB;
  const double dist = d.norm();
  const Vector2d n = dist > tiny ? Vector2d(d / dist) : fallback_n;
  const double gap = (dist > tiny ? dist : n.dot(d)) - rA - rB;
  if (gap > envelope) return;
  Push(cA - rA * n, cB + rB * n, n, gap, out);
}

std::pair<Vector2d, Vector2d> SegmentEnds(const Shape& s, const Frame2& X) {
  const Vector2d axis = X.R.col(0) * s.half_length;
  return {X.p - axis, X.p + axis};
}

// Convex polygon view of a shape's vertices (x, y), either orientation.
class Polygon2 {
 public:
  explicit Polygon2(const Shape& s) : v_(&s.vertices) {
    const int n = size();
    if (n < 3) {
      throw std::invalid_argument("polygon shape '" + s.name +
                                  "': needs at least 3 vertices, got " + std::to_string(n));
    }
    double twice_area = 0.0;
    for (int i = 0; i < n; ++i) {
      const Vector2d a = vertex(i), b = vertex((i + 1) % n);
      if (a == b) {
        throw std::invalid_argument("polygon shape '" + s.name + "': vertices " +
                                    std::to_string(i) + " and " + std::to_string((i + 1) % n) +
                                    " coincide");
      }
      twice_area += Cross2(a, b);
      radius_ = std::max(radius_, a.norm());
    }
    if (!(twice_area != 0.0)) {
      throw std::invalid_argument("polygon shape '" + s.name + "': zero area");
    }
    sign_ = twice_area > 0.0 ? 1.0 : -1.0;
  }
  int size() const { return static_cast<int>(v_->size()); }
  Vector2d vertex(int i) const { return (*v_)[i].head<2>(); }
  // Outward unit normal of edge i (vertex i → i + 1).
  Vector2d edge_normal(int i) const {
    const Vector2d e = vertex((i + 1) % size()) - vertex(i);
    return sign_ * Vector2d(e.y(), -e.x()) / e.norm();
  }
  double MaxDot(const Vector2d& d) const {
    double m = -kInf;
    for (int i = 0; i < size(); ++i) m = std::max(m, d.dot(vertex(i)));
    return m;
  }
  double radius() const { return radius_; }

 private:
  const std::vector<Vector3d>* v_;
  double sign_ = 1.0;
  double radius_ = 0.0;
};

struct PointQuery2 {
  double dist;  // signed
  Vector2d closest;
  Vector2d normal;
};

// Signed distance from x to polygon P (both in P's frame), closest boundary point, normal.
PointQuery2 PointToPolygon(const Polygon2& P, const Vector2d& x) {
  const int n = P.size();
  int i_max = 0;
  double s_max = -kInf;
  for (int i = 0; i < n; ++i) {
    const double s = P.edge_normal(i).dot(x - P.vertex(i));
    if (s > s_max) {
      s_max = s;
      i_max = i;
    }
  }
  if (s_max <= 0.0) {
    const Vector2d nrm = P.edge_normal(i_max);
    return {s_max, x - s_max * nrm, nrm};
  }
  Vector2d best = x;
  double best_d2 = kInf;
  for (int i = 0; i < n; ++i) {
    const Vector2d a = P.vertex(i), b = P.vertex((i + 1) % n);
    if (P.edge_normal(i).dot(x - a) <= 0.0) continue;
    const Vector2d q = a + ClosestParamOnSegment(a, b, x) * (b - a);
    const double d2 = (x - q).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best = q;
    }
  }
  const double dist = std::sqrt(best_d2);
  return {dist, best, (x - best) / dist};
}

// ---------------------------------------------------------------------------------------------
// Half-plane B: {y ≤ 0} in its frame, outward normal +y.

void DiscOnHalfPlane(const Vector2d& c, double r, const Frame2& X_WB, double envelope,
                     Contacts* out) {
  const Vector2d n = X_WB.R.col(1);
  const double h = n.dot(c - X_WB.p);
  const double gap = h - r;
  if (gap > envelope) return;
  Push(c - r * n, c - h * n, n, gap, out);
}

void DiscHalfPlane(const Shape& a, const Frame2& X_WA, const Frame2& X_WB, double envelope,
                   Contacts* out) {
  DiscOnHalfPlane(X_WA.p, a.radius, X_WB, envelope, out);
}

void SegmentHalfPlane(const Shape& a, const Frame2& X_WA, const Frame2& X_WB, double envelope,
                      Contacts* out) {
  const auto [a0, a1] = SegmentEnds(a, X_WA);
  DiscOnHalfPlane(a0, a.radius, X_WB, envelope, out);
  if (a.half_length > 0.0) DiscOnHalfPlane(a1, a.radius, X_WB, envelope, out);
}

void PolygonHalfPlane(const Shape& a, const Frame2& X_WA, const Frame2& X_WB, double envelope,
                      Contacts* out) {
  const Polygon2 A(a);
  for (int i = 0; i < A.size(); ++i) DiscOnHalfPlane(X_WA * A.vertex(i), 0.0, X_WB, envelope, out);
}

// ---------------------------------------------------------------------------------------------
// Disc A.

void DiscDisc(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
              double envelope, Contacts* out) {
  AddDiscPair(X_WA.p, a.radius, X_WB.p, b.radius, Vector2d::UnitY(),
              kRelTol * (a.radius + b.radius), envelope, out);
}

void DiscSegment(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                 double envelope, Contacts* out) {
  const auto [b0, b1] = SegmentEnds(b, X_WB);
  const double t = ClosestParamOnSegment(b0, b1, X_WA.p);
  AddDiscPair(X_WA.p, a.radius, b0 + t * (b1 - b0), b.radius, Vector2d(X_WB.R.col(1)),
              kRelTol * (a.radius + b.radius + b.half_length), envelope, out);
}

void DiscPolygon(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                 double envelope, Contacts* out) {
  const Polygon2 B(b);
  const PointQuery2 q = PointToPolygon(B, X_WB.R.transpose() * (X_WA.p - X_WB.p));
  const double gap = q.dist - a.radius;
  if (gap > envelope) return;
  const Vector2d n = X_WB.R * q.normal;
  Push(X_WA.p - a.radius * n, X_WB * q.closest, n, gap, out);
}

// ---------------------------------------------------------------------------------------------
// Segment A.

bool Interior(double t) { return t > kParamEps && t < 1.0 - kParamEps; }

// Rounded segments whose axes cross (penetration ≥ rA + rB): push apart along the normal of
// one axis by the smaller distance of an end of the other axis to it.
// `x` is the crossing point, used with `fallback_n` if no end projects onto the other axis.
void CrossingSegments(const Vector2d& a0, const Vector2d& a1, double ra, const Vector2d& b0,
                      const Vector2d& b1, double rb, const Vector2d& x, const Vector2d& fallback_n,
                      double envelope, Contacts* out) {
  double best_depth = kInf;
  Vector2d n = fallback_n, ca = x, cb = x;
  auto try_end = [&](const Vector2d& e, const Vector2d& o0, const Vector2d& o1, bool end_of_a) {
    const Vector2d u = (o1 - o0).normalized();
    const double along = u.dot(e - o0);
    if (along < 0.0 || along > (o1 - o0).norm()) return;
    const Vector2d no = Perp(u);
    const double delta = no.dot(e - o0);
    if (std::abs(delta) >= best_depth) return;
    best_depth = std::abs(delta);
    const double side = delta >= 0.0 ? 1.0 : -1.0;
    const Vector2d foot = e - delta * no;
    // The other shape (mostly on the far side of the line) moves towards −side.
    n = end_of_a ? Vector2d(-side * no) : Vector2d(side * no);
    ca = end_of_a ? e : foot;
    cb = end_of_a ? foot : e;
  };
  try_end(a0, b0, b1, true);
  try_end(a1, b0, b1, true);
  try_end(b0, a0, a1, false);
  try_end(b1, a0, a1, false);
  const Vector2d p_A = ca - ra * n;
  const Vector2d p_B = cb + rb * n;
  const double gap = n.dot(p_A - p_B);
  if (gap <= envelope) Push(p_A, p_B, n, gap, out);
}

void SegmentSegment(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                    double envelope, Contacts* out) {
  const auto [a0, a1] = SegmentEnds(a, X_WA);
  const auto [b0, b1] = SegmentEnds(b, X_WB);
  const Vector2d da = a1 - a0;
  const Vector2d db = b1 - b0;
  const double la = da.norm();
  const double lb = db.norm();
  const double tiny = kRelTol * (la + lb + a.radius + b.radius);
  const Vector2d ua = X_WA.R.col(0);
  const Vector2d ub = X_WB.R.col(0);
  // Normal used when the axes touch: perpendicular to B's axis (or A's), from B towards A.
  Vector2d fallback = lb > 0.0 ? Perp(ub) : Perp(ua);
  if (fallback.dot(X_WA.p - X_WB.p) < 0.0) fallback = -fallback;

  if (la > 0.0 && lb > 0.0 && std::abs(Cross2(ua, ub)) < kAxisParallelSin) {
    // Nearly parallel: one contact at each end of the overlap of B's projection onto A.
    const double t0 = ua.dot(b0 - a0);
    const double t1 = ua.dot(b1 - a0);
    const double lo = std::max(0.0, std::min(t0, t1));
    const double hi = std::min(la, std::max(t0, t1));
    if (hi - lo > tiny) {
      for (const double t : {lo, hi}) {
        const Vector2d pa = a0 + t * ua;
        const Vector2d pb = b0 + ClosestParamOnSegment(b0, b1, pa) * db;
        AddDiscPair(pa, a.radius, pb, b.radius, fallback, tiny, envelope, out);
      }
      return;
    }
  }
  double s, t;
  ClosestSegmentSegment(a0, a1, b0, b1, &s, &t);
  const Vector2d pa = a0 + s * da;
  const Vector2d pb = b0 + t * db;
  if ((pa - pb).norm() <= tiny && la > 0.0 && lb > 0.0) {
    CrossingSegments(a0, a1, a.radius, b0, b1, b.radius, pa, fallback, envelope, out);
    return;
  }
  AddDiscPair(pa, a.radius, pb, b.radius, fallback, tiny, envelope, out);
}

// Rounded segment A against polygon B: each end disc (exact signed distance), each vertex of B
// whose closest point on the axis is interior and which supports B towards that point (within
// the envelope), and, if the axis crosses B with both ends outside, the middle of the part
// inside, pushed out through its nearest edge.
void SegmentPolygon(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                    double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  const Polygon2 B(b);
  const Frame2 X_BA = Relative(X_WB, X_WA);
  const auto [p0, p1] = SegmentEnds(a, X_BA);
  const double r = a.radius;
  const double tiny = kRelTol * (B.radius() + a.half_length + r);
  auto emit = [&](const Vector2d& axis_point, const Vector2d& p_B, const Vector2d& n, double gap) {
    Push(X_WB * (axis_point - r * n), X_WB * p_B, X_WB.R * n, gap, out);
  };
  bool end_inside = false;
  for (const Vector2d& p : {p0, p1}) {
    const PointQuery2 q = PointToPolygon(B, p);
    end_inside = end_inside || q.dist <= 0.0;
    if (q.dist - r <= envelope) emit(p, q.closest, q.normal, q.dist - r);
    if (a.half_length <= 0.0) break;
  }
  if (a.half_length > 0.0) {
    const Vector2d d = p1 - p0;
    for (int i = 0; i < B.size(); ++i) {
      const Vector2d v = B.vertex(i);
      const double t = ClosestParamOnSegment(p0, p1, v);
      if (!Interior(t)) continue;
      const Vector2d w = p0 + t * d - v;
      const double dist = w.norm();
      if (dist - r > envelope || dist <= tiny) continue;
      const Vector2d n = w / dist;
      if (B.MaxDot(n) - n.dot(v) > envelope + tiny) continue;
      emit(p0 + t * d, v, n, dist - r);
    }
    if (!end_inside) {  // Cyrus–Beck clip of the axis against B's edges
      double t_in = 0.0, t_out = 1.0;
      bool hit = true;
      for (int i = 0; i < B.size() && hit; ++i) {
        const Vector2d n = B.edge_normal(i);
        const double num = n.dot(B.vertex(i) - p0);  // inside where t · (n · d) ≤ num
        const double den = n.dot(d);
        if (den == 0.0) {
          hit = num >= 0.0;
        } else if (den < 0.0) {
          t_in = std::max(t_in, num / den);
        } else {
          t_out = std::min(t_out, num / den);
        }
        hit = hit && t_in <= t_out;
      }
      if (hit) {
        const Vector2d m = p0 + 0.5 * (t_in + t_out) * d;
        const PointQuery2 q = PointToPolygon(B, m);
        if (q.dist - r <= envelope) emit(m, q.closest, q.normal, q.dist - r);
      }
    }
  }
  RemoveDuplicateContacts(out, begin, tiny);
}

// ---------------------------------------------------------------------------------------------
// Polygon pairs: the planar analogue of VertexFeatures in collision.cc. For each vertex x of P
// (in Q's frame) that no edge line of Q separates by more than the envelope:
//  * vertex–edge: among the edges whose s_e = n_e · (x − q_e) is within `slop` of the largest,
//    the one with the largest s_e for which x is a lowest point of P along n_e (within the
//    envelope), else the plain largest; contact x and its projection, kept if the projection
//    lies within the edge grown by the envelope at both ends;
//  * vertex–vertex (separated only): a vertex w of Q, if Q is supported at w in direction
//    n = (x − w)/|x − w| and P at x in direction −n (within the envelope); gap |x − w|.
void VertexFeatures2(const Polygon2& P, const Frame2& X_WP, const Polygon2& Q, const Frame2& X_WQ,
                     double envelope, double tie, bool p_is_a, Contacts* out) {
  const Frame2 X_QP = Relative(X_WQ, X_WP);
  const Matrix2d R_PQ = X_QP.R.transpose();
  const int nq = Q.size();
  const double support_tol = envelope + tie;
  auto min_p = [&](const Vector2d& n) { return -P.MaxDot(-(R_PQ * n)) + n.dot(X_QP.p); };
  auto emit = [&](const Vector2d& x, const Vector2d& y, const Vector2d& n, double gap) {
    const Vector2d n_W = X_WQ.R * n;
    if (p_is_a) {
      Push(X_WQ * x, X_WQ * y, n_W, gap, out);
    } else {
      Push(X_WQ * y, X_WQ * x, -n_W, gap, out);
    }
  };
  for (int i = 0; i < P.size(); ++i) {
    const Vector2d x = X_QP * P.vertex(i);
    int e_max = -1;
    double s_max = -kInf;
    for (int e = 0; e < nq; ++e) {
      const double s = Q.edge_normal(e).dot(x - Q.vertex(e));
      if (s > s_max) {
        s_max = s;
        e_max = e;
      }
    }
    if (s_max > envelope) continue;
    int best = -1;
    double best_s = -kInf;
    for (int e = 0; e < nq; ++e) {
      const Vector2d n = Q.edge_normal(e);
      const double s = n.dot(x - Q.vertex(e));
      if (s < s_max - support_tol || s <= best_s) continue;
      if (n.dot(x) - min_p(n) > support_tol) continue;
      best = e;
      best_s = s;
    }
    if (best < 0) {
      best = e_max;
      best_s = s_max;
    }
    const Vector2d n = Q.edge_normal(best);
    const Vector2d y = x - best_s * n;
    const Vector2d q0 = Q.vertex(best);
    const Vector2d edge = Q.vertex((best + 1) % nq) - q0;
    const double len = edge.norm();
    const double along = edge.dot(y - q0) / len;
    if (along >= -envelope && along <= len + envelope) emit(x, y, n, best_s);
    if (s_max <= tie) continue;  // vertex–vertex only for separated vertices
    for (int j = 0; j < nq; ++j) {
      const Vector2d w = Q.vertex(j);
      const double dist = (x - w).norm();
      if (dist > envelope || dist <= tie) continue;
      const Vector2d nw = (x - w) / dist;
      if (Q.MaxDot(nw) - nw.dot(w) > support_tol || nw.dot(x) - min_p(nw) > support_tol) continue;
      emit(x, w, nw, dist);
    }
  }
}

void PolygonPolygon(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                    double envelope, Contacts* out) {
  const std::size_t begin = out->size();
  const Polygon2 A(a), B(b);
  const double tie = kRelTol * (A.radius() + B.radius());
  VertexFeatures2(A, X_WA, B, X_WB, envelope, tie, /*p_is_a=*/true, out);
  VertexFeatures2(B, X_WB, A, X_WA, envelope, tie, /*p_is_a=*/false, out);
  RemoveDuplicateContacts(out, begin, tie);
}

// ---------------------------------------------------------------------------------------------
// Dispatch.

int PlanarRank(ShapeType t) {
  switch (t) {
    case ShapeType::kDisc:
      return 0;
    case ShapeType::kSegment:
      return 1;
    case ShapeType::kPolygon:
      return 2;
    default:
      return 3;  // kHalfPlane
  }
}

void CollidePlanarOrdered(const Shape& a, const Frame2& X_WA, const Shape& b, const Frame2& X_WB,
                          double envelope, Contacts* out) {
  switch (a.type) {
    case ShapeType::kDisc:
      switch (b.type) {
        case ShapeType::kDisc:
          return DiscDisc(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kSegment:
          return DiscSegment(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kPolygon:
          return DiscPolygon(a, X_WA, b, X_WB, envelope, out);
        default:
          return DiscHalfPlane(a, X_WA, X_WB, envelope, out);
      }
    case ShapeType::kSegment:
      switch (b.type) {
        case ShapeType::kSegment:
          return SegmentSegment(a, X_WA, b, X_WB, envelope, out);
        case ShapeType::kPolygon:
          return SegmentPolygon(a, X_WA, b, X_WB, envelope, out);
        default:
          return SegmentHalfPlane(a, X_WA, X_WB, envelope, out);
      }
    case ShapeType::kPolygon:
      if (b.type == ShapeType::kPolygon) return PolygonPolygon(a, X_WA, b, X_WB, envelope, out);
      return PolygonHalfPlane(a, X_WA, X_WB, envelope, out);
    default:
      ThrowPair(a, b, "two half-planes");
  }
}

}  // namespace

void CollidePlanar(const Shape& a, const Isometry3d& X_WA, const Shape& b, const Isometry3d& X_WB,
                   double envelope, std::vector<ContactPoint>* out) {
  if (a.type == ShapeType::kConcavePolygon || b.type == ShapeType::kConcavePolygon) {
    if (a.type == ShapeType::kHalfPlane && b.type == ShapeType::kHalfPlane) ThrowPair(a, b, "");
    CollideConcave(a, X_WA, b, X_WB, envelope, out);
    return;
  }
  if (PlanarRank(a.type) <= PlanarRank(b.type)) {
    CollidePlanarOrdered(a, ToFrame2(X_WA), b, ToFrame2(X_WB), envelope, out);
    return;
  }
  const std::size_t begin = out->size();
  CollidePlanarOrdered(b, ToFrame2(X_WB), a, ToFrame2(X_WA), envelope, out);
  FlipContacts(out, begin);
}

}  // namespace vinci::sim::collision_internal
