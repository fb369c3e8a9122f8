// Unit-density mass properties and world bounding boxes of the shape kinds.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "collision_internal.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::sim {
namespace {

using collision_internal::ShapeTypeName;

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();

[[noreturn]] void ThrowBad(const Shape& s, const std::string& what) {
  throw std::invalid_argument(std::string("ComputeUnitMassProperties: ") + ShapeTypeName(s.type) +
                              " shape '" + s.name + "': " + what);
}

void RequirePositive(const Shape& s, const char* field, double value) {
  if (!(value > 0.0))
    ThrowBad(s, std::string(field) + " = " + FormatNumber(value) + ", expected > 0");
}

void RequireNonNegative(const Shape& s, const char* field, double value) {
  if (!(value >= 0.0)) {
    ThrowBad(s, std::string(field) + " = " + FormatNumber(value) + ", expected >= 0");
  }
}

// Inertia per mass of a thin lamina in the xy-plane from its per-area second moments about
// its centroid: (0,0) = ∫y², (1,1) = ∫x², (0,1) = −∫xy, (2,2) = ∫(x² + y²).
Matrix3d LaminaInertia(double xx, double yy, double xy) {
  Matrix3d I = Matrix3d::Zero();
  I(0, 0) = yy;
  I(1, 1) = xx;
  I(0, 1) = I(1, 0) = -xy;
  I(2, 2) = xx + yy;
  return I;
}

UnitMassProperties Polyhedron(const Shape& s) {
  collision_internal::HullScratch scratch;
  const std::vector<HullFace>* faces = &s.faces;
  const std::vector<int>* hull_vertices = &s.hull_vertices;
  if (s.faces.empty() || s.hull_vertices.empty()) {
    try {
      collision_internal::ComputeConvexHull(s.vertices, &scratch.faces, &scratch.hull_vertices);
    } catch (const std::invalid_argument& e) {
      ThrowBad(s, e.what());
    }
    faces = &scratch.faces;
    hull_vertices = &scratch.hull_vertices;
  }
  // Tetrahedra (c, v0, vk, vk+1) from an interior point c over each face's fan. With q_i the
  // corners relative to c (q_0 = 0): volume det/6, ∫q = V Σq/4, ∫q qᵀ = V/20 (Σ q qᵀ + Σq Σqᵀ).
  Vector3d c = Vector3d::Zero();
  for (int i : *hull_vertices) c += s.vertices[i];
  c /= static_cast<double>(hull_vertices->size());
  double volume = 0.0;
  Vector3d first = Vector3d::Zero();
  Matrix3d second = Matrix3d::Zero();
  for (const HullFace& f : *faces) {
    const Vector3d q0 = s.vertices[f.vertices[0]] - c;
    for (std::size_t k = 1; k + 1 < f.vertices.size(); ++k) {
      const Vector3d q1 = s.vertices[f.vertices[k]] - c;
      const Vector3d q2 = s.vertices[f.vertices[k + 1]] - c;
      const double v = q0.dot(q1.cross(q2)) / 6.0;
      const Vector3d sum = q0 + q1 + q2;
      volume += v;
      first += v * sum / 4.0;
      second +=
          v / 20.0 *
          (q0 * q0.transpose() + q1 * q1.transpose() + q2 * q2.transpose() + sum * sum.transpose());
    }
  }
  if (!(volume > 0.0)) ThrowBad(s, "hull has no volume");
  const Vector3d g = first / volume;  // centroid relative to c
  const Matrix3d cov = second / volume - g * g.transpose();
  UnitMassProperties m;
  m.volume = volume;
  m.centroid_S = c + g;
  m.inertia_per_mass_S = cov.trace() * Matrix3d::Identity() - cov;
  return m;
}

UnitMassProperties Polygon(const Shape& s) {
  const int n = static_cast<int>(s.vertices.size());
  if (n < 3) ThrowBad(s, "needs at least 3 vertices, got " + std::to_string(n));
  // Shoelace sums relative to vertex 0 (better conditioned); signed for either orientation.
  const Vector2d o = s.vertices[0].head<2>();
  double a2 = 0.0, cx = 0.0, cy = 0.0, xx = 0.0, yy = 0.0, xy = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vector2d p = s.vertices[i].head<2>() - o;
    const Vector2d q = s.vertices[(i + 1) % n].head<2>() - o;
    const double w = Cross2(p, q);
    a2 += w;
    cx += (p.x() + q.x()) * w;
    cy += (p.y() + q.y()) * w;
    xx += (p.x() * p.x() + p.x() * q.x() + q.x() * q.x()) * w;
    yy += (p.y() * p.y() + p.y() * q.y() + q.y() * q.y()) * w;
    xy += (p.x() * q.y() + 2.0 * p.x() * p.y() + 2.0 * q.x() * q.y() + q.x() * p.y()) * w;
  }
  const double area = 0.5 * a2;
  if (!(std::abs(area) > 0.0)) ThrowBad(s, "zero area");
  const Vector2d g(cx / (6.0 * area), cy / (6.0 * area));
  UnitMassProperties m;
  m.volume = std::abs(area);
  m.centroid_S = Vector3d(o.x() + g.x(), o.y() + g.y(), 0.0);
  m.inertia_per_mass_S =
      LaminaInertia(xx / (12.0 * area) - g.x() * g.x(), yy / (12.0 * area) - g.y() * g.y(),
                    xy / (24.0 * area) - g.x() * g.y());
  return m;
}

// Per-mass second moment ∫u₁² / ∫1 of the unit superball Σ|u_i|^e ≤ 1 in n = 2 or 3
// dimensions (Dirichlet's integral): Γ(3/e) Γ(1 + n/e) / (Γ(1/e) Γ(1 + (n + 2)/e)).
double SuperballSecondMoment(double e, int n) {
  return std::tgamma(3.0 / e) * std::tgamma(1.0 + n / e) /
         (std::tgamma(1.0 / e) * std::tgamma(1.0 + (n + 2) / e));
}

// Volume of the unit superball in n dimensions: (2 Γ(1 + 1/e))ⁿ / Γ(1 + n/e).
double SuperballVolume(double e, int n) {
  return std::pow(2.0 * std::tgamma(1.0 + 1.0 / e), n) / std::tgamma(1.0 + n / e);
}

void RequireExponent(const Shape& s) {
  if (!(s.exponent >= 2.0) || !std::isfinite(s.exponent))
    ThrowBad(s, "exponent = " + FormatNumber(s.exponent) + ", expected a finite number >= 2");
}

void RequireSemiAxes(const Shape& s, int n) {
  for (int c = 0; c < n; ++c)
    RequirePositive(s,
                    c == 0   ? "half_extents.x"
                    : c == 1 ? "half_extents.y"
                             : "half_extents.z",
                    s.half_extents[c]);
}

// Lens: the intersection of two spheres of radius R centred at z = ±c, c = R − t (t = half
// thickness). Its upper half z ∈ [0, t] has cross-section radius² ρ²(z) = R² − (z + c)², a
// quadratic, so the integrands below (degree ≤ 6) are integrated exactly by 4-point
// Gauss–Legendre.
UnitMassProperties Lens(const Shape& s) {
  RequirePositive(s, "radius", s.radius);
  RequirePositive(s, "half_length", s.half_length);
  if (s.half_length > s.radius)
    ThrowBad(s, "half_length = " + FormatNumber(s.half_length) +
                    ", expected <= radius = " + FormatNumber(s.radius));
  const double R = s.radius, t = s.half_length, c = R - t;
  constexpr double kNodes[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                0.8611363115940526};
  constexpr double kWeights[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                  0.3478548451374538};
  double vol = 0.0, zz = 0.0, rr = 0.0;  // ∫1, ∫z², ∫(x² + y²) over the upper half
  for (int k = 0; k < 4; ++k) {
    const double z = 0.5 * t * (kNodes[k] + 1.0), w = 0.5 * t * kWeights[k];
    const double rho2 = R * R - (z + c) * (z + c);
    vol += w * kPi * rho2;
    zz += w * kPi * rho2 * z * z;
    rr += w * kPi * rho2 * rho2 / 2.0;
  }
  UnitMassProperties m;
  m.volume = 2.0 * vol;
  const double i_axial = rr / vol, i_trans = 0.5 * rr / vol + zz / vol;
  m.inertia_per_mass_S = Vector3d(i_trans, i_trans, i_axial).asDiagonal();
  return m;
}

}  // namespace

UnitMassProperties ComputeUnitMassProperties(const Shape& s) {
  UnitMassProperties m;
  switch (s.type) {
    case ShapeType::kHalfSpace:
    case ShapeType::kHalfPlane:
      throw std::invalid_argument(std::string("ComputeUnitMassProperties: ") +
                                  ShapeTypeName(s.type) + " shape '" + s.name +
                                  "' has infinite extent (no mass properties)");
    case ShapeType::kSphere: {
      RequirePositive(s, "radius", s.radius);
      const double r2 = s.radius * s.radius;
      m.volume = 4.0 / 3.0 * kPi * r2 * s.radius;
      m.inertia_per_mass_S = 0.4 * r2 * Matrix3d::Identity();
      return m;
    }
    case ShapeType::kBox: {
      const Vector3d& h = s.half_extents;
      RequirePositive(s, "half_extents.x", h.x());
      RequirePositive(s, "half_extents.y", h.y());
      RequirePositive(s, "half_extents.z", h.z());
      const Vector3d h2 = h.cwiseProduct(h);
      m.volume = 8.0 * h.prod();
      m.inertia_per_mass_S =
          Vector3d(h2.y() + h2.z(), h2.x() + h2.z(), h2.x() + h2.y()).asDiagonal() * (1.0 / 3.0);
      return m;
    }
    case ShapeType::kCapsule: {
      RequirePositive(s, "radius", s.radius);
      RequireNonNegative(s, "half_length", s.half_length);
      const double r = s.radius, r2 = r * r, len = 2.0 * s.half_length;
      const double m_cyl = kPi * r2 * len;
      const double m_hemi = 2.0 / 3.0 * kPi * r2 * r;  // each
      m.volume = m_cyl + 2.0 * m_hemi;
      // Hemisphere: centroid 3r/8 from its flat face, inertia about the face centre 2/5 m r²
      // (any axis through it); parallel-axis shift to the capsule centre at len/2 + 3r/8.
      const double i_axial = m_cyl * r2 / 2.0 + 2.0 * (0.4 * m_hemi * r2);
      const double i_trans = m_cyl * (3.0 * r2 + len * len) / 12.0 +
                             2.0 * m_hemi * (0.4 * r2 + len * len / 4.0 + 3.0 * len * r / 8.0);
      m.inertia_per_mass_S = Vector3d(i_trans, i_trans, i_axial).asDiagonal() * (1.0 / m.volume);
      return m;
    }
    case ShapeType::kPolyhedron:
      return Polyhedron(s);
    case ShapeType::kDisc: {
      RequirePositive(s, "radius", s.radius);
      const double r2 = s.radius * s.radius;
      m.volume = kPi * r2;
      m.inertia_per_mass_S = LaminaInertia(r2 / 4.0, r2 / 4.0, 0.0);
      return m;
    }
    case ShapeType::kPolygon:
      return Polygon(s);
    case ShapeType::kConcavePolygon:  // the shoelace sums are exact for any simple polygon
      if (!s.polygon_checked) collision_internal::CheckSimplePolygon(s);
      return Polygon(s);
    case ShapeType::kSegment: {
      RequireNonNegative(s, "radius", s.radius);
      RequireNonNegative(s, "half_length", s.half_length);
      const double r = s.radius, r2 = r * r, hl = s.half_length, hl2 = hl * hl;
      if (r == 0.0) {  // thin rod of length 2 hl: "volume" is its length (line density)
        RequirePositive(s, "half_length (of a radius-0 segment)", hl);
        m.volume = 2.0 * hl;
        m.inertia_per_mass_S = LaminaInertia(hl2 / 3.0, 0.0, 0.0);
        return m;
      }
      // Stadium: rectangle 2hl × 2r plus two half discs (flat side at x = ±hl, centroid
      // 4r/(3π) beyond it).
      const double a_rect = 4.0 * hl * r;
      m.volume = a_rect + kPi * r2;
      const double xx =
          a_rect * hl2 / 3.0 + kPi * r2 * hl2 + 8.0 / 3.0 * hl * r2 * r + kPi * r2 * r2 / 4.0;
      const double yy = a_rect * r2 / 3.0 + kPi * r2 * r2 / 4.0;
      m.inertia_per_mass_S = LaminaInertia(xx / m.volume, yy / m.volume, 0.0);
      return m;
    }
    case ShapeType::kEllipsoid:
    case ShapeType::kSuperquadric: {
      RequireSemiAxes(s, 3);
      const double e = s.type == ShapeType::kEllipsoid ? 2.0 : s.exponent;
      if (s.type == ShapeType::kSuperquadric) RequireExponent(s);
      const Vector3d& a = s.half_extents;
      m.volume = a.prod() * SuperballVolume(e, 3);
      const Vector3d second = SuperballSecondMoment(e, 3) * a.cwiseProduct(a);  // ∫x_i²/V
      m.inertia_per_mass_S =
          Vector3d(second.y() + second.z(), second.x() + second.z(), second.x() + second.y())
              .asDiagonal();
      return m;
    }
    case ShapeType::kCylinder: {
      RequirePositive(s, "radius", s.radius);
      RequirePositive(s, "half_length", s.half_length);
      const double r2 = s.radius * s.radius, len = 2.0 * s.half_length;
      m.volume = kPi * r2 * len;
      const double i_trans = (3.0 * r2 + len * len) / 12.0;
      m.inertia_per_mass_S = Vector3d(i_trans, i_trans, r2 / 2.0).asDiagonal();
      return m;
    }
    case ShapeType::kLens:
      return Lens(s);
    case ShapeType::kEllipse:
    case ShapeType::kSuperellipse: {
      RequireSemiAxes(s, 2);
      const double e = s.type == ShapeType::kEllipse ? 2.0 : s.exponent;
      if (s.type == ShapeType::kSuperellipse) RequireExponent(s);
      const double a = s.half_extents.x(), b = s.half_extents.y();
      m.volume = a * b * SuperballVolume(e, 2);
      const double k = SuperballSecondMoment(e, 2);
      m.inertia_per_mass_S = LaminaInertia(k * a * a, k * b * b, 0.0);
      return m;
    }
  }
  throw std::logic_error("ComputeUnitMassProperties: unknown ShapeType");
}

namespace {

// Bounds of the half-space {n · (x − p) ≤ 0}: infinite, except that a normal along a coordinate
// axis bounds that coordinate on one side. Only the first `dims` coordinates are set.
void HalfSpaceBounds(const Vector3d& n, const Vector3d& p, int dims, Aabb* box) {
  for (int k = 0; k < dims; ++k) {
    box->lo[k] = -kInf;
    box->hi[k] = kInf;
    bool aligned = true;
    for (int j = 0; j < dims; ++j) aligned = aligned && (j == k || n[j] == 0.0);
    if (!aligned) continue;
    if (n[k] > 0.0) box->hi[k] = p[k];
    if (n[k] < 0.0) box->lo[k] = p[k];
  }
}

// Support function h(d) = max_{x ∈ S} d·x of the origin-symmetric smooth kinds, d in the
// shape frame (planar kinds: d.z ignored).
double SmoothSupport(const Shape& s, const Vector3d& d) {
  switch (s.type) {
    case ShapeType::kEllipsoid:
      return d.cwiseProduct(s.half_extents).norm();
    case ShapeType::kEllipse:
      return d.head<2>().cwiseProduct(s.half_extents.head<2>()).norm();
    case ShapeType::kSuperquadric:
    case ShapeType::kSuperellipse: {
      // The dual norm: h(d) = ‖(a_i d_i)‖_q with 1/e + 1/q = 1.
      const int n = s.type == ShapeType::kSuperquadric ? 3 : 2;
      const double q = s.exponent / (s.exponent - 1.0);
      double sum = 0.0, big = 0.0;
      for (int i = 0; i < n; ++i) big = std::max(big, std::abs(s.half_extents[i] * d[i]));
      if (big == 0.0) return 0.0;
      for (int i = 0; i < n; ++i) sum += std::pow(std::abs(s.half_extents[i] * d[i]) / big, q);
      return big * std::pow(sum, 1.0 / q);
    }
    case ShapeType::kCylinder: {
      const double dz = std::abs(d.z());
      return s.radius * d.head<2>().norm() + s.half_length * dz;
    }
    case ShapeType::kLens: {
      // Caps: spheres centred at ∓c e_z (c = R − t); rim: the circle of radius ρ at z = 0.
      const double R = s.radius, c = R - s.half_length;
      const double rho = std::sqrt(std::max(0.0, R * R - c * c));
      const double dn = d.norm(), dz = std::abs(d.z()), dxy = d.head<2>().norm();
      if (dn == 0.0) return 0.0;
      // The cap point −c e_z + R d/|d| is on the lens iff its radial distance ≤ ρ.
      if (R * dxy <= rho * dn) return R * dn - c * dz;
      return rho * dxy;
    }
    default:
      throw std::logic_error("SmoothSupport: not a smooth kind");
  }
}

}  // namespace

Aabb ComputeAabb(const Shape& s, const Isometry3d& X_WS) {
  Aabb box;
  const Vector3d p = X_WS.translation();
  const Matrix3d& R = X_WS.linear();
  const bool planar = IsPlanar(s.type);
  switch (s.type) {
    case ShapeType::kHalfSpace:
      HalfSpaceBounds(R.col(2), p, 3, &box);
      return box;
    case ShapeType::kHalfPlane:
      HalfSpaceBounds(Vector3d(R(0, 1), R(1, 1), 0.0), p, 2, &box);
      box.lo.z() = box.hi.z() = 0.0;
      return box;
    case ShapeType::kSphere:
    case ShapeType::kDisc:
      box.lo = p.array() - s.radius;
      box.hi = p.array() + s.radius;
      break;
    case ShapeType::kBox: {
      const Vector3d e = R.cwiseAbs() * s.half_extents;
      box.lo = p - e;
      box.hi = p + e;
      break;
    }
    case ShapeType::kCapsule:
    case ShapeType::kSegment: {
      // Capsule axis along shape z, segment axis along shape x.
      const Vector3d axis = R.col(planar ? 0 : 2).cwiseAbs() * s.half_length;
      box.lo = p - axis - Vector3d::Constant(s.radius);
      box.hi = p + axis + Vector3d::Constant(s.radius);
      break;
    }
    case ShapeType::kPolyhedron:
    case ShapeType::kPolygon:
    case ShapeType::kConcavePolygon: {
      box.lo = Vector3d::Constant(kInf);
      box.hi = Vector3d::Constant(-kInf);
      for (Vector3d v : s.vertices) {
        if (planar) v.z() = 0.0;
        const Vector3d w = X_WS * v;
        box.lo = box.lo.cwiseMin(w);
        box.hi = box.hi.cwiseMax(w);
      }
      break;
    }
    case ShapeType::kEllipsoid:
    case ShapeType::kSuperquadric:
    case ShapeType::kCylinder:
    case ShapeType::kLens:
    case ShapeType::kEllipse:
    case ShapeType::kSuperellipse: {
      // Symmetric about the shape origin: extent along world axis i is h(R_WSᵀ e_i).
      for (int i = 0; i < 3; ++i) {
        const double e = SmoothSupport(s, R.row(i).transpose());
        box.lo[i] = p[i] - e;
        box.hi[i] = p[i] + e;
      }
      break;
    }
  }
  if (planar) box.lo.z() = box.hi.z() = 0.0;
  return box;
}

}  // namespace vinci::sim
