// Unit-density mass properties and world bounding boxes (sim/src/geometry/mass_properties.cc).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/geometry/shape.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Closed forms evaluated with a few flops: round-off only.
constexpr double kTol = 1e-12;
// Composite Simpson integration with 200k panels of integrands with √ end singularities.
constexpr double kQuadratureTol = 1e-7;

Shape Make(ShapeType type) {
  Shape s;
  s.type = type;
  s.name = "s";
  return s;
}

Matrix3d Rot(double angle, const Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

::testing::AssertionResult MatNear(const Matrix3d& a, const Matrix3d& b, double tol) {
  if ((a - b).cwiseAbs().maxCoeff() <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\n" << a << "\nvs\n" << b;
}

// Composite Simpson rule on [lo, hi].
double Integrate(const std::function<double(double)>& f, double lo, double hi,
                 int panels = 200000) {
  const double h = (hi - lo) / panels;
  double sum = f(lo) + f(hi);
  for (int i = 1; i < panels; ++i) sum += (i % 2 ? 4.0 : 2.0) * f(lo + i * h);
  return sum * h / 3.0;
}

TEST(MassPropertiesTest, Sphere) {
  Shape s = Make(ShapeType::kSphere);
  s.radius = 0.7;
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  EXPECT_NEAR(m.volume, 4.0 / 3.0 * kPi * std::pow(0.7, 3), kTol);
  EXPECT_TRUE(m.centroid_S.isZero());
  EXPECT_TRUE(MatNear(m.inertia_per_mass_S, 0.4 * 0.49 * Matrix3d::Identity(), kTol));
}

TEST(MassPropertiesTest, Box) {
  Shape s = Make(ShapeType::kBox);
  s.half_extents = Vector3d(0.5, 0.2, 0.1);  // edges a = 1, b = 0.4, c = 0.2
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  EXPECT_NEAR(m.volume, 0.08, kTol);
  const double a = 1.0, b = 0.4, c = 0.2;
  const Matrix3d expected =
      Matrix3d(Vector3d(b * b + c * c, a * a + c * c, a * a + b * b).asDiagonal()) / 12.0;
  EXPECT_TRUE(MatNear(m.inertia_per_mass_S, expected, kTol));
}

TEST(MassPropertiesTest, CapsuleMatchesSliceIntegrationAndSphereLimit) {
  Shape s = Make(ShapeType::kCapsule);
  s.radius = 0.3;
  s.half_length = 0.5;
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  // Discs of radius ρ(z) stacked along z: dV = πρ² dz, dI_zz = πρ⁴/2 dz,
  // dI_xx = (πρ⁴/4 + πρ² z²) dz.
  const double r = s.radius, hl = s.half_length;
  auto rho2 = [&](double z) {
    const double e = std::max(0.0, std::abs(z) - hl);
    return std::max(0.0, r * r - e * e);
  };
  const double V = Integrate([&](double z) { return kPi * rho2(z); }, -hl - r, hl + r);
  const double Izz =
      Integrate([&](double z) { return kPi * rho2(z) * rho2(z) / 2; }, -hl - r, hl + r);
  const double Ixx =
      Integrate([&](double z) { return kPi * rho2(z) * rho2(z) / 4 + kPi * rho2(z) * z * z; },
                -hl - r, hl + r);
  EXPECT_NEAR(m.volume, V, kQuadratureTol);
  EXPECT_NEAR(m.volume, kPi * r * r * 2 * hl + 4.0 / 3.0 * kPi * r * r * r, kTol);
  EXPECT_TRUE(MatNear(m.inertia_per_mass_S, Matrix3d(Vector3d(Ixx, Ixx, Izz).asDiagonal()) / V,
                      kQuadratureTol));
  // Zero length: a sphere.
  s.half_length = 0.0;
  EXPECT_TRUE(MatNear(ComputeUnitMassProperties(s).inertia_per_mass_S,
                      0.4 * r * r * Matrix3d::Identity(), kTol));
}

TEST(MassPropertiesTest, CubePolyhedronEqualsBox) {
  const Vector3d offset(1, -2, 3);
  const Matrix3d R = Rot(0.7, Vector3d(1, 2, 3));
  Shape box = Make(ShapeType::kBox);
  box.half_extents = Vector3d(0.5, 0.3, 0.2);
  const UnitMassProperties mb = ComputeUnitMassProperties(box);
  for (const bool prepare : {false, true}) {
    Shape poly = Make(ShapeType::kPolyhedron);
    for (int i = 0; i < 8; ++i) {
      const Vector3d c((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.3 : -0.3, (i & 4) ? 0.2 : -0.2);
      poly.vertices.push_back(offset + R * c);
    }
    poly.vertices.push_back(offset);                              // interior
    poly.vertices.push_back(offset + R * Vector3d(0.5, 0, 0.1));  // inside a face
    if (prepare) PrepareShape(&poly);
    const UnitMassProperties mp = ComputeUnitMassProperties(poly);
    EXPECT_NEAR(mp.volume, mb.volume, kTol);
    EXPECT_TRUE(mp.centroid_S.isApprox(offset, kTol));
    EXPECT_TRUE(MatNear(mp.inertia_per_mass_S, R * mb.inertia_per_mass_S * R.transpose(), kTol));
  }
}

TEST(MassPropertiesTest, CornerTetrahedron) {
  // Vertices 0, e1, e2, e3: V = 1/6, centroid 1/4, second moments about the centroid
  // ∫x² = 1/60 − V/16, ∫xy = 1/120 − V/16, so I/m has diagonal 3/40 and off-diagonal 1/80.
  Shape s = Make(ShapeType::kPolyhedron);
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  EXPECT_NEAR(m.volume, 1.0 / 6.0, kTol);
  EXPECT_TRUE(m.centroid_S.isApprox(Vector3d::Constant(0.25), kTol));
  Matrix3d expected = Matrix3d::Constant(1.0 / 80.0);
  expected.diagonal().setConstant(3.0 / 40.0);
  EXPECT_TRUE(MatNear(m.inertia_per_mass_S, expected, kTol));
}

TEST(MassPropertiesTest, Disc) {
  Shape s = Make(ShapeType::kDisc);
  s.radius = 0.4;
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  EXPECT_NEAR(m.volume, kPi * 0.16, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(2, 2), 0.16 / 2, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(0, 0), 0.16 / 4, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(1, 1), 0.16 / 4, kTol);
}

TEST(MassPropertiesTest, PolygonSquareAndTriangle) {
  // Square of side a, off-centre, either orientation, turned: polar a²/6, planar a²/12.
  const double a = 0.6;
  const Eigen::Rotation2Dd rot(0.4);
  for (const bool clockwise : {false, true}) {
    Shape s = Make(ShapeType::kPolygon);
    for (const Vector2d& c : {Vector2d(-1, -1), Vector2d(1, -1), Vector2d(1, 1), Vector2d(-1, 1)}) {
      const Vector2d p = Vector2d(2, 3) + rot * (0.5 * a * c);
      s.vertices.emplace_back(p.x(), p.y(), 0.0);
    }
    if (clockwise) std::reverse(s.vertices.begin(), s.vertices.end());
    const UnitMassProperties m = ComputeUnitMassProperties(s);
    EXPECT_NEAR(m.volume, a * a, kTol);
    EXPECT_TRUE(m.centroid_S.isApprox(Vector3d(2, 3, 0), kTol));
    EXPECT_NEAR(m.inertia_per_mass_S(2, 2), a * a / 6, kTol);
    EXPECT_NEAR(m.inertia_per_mass_S(0, 0), a * a / 12, kTol);  // a square's are isotropic
    EXPECT_NEAR(m.inertia_per_mass_S(1, 1), a * a / 12, kTol);
    EXPECT_NEAR(m.inertia_per_mass_S(0, 1), 0.0, kTol);
  }
  // Right triangle with legs b (x) and c (y): centroid (b/3, c/3), per-area ∫x² = b²/18,
  // ∫y² = c²/18, ∫xy = −bc/36 about the centroid.
  const double b = 0.9, c = 0.4;
  Shape t = Make(ShapeType::kPolygon);
  t.vertices = {{0, 0, 0}, {b, 0, 0}, {0, c, 0}};
  const UnitMassProperties m = ComputeUnitMassProperties(t);
  EXPECT_NEAR(m.volume, b * c / 2, kTol);
  EXPECT_TRUE(m.centroid_S.isApprox(Vector3d(b / 3, c / 3, 0), kTol));
  EXPECT_NEAR(m.inertia_per_mass_S(0, 0), c * c / 18, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(1, 1), b * b / 18, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(0, 1), b * c / 36, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(2, 2), (b * b + c * c) / 18, kTol);
}

TEST(MassPropertiesTest, SegmentStadiumMatchesSliceIntegrationAndRodLimit) {
  Shape s = Make(ShapeType::kSegment);
  s.half_length = 0.5;
  s.radius = 0.2;
  const UnitMassProperties m = ComputeUnitMassProperties(s);
  // Vertical slices of height h(x): dA = h dx, ∫x² dA = x² h dx, ∫y² dA = h³/12 dx.
  const double hl = s.half_length, r = s.radius;
  auto height = [&](double x) {
    const double e = std::max(0.0, std::abs(x) - hl);
    return 2.0 * std::sqrt(std::max(0.0, r * r - e * e));
  };
  const double A = Integrate(height, -hl - r, hl + r);
  const double Ixx = Integrate([&](double x) { return x * x * height(x); }, -hl - r, hl + r);
  const double Iyy =
      Integrate([&](double x) { return std::pow(height(x), 3) / 12; }, -hl - r, hl + r);
  EXPECT_NEAR(m.volume, A, kQuadratureTol);
  EXPECT_NEAR(m.volume, 4 * hl * r + kPi * r * r, kTol);
  EXPECT_NEAR(m.inertia_per_mass_S(1, 1), Ixx / A, kQuadratureTol);
  EXPECT_NEAR(m.inertia_per_mass_S(0, 0), Iyy / A, kQuadratureTol);
  EXPECT_NEAR(m.inertia_per_mass_S(2, 2), (Ixx + Iyy) / A, kQuadratureTol);
  // Radius 0: a thin rod of length L whose "volume" is L and inertia L²/12.
  s.radius = 0.0;
  const UnitMassProperties rod = ComputeUnitMassProperties(s);
  EXPECT_NEAR(rod.volume, 1.0, kTol);
  EXPECT_NEAR(rod.inertia_per_mass_S(2, 2), 1.0 / 12, kTol);
  EXPECT_NEAR(rod.inertia_per_mass_S(0, 0), 0.0, kTol);
}

TEST(MassPropertiesTest, InvalidShapesThrow) {
  auto expect_throw = [](const Shape& s, const std::string& fragment) {
    try {
      ComputeUnitMassProperties(s);
      ADD_FAILURE() << "no exception, expected one mentioning '" << fragment << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  expect_throw(Make(ShapeType::kHalfSpace), "infinite");
  expect_throw(Make(ShapeType::kHalfPlane), "infinite");
  expect_throw(Make(ShapeType::kSphere), "radius");
  Shape box = Make(ShapeType::kBox);
  box.half_extents = Vector3d(1, 0, 1);
  expect_throw(box, "half_extents.y");
  Shape poly = Make(ShapeType::kPolyhedron);
  poly.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  expect_throw(poly, "coplanar");
  Shape polygon = Make(ShapeType::kPolygon);
  polygon.vertices = {{0, 0, 0}, {1, 0, 0}};
  expect_throw(polygon, "3 vertices");
  Shape segment = Make(ShapeType::kSegment);
  expect_throw(segment, "half_length");
}

// ---------------------------------------------------------------------------------------------
// Bounding boxes: contain sampled surface points and are attained by extreme surface points.

TEST(AabbTest, ContainsSurfaceSamplesAndIsTight) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::normal_distribution<double> N;
  auto unit = [&]() {
    Vector3d d(N(rng), N(rng), N(rng));
    return Vector3d(d.normalized());
  };
  constexpr double kContainTol = 1e-12;  // samples are computed with a few roundings
  for (int trial = 0; trial < 20; ++trial) {
    const Isometry3d X_WS = [&] {
      Isometry3d X = Isometry3d::Identity();
      X.linear() = Rot(3 * U(rng), Vector3d(U(rng), U(rng), U(rng)));
      X.translation() = Vector3d(U(rng), U(rng), U(rng));
      return X;
    }();
    const Isometry3d X_planar = PlanarPose(U(rng), U(rng), 3 * U(rng));
    std::vector<std::pair<Shape, Isometry3d>> cases;
    std::vector<std::vector<Vector3d>> samples;  // world surface points incl. extremes
    {
      Shape s = Make(ShapeType::kSphere);
      s.radius = 0.3;
      std::vector<Vector3d> pts;
      for (int i = 0; i < 200; ++i) pts.push_back(X_WS * (0.3 * unit()));
      for (int k = 0; k < 3; ++k) {
        pts.push_back(X_WS.translation() + 0.3 * Vector3d::Unit(k));
        pts.push_back(X_WS.translation() - 0.3 * Vector3d::Unit(k));
      }
      cases.emplace_back(s, X_WS);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kBox);
      s.half_extents = Vector3d(0.4, 0.2, 0.1);
      std::vector<Vector3d> pts;
      for (int i = 0; i < 8; ++i) {
        pts.push_back(X_WS *
                      Vector3d((i & 1) ? 0.4 : -0.4, (i & 2) ? 0.2 : -0.2, (i & 4) ? 0.1 : -0.1));
      }
      for (int i = 0; i < 200; ++i) {
        Vector3d p(0.4 * U(rng), 0.2 * U(rng), 0.1 * U(rng));
        const int k = i % 3;
        p[k] = (i % 2 ? 1 : -1) * s.half_extents[k];
        pts.push_back(X_WS * p);
      }
      cases.emplace_back(s, X_WS);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kCapsule);
      s.radius = 0.1;
      s.half_length = 0.3;
      std::vector<Vector3d> pts;
      for (int i = 0; i < 300; ++i) {
        const Vector3d axis_pt = X_WS * Vector3d(0, 0, 0.3 * U(rng));
        pts.push_back(axis_pt + 0.1 * unit());  // inside or on the surface
      }
      for (const double e : {-0.3, 0.3}) {
        for (int k = 0; k < 3; ++k) {
          pts.push_back(X_WS * Vector3d(0, 0, e) + 0.1 * Vector3d::Unit(k));
          pts.push_back(X_WS * Vector3d(0, 0, e) - 0.1 * Vector3d::Unit(k));
        }
      }
      cases.emplace_back(s, X_WS);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kPolyhedron);
      s.vertices = {{1, 0, 0}, {-0.5, 0.2, 0}, {0, 1, 0.3}, {0, -0.5, -0.2}, {0.1, 0.1, 0.8}};
      std::vector<Vector3d> pts;
      for (const Vector3d& v : s.vertices) pts.push_back(X_WS * v);
      for (int i = 0; i < 100; ++i) {  // points of segments between vertices
        const double t = 0.5 + 0.5 * U(rng);
        pts.push_back(X_WS * (t * s.vertices[i % 5] + (1 - t) * s.vertices[(i + 2) % 5]));
      }
      cases.emplace_back(s, X_WS);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kDisc);
      s.radius = 0.25;
      std::vector<Vector3d> pts;
      for (int i = 0; i < 200; ++i) {
        const double a = kPi * U(rng);
        pts.push_back(X_planar * Vector3d(0.25 * std::cos(a), 0.25 * std::sin(a), 0));
      }
      for (const double a : {0.0, kPi / 2, kPi, -kPi / 2}) {
        pts.push_back(X_planar.translation() + Vector3d(0.25 * std::cos(a), 0.25 * std::sin(a), 0));
      }
      cases.emplace_back(s, X_planar);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kPolygon);
      s.vertices = {{-0.3, -0.2, 5}, {0.4, -0.1, -5}, {0, 0.5, 0}};  // z is ignored
      std::vector<Vector3d> pts;
      for (int i = 0; i < 3; ++i) {
        const Vector3d a(s.vertices[i].x(), s.vertices[i].y(), 0);
        const Vector3d b(s.vertices[(i + 1) % 3].x(), s.vertices[(i + 1) % 3].y(), 0);
        pts.push_back(X_planar * a);
        for (int k = 0; k < 50; ++k) pts.push_back(X_planar * (a + 0.5 * (1 + U(rng)) * (b - a)));
      }
      cases.emplace_back(s, X_planar);
      samples.push_back(pts);
    }
    {
      Shape s = Make(ShapeType::kSegment);
      s.radius = 0.05;
      s.half_length = 0.4;
      std::vector<Vector3d> pts;
      for (int i = 0; i < 200; ++i) {
        const double a = kPi * U(rng);
        pts.push_back(X_planar * Vector3d(0.4 * U(rng), 0, 0) +
                      Vector3d(0.05 * std::cos(a), 0.05 * std::sin(a), 0));
      }
      for (const double e : {-0.4, 0.4}) {
        for (const Vector3d& d : {Vector3d(0.05, 0, 0), Vector3d(-0.05, 0, 0), Vector3d(0, 0.05, 0),
                                  Vector3d(0, -0.05, 0)}) {
          pts.push_back(X_planar * Vector3d(e, 0, 0) + d);
        }
      }
      cases.emplace_back(s, X_planar);
      samples.push_back(pts);
    }
    for (std::size_t c = 0; c < cases.size(); ++c) {
      SCOPED_TRACE("shape kind " + std::to_string(static_cast<int>(cases[c].first.type)));
      const Aabb box = ComputeAabb(cases[c].first, cases[c].second);
      Vector3d lo = Vector3d::Constant(1e300), hi = Vector3d::Constant(-1e300);
      for (const Vector3d& p : samples[c]) {
        EXPECT_TRUE((p.array() >= box.lo.array() - kContainTol).all() &&
                    (p.array() <= box.hi.array() + kContainTol).all())
            << p.transpose() << " outside [" << box.lo.transpose() << "] [" << box.hi.transpose()
            << "]";
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
      // The extreme samples reach the box (tight), except the capsule whose extremes are on
      // the end spheres along the world axes, which the samples include.
      EXPECT_LE((lo - box.lo).cwiseAbs().maxCoeff(), kContainTol);
      EXPECT_LE((hi - box.hi).cwiseAbs().maxCoeff(), kContainTol);
      if (IsPlanar(cases[c].first.type)) {
        EXPECT_EQ(box.lo.z(), 0.0);
        EXPECT_EQ(box.hi.z(), 0.0);
      }
    }
  }
}

TEST(AabbTest, HalfSpacesAreInfinite) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  Shape h = Make(ShapeType::kHalfSpace);
  // Tilted: unbounded everywhere.
  Isometry3d X = Isometry3d::Identity();
  X.linear() = Rot(0.3, Vector3d(1, 1, 0));
  Aabb box = ComputeAabb(h, X);
  EXPECT_TRUE((box.lo.array() == -kInf).all());
  EXPECT_TRUE((box.hi.array() == kInf).all());
  // Axis-aligned floor at z = 2: bounded above in z only.
  box = ComputeAabb(h, Isometry3d(Eigen::Translation3d(1, 1, 2)));
  EXPECT_TRUE((box.lo.array() == -kInf).all());
  EXPECT_EQ(box.hi.x(), kInf);
  EXPECT_EQ(box.hi.y(), kInf);
  EXPECT_EQ(box.hi.z(), 2.0);
  // Half-plane rotated a quarter turn: normal −x, bounded below in x; z range [0, 0].
  Shape hp = Make(ShapeType::kHalfPlane);
  Isometry3d Xp = Isometry3d::Identity();
  Xp.linear() << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // exact quarter turn about z
  Xp.translation() = Vector3d(3, 4, 0);
  box = ComputeAabb(hp, Xp);
  EXPECT_EQ(box.lo.x(), 3.0);
  EXPECT_EQ(box.hi.x(), kInf);
  EXPECT_EQ(box.lo.y(), -kInf);
  EXPECT_EQ(box.hi.y(), kInf);
  EXPECT_EQ(box.lo.z(), 0.0);
  EXPECT_EQ(box.hi.z(), 0.0);
  // A half-space overlaps any finite box (the broad phase must not prune it).
  Shape sphere = Make(ShapeType::kSphere);
  sphere.radius = 1;
  EXPECT_TRUE(ComputeAabb(h, X).Overlaps(
      ComputeAabb(sphere, Isometry3d(Eigen::Translation3d(100, -50, 30))), 0.0));
}

}  // namespace
}  // namespace vinci::sim
