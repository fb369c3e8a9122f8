#include "vinci/sim/geometry/contact_rate.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "collision_internal.h"

namespace vinci::sim {
namespace {

bool IsHalf(ShapeType t) { return t == ShapeType::kHalfSpace || t == ShapeType::kHalfPlane; }

// The radius of the ball whose centre is a material point for a contact of this shape against a
// half-space/half-plane (CollideShapes: each vertex, each end sphere/disc, or the sphere/disc);
// < 0: no such form.
double BallRadius(ShapeType t, double radius) {
  switch (t) {
    case ShapeType::kSphere:
    case ShapeType::kDisc:
    case ShapeType::kCapsule:
    case ShapeType::kSegment:
      return radius;
    case ShapeType::kBox:
    case ShapeType::kPolyhedron:
    case ShapeType::kPolygon:
      return 0.0;
    default:
      return -1.0;
  }
}

// Ball (A: witness p_A, radius r) on the half-space B with normal n; gap ψ.
void BallOnHalf(const ContactPoint& c, double r, const BodyRate& ra, const BodyRate& rb,
                ContactPointRate* out) {
  const Vector3d& n = c.n_W;
  const Vector3d x = c.p_A_W + r * n;
  const Vector3d dx = ra.PointVelocity(x);
  const Vector3d dn = rb.w_W.cross(n);
  const double dgap = n.dot(dx - rb.PointVelocity(c.p_B_W));
  // p_B = x − h n with h = ψ + r the centre's height.
  out->n_W = dn;
  out->gap = dgap;
  out->p_A_W = dx - r * dn;
  out->p_B_W = dx - (c.gap + r) * dn - dgap * n;
}

// b's vertex (as witness p_B) on a's face: the flipped ball-on-half form.
void FlippedBallOnHalf(const ContactPoint& c, double r, const BodyRate& ra, const BodyRate& rb,
                       ContactPointRate* out) {
  ContactPoint f = c;
  f.p_A_W = c.p_B_W;
  f.p_B_W = c.p_A_W;
  f.n_W = -c.n_W;
  ContactPointRate d;
  BallOnHalf(f, r, rb, ra, &d);
  out->p_A_W = d.p_B_W;
  out->p_B_W = d.p_A_W;
  out->n_W = -d.n_W;
  out->gap = d.gap;
}

// The face of P (shape frame) whose normal is n_P within tol, or −1.
int FaceWithNormal(const collision_internal::Polytope& P, const Vector3d& n_P, double tol) {
  for (int f = 0; f < P.num_faces(); ++f)
    if ((P.face_normal(f) - n_P).norm() <= tol) return f;
  return -1;
}

bool IsVertex(const collision_internal::Polytope& P, const Vector3d& x_P, double tol) {
  for (int i = 0; i < P.num_vertices(); ++i)
    if ((P.vertex(i) - x_P).norm() <= tol) return true;
  return false;
}

// Distance from y (in face f's plane, shape frame) to the boundary of face f.
double DistanceToFaceBoundary(const collision_internal::Polytope& P, int f, const Vector3d& y) {
  double d = std::numeric_limits<double>::infinity();
  const int m = P.face_size(f);
  for (int k = 0; k < m; ++k) {
    const Vector3d v0 = P.face_vertex(f, k), e = P.face_vertex(f, (k + 1) % m) - v0;
    const double t = std::clamp(e.dot(y - v0) / e.squaredNorm(), 0.0, 1.0);
    d = std::min(d, (v0 + t * e - y).norm());
  }
  return d;
}

// The unit direction of an edge of P (shape frame) that has x_P in its interior, or zero.
Vector3d EdgeThrough(const collision_internal::Polytope& P, const Vector3d& x_P, double tol) {
  Vector3d found = Vector3d::Zero();
  P.ForEachEdge([&](const Vector3d& e0, const Vector3d& e1) {
    const Vector3d e = e1 - e0;
    const double t = e.dot(x_P - e0) / e.squaredNorm();
    if (t <= 0.0 || t >= 1.0 || (e0 + t * e - x_P).norm() > tol) return;
    found = e.normalized();
  });
  return found;
}

}  // namespace

bool IsPolytopeType(ShapeType t) { return t == ShapeType::kBox || t == ShapeType::kPolyhedron; }

PolytopeFeature ClassifyPolytopeContact(const Shape& a, const Isometry3d& X_WA, const Shape& b,
                                        const Isometry3d& X_WB, const ContactPoint& c,
                                        double near) {
  PolytopeFeature out;
  if (c.corner || !IsPolytopeType(a.type) || !IsPolytopeType(b.type)) return out;
  collision_internal::HullScratch sa, sb;
  const collision_internal::Polytope A = collision_internal::MakePolytope(a, &sa);
  const collision_internal::Polytope B = collision_internal::MakePolytope(b, &sb);
  const double tol = 1e-9 * (A.radius() + B.radius());
  const Isometry3d X_AW = X_WA.inverse(Eigen::Isometry), X_BW = X_WB.inverse(Eigen::Isometry);
  // a's vertex on b's face (checked first, as the collision routine keeps it).
  int f = FaceWithNormal(B, X_BW.linear() * c.n_W, 1e-9);
  if (f >= 0 && IsVertex(A, X_AW * c.p_A_W, tol)) {
    out.side = VertexSide::kA;
    out.near_face_boundary = DistanceToFaceBoundary(B, f, X_BW * c.p_B_W) <= near;
    return out;
  }
  f = FaceWithNormal(A, -(X_AW.linear() * c.n_W), 1e-9);
  if (f >= 0 && IsVertex(B, X_BW * c.p_B_W, tol)) {
    out.side = VertexSide::kB;
    out.near_face_boundary = DistanceToFaceBoundary(A, f, X_AW * c.p_A_W) <= near;
    return out;
  }
  const Vector3d e_A = EdgeThrough(A, X_AW * c.p_A_W, tol);
  const Vector3d e_B = EdgeThrough(B, X_BW * c.p_B_W, tol);
  if (e_A.isZero() || e_B.isZero()) return out;
  out.e_A_W = X_WA.linear() * e_A;
  out.e_B_W = X_WB.linear() * e_B;
  const Vector3d axis = out.e_A_W.cross(out.e_B_W);
  // Not parallel, and n is ±their common normal (else another feature pair).
  out.edge_edge =
      axis.norm() > 1e-6 && std::abs(std::abs(axis.normalized().dot(c.n_W)) - 1.0) <= 1e-9;
  return out;
}

bool EdgeEdgeRate(const PolytopeFeature& f, const ContactPoint& c, const BodyRate& ra,
                  const BodyRate& rb, ContactPointRate* out) {
  if (c.corner || !f.edge_edge) return false;
  const Vector3d& eA = f.e_A_W;
  const Vector3d& eB = f.e_B_W;
  const Vector3d& n = c.n_W;
  const Vector3d axis = eA.cross(eB);
  const double sign = axis.dot(n) >= 0.0 ? 1.0 : -1.0;
  const Vector3d daxis = ra.w_W.cross(eA).cross(eB) + eA.cross(rb.w_W.cross(eB));
  const Vector3d dn = sign * (daxis - n * n.dot(daxis)) / axis.norm();
  const Vector3d vA = ra.PointVelocity(c.p_A_W), vB = rb.PointVelocity(c.p_B_W);
  Eigen::Matrix3d M;
  M << eA, -eB, -n;
  const Vector3d st = M.partialPivLu().solve(c.gap * dn - vA + vB);
  out->n_W = dn;
  out->gap = st[2];
  out->p_A_W = vA + st[0] * eA;
  out->p_B_W = vB + st[1] * eB;
  return true;
}

bool VertexFaceRate(VertexSide side, const ContactPoint& c, const BodyRate& ra, const BodyRate& rb,
                    ContactPointRate* out) {
  if (c.corner || side == VertexSide::kNone) return false;
  if (side == VertexSide::kA) {
    BallOnHalf(c, 0.0, ra, rb, out);
  } else {
    FlippedBallOnHalf(c, 0.0, ra, rb, out);
  }
  return true;
}

bool ContactRate(const Shape& a, const Shape& b, const ContactPoint& c, const BodyRate& ra,
                 const BodyRate& rb, ContactPointRate* out) {
  if (c.corner) return false;
  if (IsHalf(b.type) && !IsHalf(a.type)) {
    const double r = BallRadius(a.type, a.radius);
    if (r < 0.0) return false;
    BallOnHalf(c, r, ra, rb, out);
    return true;
  }
  if (IsHalf(a.type) && !IsHalf(b.type)) {
    // CollideShapes(b, a) flipped: witnesses swapped, normal negated.
    const double r = BallRadius(b.type, b.radius);
    if (r < 0.0) return false;
    FlippedBallOnHalf(c, r, ra, rb, out);
    return true;
  }
  const bool balls = (a.type == ShapeType::kSphere && b.type == ShapeType::kSphere) ||
                     (a.type == ShapeType::kDisc && b.type == ShapeType::kDisc);
  if (!balls) return false;
  const Vector3d& n = c.n_W;
  const Vector3d cA = c.p_A_W + a.radius * n, cB = c.p_B_W - b.radius * n;
  const double d = c.gap + a.radius + b.radius;
  if (!(d > 0.0)) return false;  // coincident centres: the fallback normal
  const Vector3d dc = ra.PointVelocity(cA) - rb.PointVelocity(cB);
  out->gap = n.dot(dc);
  out->n_W = (dc - out->gap * n) / d;
  out->p_A_W = ra.PointVelocity(cA) - a.radius * out->n_W;
  out->p_B_W = rb.PointVelocity(cB) + b.radius * out->n_W;
  return true;
}

}  // namespace vinci::sim
