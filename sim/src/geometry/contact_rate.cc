#include "vinci/sim/geometry/contact_rate.h"

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

}  // namespace

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
