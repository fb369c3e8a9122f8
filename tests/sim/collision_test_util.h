// Shared helpers of the narrow-phase tests (collision_test.cc, collision_planar_test.cc):
// shapes, poses, contact comparisons and the brute-force distance by alternating projections.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/geometry/shape.h"

namespace vinci::sim::collision_test {

inline constexpr double kPi = 3.14159265358979323846;
// Round-off of unit-size geometry pushed through a few rigid transforms.
inline constexpr double kTol = 1e-12;
// Agreement with the iterative brute-force distance (alternating projections, converged to
// ~1e-13 on these shapes; this leaves a wide margin).
inline constexpr double kBruteTol = 1e-7;

// ---------------------------------------------------------------------------------------------
// Shapes and poses.

inline Shape Sphere(double r) {
  Shape s;
  s.type = ShapeType::kSphere;
  s.radius = r;
  return s;
}
inline Shape Box(double hx, double hy, double hz) {
  Shape s;
  s.type = ShapeType::kBox;
  s.half_extents = Vector3d(hx, hy, hz);
  return s;
}
inline Shape Capsule(double r, double half_length) {
  Shape s;
  s.type = ShapeType::kCapsule;
  s.radius = r;
  s.half_length = half_length;
  return s;
}
inline Shape Polyhedron(std::vector<Vector3d> vertices, bool prepare) {
  Shape s;
  s.type = ShapeType::kPolyhedron;
  s.name = "poly";
  s.vertices = std::move(vertices);
  if (prepare) PrepareShape(&s);
  return s;
}
inline Shape HalfSpace() {
  Shape s;
  s.type = ShapeType::kHalfSpace;
  return s;
}
inline Shape Disc(double r) {
  Shape s;
  s.type = ShapeType::kDisc;
  s.radius = r;
  return s;
}
inline Shape Polygon(std::vector<Vector3d> vertices) {
  Shape s;
  s.type = ShapeType::kPolygon;
  s.vertices = std::move(vertices);
  return s;
}
inline Shape Square(double half) {
  return Polygon({{-half, -half, 0}, {half, -half, 0}, {half, half, 0}, {-half, half, 0}});
}
inline Shape Segment(double half_length, double r) {
  Shape s;
  s.type = ShapeType::kSegment;
  s.half_length = half_length;
  s.radius = r;
  return s;
}
inline Shape HalfPlane() {
  Shape s;
  s.type = ShapeType::kHalfPlane;
  return s;
}

inline std::vector<Vector3d> CubeVertices(double h) {
  std::vector<Vector3d> v;
  for (int i = 0; i < 8; ++i) v.emplace_back((i & 1) ? h : -h, (i & 2) ? h : -h, (i & 4) ? h : -h);
  return v;
}
inline std::vector<Vector3d> OctahedronVertices() {
  return {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
}
inline std::vector<Vector3d> CornerTetrahedronVertices() {
  return {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
}

inline Matrix3d Rot(double angle, const Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}
// Rotation taking unit-length direction u to v (u ≠ −v).
inline Matrix3d RotFromTo(const Vector3d& u, const Vector3d& v) {
  const Vector3d axis = u.cross(v);
  if (axis.norm() < 1e-15) return Matrix3d::Identity();
  return Rot(std::atan2(axis.norm(), u.dot(v)), axis);
}
inline Isometry3d Pose(const Vector3d& p, const Matrix3d& R = Matrix3d::Identity()) {
  Isometry3d X = Isometry3d::Identity();
  X.linear() = R;
  X.translation() = p;
  return X;
}
inline Vector3d Xyz(double x, double y, double z) { return Vector3d(x, y, z); }

// ---------------------------------------------------------------------------------------------
// Checks.

inline ::testing::AssertionResult Near(const Vector3d& a, const Vector3d& b, double tol) {
  if ((a - b).norm() <= tol) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "(" << a.transpose() << ") vs (" << b.transpose()
                                       << "), distance " << (a - b).norm() << " > " << tol;
}

inline std::string Describe(const std::vector<ContactPoint>& cs) {
  std::string s;
  for (const ContactPoint& c : cs) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "  p_A (%.6g %.6g %.6g) p_B (%.6g %.6g %.6g) n (%.6g %.6g %.6g) gap %.6g\n",
                  c.p_A_W.x(), c.p_A_W.y(), c.p_A_W.z(), c.p_B_W.x(), c.p_B_W.y(), c.p_B_W.z(),
                  c.n_W.x(), c.n_W.y(), c.n_W.z(), c.gap);
    s += buf;
  }
  return s;
}

// The documented invariants of every reported contact.
inline void ExpectInvariants(const std::vector<ContactPoint>& cs, double envelope, bool planar) {
  for (const ContactPoint& c : cs) {
    EXPECT_NEAR(c.n_W.norm(), 1.0, kTol);
    EXPECT_NEAR(c.gap, c.n_W.dot(c.p_A_W - c.p_B_W), kTol);
    EXPECT_LE(c.gap, envelope);
    EXPECT_TRUE(c.p_A_W.allFinite() && c.p_B_W.allFinite() && std::isfinite(c.gap));
    if (planar) {
      EXPECT_EQ(c.p_A_W.z(), 0.0);
      EXPECT_EQ(c.p_B_W.z(), 0.0);
      EXPECT_EQ(c.n_W.z(), 0.0);
    }
  }
}

inline bool SameContact(const ContactPoint& a, const ContactPoint& b, double tol) {
  return (a.p_A_W - b.p_A_W).norm() <= tol && (a.p_B_W - b.p_B_W).norm() <= tol &&
         (a.n_W - b.n_W).norm() <= tol && std::abs(a.gap - b.gap) <= tol;
}

// True if the two lists hold the same contacts, in any order.
inline ::testing::AssertionResult SameContactSet(const std::vector<ContactPoint>& x,
                                                 const std::vector<ContactPoint>& y, double tol) {
  std::vector<bool> used(y.size(), false);
  bool ok = x.size() == y.size();
  for (const ContactPoint& c : x) {
    bool found = false;
    for (std::size_t j = 0; j < y.size() && !found; ++j) {
      if (!used[j] && SameContact(c, y[j], tol)) found = used[j] = true;
    }
    ok = ok && found;
  }
  if (ok) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "contact sets differ:\n"
                                       << Describe(x) << "vs\n"
                                       << Describe(y);
}

inline ContactPoint Flipped(ContactPoint c) {
  std::swap(c.p_A_W, c.p_B_W);
  c.n_W = -c.n_W;
  return c;
}

// CollideShapes(a, b), checked for the invariants and against CollideShapes(b, a) (same contacts,
// witnesses swapped, normals negated). Also checks that it appends to `out`.
inline std::vector<ContactPoint> Collide(const Shape& a, const Isometry3d& X_WA, const Shape& b,
                                         const Isometry3d& X_WB, double envelope) {
  ContactPoint sentinel;
  sentinel.gap = -123.0;
  std::vector<ContactPoint> ab{sentinel}, ba;
  CollideShapes(a, X_WA, b, X_WB, envelope, &ab);
  EXPECT_EQ(ab.front().gap, -123.0) << "CollideShapes must append";
  ab.erase(ab.begin());
  CollideShapes(b, X_WB, a, X_WA, envelope, &ba);
  const bool planar = IsPlanar(a.type);
  ExpectInvariants(ab, envelope, planar);
  ExpectInvariants(ba, envelope, planar);
  std::vector<ContactPoint> ba_flipped;
  for (const ContactPoint& c : ba) ba_flipped.push_back(Flipped(c));
  EXPECT_TRUE(SameContactSet(ab, ba_flipped, kTol)) << "swap symmetry";
  return ab;
}

// Index of the contact whose A witness is at p_A, or -1.
inline int FindByPA(const std::vector<ContactPoint>& cs, const Vector3d& p_A, double tol) {
  for (std::size_t i = 0; i < cs.size(); ++i) {
    if ((cs[i].p_A_W - p_A).norm() <= tol) return static_cast<int>(i);
  }
  return -1;
}

inline void ExpectContact(const ContactPoint& c, const Vector3d& p_A, const Vector3d& p_B,
                          const Vector3d& n, double gap, double tol = kTol) {
  EXPECT_TRUE(Near(c.p_A_W, p_A, tol)) << "p_A";
  EXPECT_TRUE(Near(c.p_B_W, p_B, tol)) << "p_B";
  EXPECT_TRUE(Near(c.n_W, n, tol)) << "n";
  EXPECT_NEAR(c.gap, gap, tol);
}

// ---------------------------------------------------------------------------------------------
// Brute-force distance: alternating projections between two convex sets converge to a closest
// pair (independent of the contact code's case analysis).

using Projector = std::function<Vector3d(const Vector3d&)>;

inline double BruteForceDistance(const Projector& PA, const Projector& PB, const Vector3d& start) {
  Vector3d b = PB(start), a = PA(b);
  for (int k = 0; k < 20000; ++k) {
    const Vector3d b_next = PB(a);
    const Vector3d a_next = PA(b_next);
    const bool done = (a_next - a).norm() < 1e-14 && (b_next - b).norm() < 1e-14;
    a = a_next;
    b = b_next;
    if (done) break;
  }
  return (a - b).norm();
}

// The contacts cs of a pose whose brute-force distance is d, against d. Touching or penetrating
// poses (d < 1e-4) are not compared. Beyond the envelope, cs is empty if the minimum gap is the
// distance (min_gap_is_distance). Within it (counted in *compared), some gap is within kBruteTol
// of d, and the minimum gap is d if min_gap_is_distance. k: the pose's index, for the messages.
inline void CheckAgainstDistance(const std::vector<ContactPoint>& cs, double d, double envelope,
                                 bool min_gap_is_distance, int k, int* compared) {
  if (d < 1e-4) return;
  if (d > envelope) {
    if (min_gap_is_distance) {
      EXPECT_TRUE(cs.empty()) << "d = " << d << "\n" << Describe(cs);
    }
    return;
  }
  ++*compared;
  ASSERT_FALSE(cs.empty()) << "d = " << d;
  double min_gap = kPi, closest = kPi;
  for (const ContactPoint& c : cs) {
    min_gap = std::min(min_gap, c.gap);
    closest = std::min(closest, std::abs(c.gap - d));
  }
  EXPECT_LE(closest, kBruteTol) << "k = " << k << " d = " << d << "\n" << Describe(cs);
  if (min_gap_is_distance) {
    EXPECT_NEAR(min_gap, d, kBruteTol) << "k = " << k;
  }
}

}  // namespace vinci::sim::collision_test
