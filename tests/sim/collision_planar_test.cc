// Narrow-phase contact detection of the planar kinds (sim/src/geometry/collision_planar.cc):
// discs, segments, polygons and the half-plane.
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

#include "collision_test_util.h"
#include "vinci/sim/geometry/shape.h"

namespace vinci::sim {
namespace {

using namespace collision_test;

// ---------------------------------------------------------------------------------------------
// Planar.

TEST(CollisionPlanarTest, DiscOnHalfPlane) {
  const Isometry3d X_WH = PlanarPose(0.5, -0.2, 0.3);
  const Vector3d n = X_WH.linear().col(1);
  const Vector3d foot = X_WH * Xyz(0.7, 0, 0);
  const Vector3d c = foot + 0.23 * n;
  const auto cs = Collide(Disc(0.2), PlanarPose(c.x(), c.y(), 1.0), HalfPlane(), X_WH, 0.05);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], c - 0.2 * n, foot, n, 0.03);
}

TEST(CollisionPlanarTest, PolygonOnHalfPlaneGivesTheTwoVerticesOfTheRestingEdge) {
  const Isometry3d X_WH = PlanarPose(0.5, -0.2, -0.4);
  const Vector3d n = X_WH.linear().col(1);
  const Shape square = Square(0.5);
  const Shape triangle = Polygon({{-0.6, -0.2, 0}, {0.4, -0.2, 0}, {0.1, 0.7, 0}});
  for (const double gap : {0.0, 0.004, -0.002}) {
    // Square on its bottom edge, and turned a quarter turn (on another edge).
    for (const double quarter : {0.0, 1.0, 3.0}) {
      const Isometry3d X_WA = X_WH * PlanarPose(0.3, 0.5 + gap, quarter * kPi / 2);
      const auto cs = Collide(square, X_WA, HalfPlane(), X_WH, 0.01);
      ASSERT_EQ(cs.size(), 2u) << Describe(cs);
      for (const double x : {-0.5, 0.5}) {
        const Vector3d p = X_WH * Xyz(0.3 + x, gap, 0);
        const int i = FindByPA(cs, p, kTol);
        ASSERT_GE(i, 0) << Describe(cs);
        ExpectContact(cs[i], p, p - gap * n, n, gap);
      }
    }
    // Triangle on its bottom edge (y = −0.2 in its frame); clockwise vertex order too.
    for (const bool clockwise : {false, true}) {
      Shape t = triangle;
      if (clockwise) std::reverse(t.vertices.begin(), t.vertices.end());
      const Isometry3d X_WA = X_WH * PlanarPose(-1, 0.2 + gap, 0);
      const auto cs = Collide(t, X_WA, HalfPlane(), X_WH, 0.01);
      ASSERT_EQ(cs.size(), 2u) << Describe(cs);
      for (const double x : {-0.6, 0.4}) {
        const int i = FindByPA(cs, X_WH * Xyz(-1 + x, gap, 0), kTol);
        ASSERT_GE(i, 0) << Describe(cs);
        EXPECT_NEAR(cs[i].gap, gap, kTol);
      }
    }
  }
}

TEST(CollisionPlanarTest, SegmentOnHalfPlane) {
  const auto lying = Collide(Segment(0.5, 0.05), PlanarPose(0, 0.06, 0.0), HalfPlane(),
                             Isometry3d::Identity(), 0.02);
  ASSERT_EQ(lying.size(), 2u);
  for (const ContactPoint& c : lying) EXPECT_NEAR(c.gap, 0.01, kTol);
  const auto standing = Collide(Segment(0.5, 0.0), PlanarPose(0, 0.499, kPi / 2), HalfPlane(),
                                Isometry3d::Identity(), 0.02);
  ASSERT_EQ(standing.size(), 1u);
  ExpectContact(standing[0], Xyz(0, -0.001, 0), Xyz(0, 0, 0), Xyz(0, 1, 0), -0.001);
}

TEST(CollisionPlanarTest, DiscDiscAndDiscSegment) {
  auto cs = Collide(Disc(0.5), PlanarPose(0, 0, 0), Disc(0.25), PlanarPose(0.6, 0.8, 2), 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.3, 0.4, 0), Xyz(0.45, 0.6, 0), Xyz(-0.6, -0.8, 0), 0.25);
  // Disc above the middle of a rounded segment, and beyond its end.
  cs = Collide(Disc(0.1), PlanarPose(0.2, 0.3, 0), Segment(0.5, 0.05), PlanarPose(0, 0, 0), 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.2, 0.2, 0), Xyz(0.2, 0.05, 0), Xyz(0, 1, 0), 0.15);
  cs = Collide(Disc(0.1), PlanarPose(0.8, 0.4, 0), Segment(0.5, 0.05), PlanarPose(0, 0, 0), 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.74, 0.32, 0), Xyz(0.53, 0.04, 0), Xyz(0.6, 0.8, 0), 0.35);
}

TEST(CollisionPlanarTest, DiscPolygonRegions) {
  const Shape square = Square(0.5);
  const Isometry3d X_WB = PlanarPose(1, 2, 0.6);
  const Matrix3d& R = X_WB.linear();
  struct Case {
    Vector3d centre_B, closest_B, normal_B;
    double radius, gap;
  };
  const Case cases[] = {
      {Xyz(0.1, 0.8, 0), Xyz(0.1, 0.5, 0), Xyz(0, 1, 0), 0.2, 0.1},         // edge
      {Xyz(0.8, -0.9, 0), Xyz(0.5, -0.5, 0), Xyz(0.6, -0.8, 0), 0.2, 0.3},  // vertex
      {Xyz(-0.3, 0.1, 0), Xyz(-0.5, 0.1, 0), Xyz(-1, 0, 0), 0.1, -0.3},     // inside
  };
  for (const Case& c : cases) {
    const Vector3d centre = X_WB * c.centre_B;
    const auto cs =
        Collide(Disc(c.radius), PlanarPose(centre.x(), centre.y(), 0), square, X_WB, 0.5);
    ASSERT_EQ(cs.size(), 1u);
    const Vector3d n = R * c.normal_B;
    ExpectContact(cs[0], centre - c.radius * n, X_WB * c.closest_B, n, c.gap);
  }
}

TEST(CollisionPlanarTest, StackedPolygons) {
  const Shape square = Square(0.5);
  const Isometry3d X_WB = PlanarPose(1, -1, 0.3);
  const Vector3d n = X_WB.linear().col(1);
  for (const double gap : {0.0, -1e-4, 0.003}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    // Equal squares: two contacts after removing coincident duplicates.
    Isometry3d X_WA = X_WB * PlanarPose(0, 1 + gap, 0);
    auto cs = Collide(square, X_WA, square, X_WB, 0.01);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    for (const double x : {-0.5, 0.5}) {
      const int i = FindByPA(cs, X_WA * Xyz(x, -0.5, 0), kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], X_WA * Xyz(x, -0.5, 0), X_WB * Xyz(x, 0.5, 0), n, gap);
    }
    // Small triangle on the square: its bottom edge's two vertices.
    const Shape tri = Polygon({{-0.2, 0, 0}, {0.2, 0, 0}, {0, 0.3, 0}});
    X_WA = X_WB * PlanarPose(0.1, 0.5 + gap, 0);
    cs = Collide(tri, X_WA, square, X_WB, 0.01);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    for (const double x : {-0.2, 0.2}) {
      const int i = FindByPA(cs, X_WA * Xyz(x, 0, 0), kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      EXPECT_NEAR(cs[i].gap, gap, kTol);
      EXPECT_TRUE(Near(cs[i].n_W, n, kTol));
    }
  }
  // Square standing on a corner (turned 45°) on the square: one contact.
  const auto cs =
      Collide(square, X_WB * PlanarPose(0.1, 0.5 + std::sqrt(0.5), kPi / 4), square, X_WB, 0.01);
  ASSERT_EQ(cs.size(), 1u) << Describe(cs);
  EXPECT_NEAR(cs[0].gap, 0.0, kTol);
  EXPECT_TRUE(Near(cs[0].n_W, n, kTol));
}

TEST(CollisionPlanarTest, VertexNearTheEndOfAnEdge) {
  // A small square rests on the big one with its right bottom corner overhanging the big
  // square's top-right corner by δ. That corner is reported (projection within the edge grown
  // by the envelope) for δ = ε/2 but not for δ = 2ε; the big square's corner under A's bottom
  // edge and A's other bottom corner are always reported.
  const double envelope = 0.01;
  const Shape big = Square(0.5), small = Square(0.2);
  for (const double delta : {0.5 * envelope, 2 * envelope}) {
    SCOPED_TRACE("delta " + std::to_string(delta));
    const Isometry3d X_WA = PlanarPose(0.3 + delta, 0.7, 0);
    const auto cs = Collide(small, X_WA, big, Isometry3d::Identity(), envelope);
    ASSERT_EQ(cs.size(), delta < envelope ? 3u : 2u) << Describe(cs);
    int i = FindByPA(cs, Xyz(0.1 + delta, 0.5, 0), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], Xyz(0.1 + delta, 0.5, 0), Xyz(0.1 + delta, 0.5, 0), Xyz(0, 1, 0), 0.0);
    i = FindByPA(cs, Xyz(0.5, 0.5, 0), kTol);  // big square's corner against A's bottom edge
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], Xyz(0.5, 0.5, 0), Xyz(0.5, 0.5, 0), Xyz(0, 1, 0), 0.0);
    i = FindByPA(cs, Xyz(0.5 + delta, 0.5, 0), kTol);
    if (delta < envelope) {
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], Xyz(0.5 + delta, 0.5, 0), Xyz(0.5 + delta, 0.5, 0), Xyz(0, 1, 0), 0.0);
    } else {
      EXPECT_LT(i, 0) << Describe(cs);
    }
  }
  // Corner to corner across a diagonal gap of 5 mm: the exact corner–corner contact, plus each
  // corner against the other square's nearer edge line (projection 3 mm beyond the edge's
  // end, within the envelope), whose gap 4 mm is the distance to that edge line.
  const Vector3d d = Xyz(0.6, 0.8, 0);
  const auto cs = Collide(small, PlanarPose(0.7 + 0.005 * d.x(), 0.7 + 0.005 * d.y(), 0), big,
                          Isometry3d::Identity(), envelope);
  ASSERT_EQ(cs.size(), 3u) << Describe(cs);
  int corner_corner = 0;
  for (const ContactPoint& c : cs) {
    if (Near(c.n_W, d, kTol)) {
      ++corner_corner;
      ExpectContact(c, Xyz(0.5, 0.5, 0) + 0.005 * d, Xyz(0.5, 0.5, 0), d, 0.005);
    } else {
      EXPECT_TRUE(Near(c.n_W, Xyz(0, 1, 0), kTol));
      EXPECT_NEAR(c.gap, 0.004, kTol);
    }
  }
  EXPECT_EQ(corner_corner, 1);
}

TEST(CollisionPlanarTest, SegmentSegment) {
  // Crossing at right angles, A above B.
  auto cs = Collide(Segment(0.5, 0.05), PlanarPose(0.1, 0.9, 0), Segment(0.6, 0.1),
                    PlanarPose(0.3, 0, kPi / 2), 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.3, 0.85, 0), Xyz(0.3, 0.6 + 0.1, 0), Xyz(0, 1, 0), 0.15);
  // Parallel (A turned half a turn), overlapping on x ∈ [0.2, 0.5]: two contacts.
  cs = Collide(Segment(0.5, 0.05), PlanarPose(0.7, 0.2, kPi), Segment(0.5, 0.1),
               PlanarPose(0, 0, 0), 0.1);
  ASSERT_EQ(cs.size(), 2u) << Describe(cs);
  for (const double x : {0.2, 0.5}) {
    const int i = FindByPA(cs, Xyz(x, 0.15, 0), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], Xyz(x, 0.15, 0), Xyz(x, 0.1, 0), Xyz(0, 1, 0), 0.05);
  }
  // Axes crossing (deep): pushed apart along B's normal by the nearer end of A.
  cs = Collide(Segment(0.5, 0.05), PlanarPose(0, 0.1, kPi / 2), Segment(1.0, 0.1),
               PlanarPose(0, 0, 0), 0.1);
  ASSERT_EQ(cs.size(), 1u) << Describe(cs);
  // A spans y ∈ [−0.4, 0.6] across B (the x-axis): lifting A by 0.4 clears its lower end.
  EXPECT_NEAR(cs[0].gap, -(0.4 + 0.05 + 0.1), kTol);
  EXPECT_TRUE(Near(cs[0].n_W, Xyz(0, 1, 0), kTol));
  EXPECT_TRUE(Near(cs[0].p_A_W, Xyz(0, -0.45, 0), kTol));
  EXPECT_TRUE(Near(cs[0].p_B_W, Xyz(0, 0.1, 0), kTol));
}

TEST(CollisionPlanarTest, SegmentPolygon) {
  const Shape square = Square(0.5);
  // Lying on the top edge, shorter than it: the two ends.
  auto cs =
      Collide(Segment(0.3, 0.05), PlanarPose(0.1, 0.56, 0), square, PlanarPose(0, 0, 0), 0.02);
  ASSERT_EQ(cs.size(), 2u) << Describe(cs);
  for (const double x : {-0.2, 0.4}) {
    const int i = FindByPA(cs, Xyz(x, 0.51, 0), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], Xyz(x, 0.51, 0), Xyz(x, 0.5, 0), Xyz(0, 1, 0), 0.01);
  }
  // Longer than the square: at its two top corners.
  cs = Collide(Segment(1.0, 0.05), PlanarPose(0.1, 0.56, 0), square, PlanarPose(0, 0, 0), 0.02);
  ASSERT_EQ(cs.size(), 2u) << Describe(cs);
  for (const double x : {-0.5, 0.5}) {
    const int i = FindByPA(cs, Xyz(x, 0.51, 0), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], Xyz(x, 0.51, 0), Xyz(x, 0.5, 0), Xyz(0, 1, 0), 0.01);
  }
  // A bare stick balanced on a triangle's apex, tilted: one contact at the apex.
  const Shape tri = Polygon({{-0.5, 0, 0}, {0.5, 0, 0}, {0, 0.6, 0}});
  const double tilt = 0.2;
  const Vector3d nrm = Xyz(-std::sin(tilt), std::cos(tilt), 0);
  const Vector3d centre =
      Xyz(0, 0.6, 0) + 0.01 * nrm + 0.1 * Xyz(std::cos(tilt), std::sin(tilt), 0);
  cs = Collide(Segment(0.8, 0.0), PlanarPose(centre.x(), centre.y(), tilt), tri,
               PlanarPose(0, 0, 0), 0.02);
  ASSERT_EQ(cs.size(), 1u) << Describe(cs);
  ExpectContact(cs[0], Xyz(0, 0.6, 0) + 0.01 * nrm, Xyz(0, 0.6, 0), nrm, 0.01);
}

// ---------------------------------------------------------------------------------------------
// Envelope, errors, symmetry over all kinds.

// The planar kinds, same method (projections in the xy-plane).
Projector ProjectOntoPlanar(const Shape& s, const Isometry3d& X) {
  switch (s.type) {
    case ShapeType::kDisc:
      return [=](const Vector3d& x) -> Vector3d {
        const Vector3d d = x - X.translation();
        return d.norm() <= s.radius ? x : Vector3d(X.translation() + s.radius * d.normalized());
      };
    case ShapeType::kSegment:
      return [=](const Vector3d& x) -> Vector3d {
        const Vector3d a = X * Xyz(-s.half_length, 0, 0), b = X * Xyz(s.half_length, 0, 0);
        const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        const Vector3d q = a + t * (b - a);
        return (x - q).norm() <= s.radius ? x : Vector3d(q + s.radius * (x - q).normalized());
      };
    default:  // counter-clockwise polygon: inside, or the nearest point of its boundary
      return [=](const Vector3d& x) -> Vector3d {
        const int n = static_cast<int>(s.vertices.size());
        bool inside = true;
        Vector3d best = x;
        double best_d = kPi * 1e9;
        for (int i = 0; i < n; ++i) {
          const Vector3d a = X * s.vertices[i], b = X * s.vertices[(i + 1) % n];
          inside = inside && (b - a).cross(x - a).z() >= 0.0;
          const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
          const Vector3d q = a + t * (b - a);
          if ((x - q).norm() < best_d) {
            best_d = (x - q).norm();
            best = q;
          }
        }
        return inside ? x : best;
      };
  }
}

TEST(CollisionPlanarTest, RandomizedGapsMatchBruteForceDistance) {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Shape disc = Disc(0.25), stick = Segment(0.35, 0.08), rod = Segment(0.3, 0.0);
  const Shape tri = Polygon({{-0.3, -0.2, 0}, {0.4, -0.1, 0}, {0, 0.45, 0}});
  const Shape quad = Polygon({{-0.3, -0.2, 0}, {0.3, -0.25, 0}, {0.35, 0.2, 0}, {-0.2, 0.3, 0}});
  struct Pair {
    const char* name;
    const Shape* a;
    const Shape* b;
    bool min_gap_is_distance;
  };
  const Pair pairs[] = {
      {"disc/disc", &disc, &disc, true},        {"disc/segment", &disc, &stick, true},
      {"disc/polygon", &disc, &tri, true},      {"segment/segment", &stick, &rod, true},
      {"segment/polygon", &stick, &quad, true}, {"rod/polygon", &rod, &tri, true},
      {"polygon/polygon", &quad, &tri, false}};
  const double envelope = 0.4;
  for (const Pair& p : pairs) {
    SCOPED_TRACE(p.name);
    int compared = 0;
    for (int k = 0; k < 300; ++k) {
      const Isometry3d X_WA = PlanarPose(1.1 * U(rng), 1.1 * U(rng), kPi * U(rng));
      const Isometry3d X_WB = PlanarPose(0, 0, kPi * U(rng));
      const double d = BruteForceDistance(ProjectOntoPlanar(*p.a, X_WA),
                                          ProjectOntoPlanar(*p.b, X_WB), X_WA.translation());
      const auto cs = Collide(*p.a, X_WA, *p.b, X_WB, envelope);
      CheckAgainstDistance(cs, d, envelope, p.min_gap_is_distance, k, &compared);
      if (::testing::Test::HasFatalFailure()) return;
    }
    EXPECT_GT(compared, 40);
  }
}

}  // namespace
}  // namespace vinci::sim
