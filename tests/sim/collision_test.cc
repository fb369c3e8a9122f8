// Narrow-phase contact detection (sim/src/geometry/collision*.cc, convex_hull.cc): 3-D pairs; the
// planar pairs are in collision_planar_test.cc.
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
// Half-space.

TEST(CollisionTest, BoxRestingOnHalfSpaceGivesExactlyItsFourBottomCorners) {
  const Shape box = Box(0.5, 0.3, 0.2);
  const Shape ground = HalfSpace();
  const double envelope = 1e-3;
  for (const Isometry3d& X_WH :
       {Isometry3d(Isometry3d::Identity()), Pose(Xyz(0.5, -1, 2), Rot(0.7, Xyz(1, 2, 3)))}) {
    const Vector3d n = X_WH.linear().col(2);
    for (const double yaw : {0.0, 0.3, 1.0, kPi / 4, 2.5, -kPi / 2}) {
      SCOPED_TRACE("yaw " + std::to_string(yaw));
      const Isometry3d X_WA = X_WH * Pose(Xyz(0.2, -0.7, 0.2), Rot(yaw, Vector3d::UnitZ()));
      const auto cs = Collide(box, X_WA, ground, X_WH, envelope);
      ASSERT_EQ(cs.size(), 4u) << Describe(cs);
      for (int corner = 0; corner < 4; ++corner) {
        const Vector3d p = X_WA * Xyz((corner & 1) ? 0.5 : -0.5, (corner & 2) ? 0.3 : -0.3, -0.2);
        const int i = FindByPA(cs, p, kTol);
        ASSERT_GE(i, 0) << "corner " << corner << "\n" << Describe(cs);
        ExpectContact(cs[i], p, p, n, 0.0);
      }
    }
  }
}

TEST(CollisionTest, TiltedBoxOnHalfSpaceReportsCornersWithinEnvelopeWithExactGaps) {
  const Vector3d h(0.5, 0.3, 0.2);
  const Shape box = Box(h.x(), h.y(), h.z());
  const Matrix3d R = Rot(0.4, Vector3d::UnitX()) * Rot(0.25, Vector3d::UnitY());
  std::vector<Vector3d> corners;  // relative to the centre, world orientation
  for (int i = 0; i < 8; ++i) {
    corners.push_back(
        R * Xyz((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z()));
  }
  double lowest = kPi;
  for (const Vector3d& c : corners) lowest = std::min(lowest, c.z());
  const double clearance = 0.003;
  const Isometry3d X_WA = Pose(Xyz(0.1, 0.2, clearance - lowest), R);
  for (const double envelope : {0.01, 0.2}) {
    SCOPED_TRACE("envelope " + std::to_string(envelope));
    const auto cs = Collide(box, X_WA, HalfSpace(), Isometry3d::Identity(), envelope);
    int expected = 0;
    for (const Vector3d& c : corners) {
      const Vector3d p = X_WA.translation() + c;
      if (p.z() > envelope) continue;
      ++expected;
      const int i = FindByPA(cs, p, kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], p, Xyz(p.x(), p.y(), 0.0), Vector3d::UnitZ(), p.z());
    }
    EXPECT_EQ(static_cast<int>(cs.size()), expected) << Describe(cs);
    if (envelope == 0.01) {
      // This tilt leaves a single corner within 1 cm: the lowest one, 3 mm up.
      ASSERT_EQ(cs.size(), 1u) << Describe(cs);
      EXPECT_NEAR(cs[0].gap, clearance, kTol);
    }
  }
}

TEST(CollisionTest, SphereHalfSpace) {
  const Isometry3d X_WH = Pose(Xyz(0.5, -1, 2), Rot(0.7, Xyz(1, 2, 3)));
  const Vector3d n = X_WH.linear().col(2);
  for (const double height : {0.7, 0.45, 0.5}) {
    const Vector3d foot = X_WH * Xyz(0.3, -0.2, 0.0);
    const Vector3d c = foot + height * n;
    const auto cs = Collide(Sphere(0.5), Pose(c, Rot(1.0, Xyz(0, 1, 1))), HalfSpace(), X_WH, 0.5);
    ASSERT_EQ(cs.size(), 1u);
    ExpectContact(cs[0], c - 0.5 * n, foot, n, height - 0.5);
  }
}

TEST(CollisionTest, CapsuleOnHalfSpace) {
  const Shape capsule = Capsule(0.1, 0.5);
  // Lying flat (axis along a rotated x), 2 cm up: both end spheres.
  const Matrix3d R = Rot(0.6, Vector3d::UnitZ()) * Rot(kPi / 2, Vector3d::UnitY());
  const Isometry3d X_WA = Pose(Xyz(1, 2, 0.12), R);
  auto cs = Collide(capsule, X_WA, HalfSpace(), Isometry3d::Identity(), 0.05);
  ASSERT_EQ(cs.size(), 2u) << Describe(cs);
  for (const double s : {-0.5, 0.5}) {
    const Vector3d end = X_WA * Xyz(0, 0, s);
    const int i = FindByPA(cs, end - Xyz(0, 0, 0.1), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], end - Xyz(0, 0, 0.1), Xyz(end.x(), end.y(), 0), Vector3d::UnitZ(), 0.02);
  }
  // Standing upright, penetrating 1 mm: only the lower end.
  cs = Collide(capsule, Pose(Xyz(0, 0, 0.599)), HalfSpace(), Isometry3d::Identity(), 0.05);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0, 0, -0.001), Xyz(0, 0, 0), Vector3d::UnitZ(), -0.001);
}

TEST(CollisionTest, PolyhedraOnHalfSpace) {
  for (const bool prepare : {true, false}) {
    SCOPED_TRACE(prepare ? "prepared" : "hull on the fly");
    // Corner tetrahedron on its z = 0 face, 1 mm up, plus points the hull must ignore (a face
    // centre, an edge midpoint, an interior point, a duplicate vertex).
    std::vector<Vector3d> tet = CornerTetrahedronVertices();
    tet.push_back(Xyz(1.0 / 3, 1.0 / 3, 0));
    tet.push_back(Xyz(0.5, 0, 0));
    tet.push_back(Xyz(0.1, 0.1, 0.1));
    tet.push_back(Xyz(1, 0, 0));
    const Shape tetra = Polyhedron(tet, prepare);
    const Isometry3d X_WA = Pose(Xyz(0.3, 0.4, 0.001), Rot(0.9, Vector3d::UnitZ()));
    auto cs = Collide(tetra, X_WA, HalfSpace(), Isometry3d::Identity(), 0.01);
    ASSERT_EQ(cs.size(), 3u) << Describe(cs);
    for (const Vector3d& v : {Xyz(0, 0, 0), Xyz(1, 0, 0), Xyz(0, 1, 0)}) {
      const Vector3d p = X_WA * v;
      const int i = FindByPA(cs, p, kTol);
      ASSERT_GE(i, 0);
      ExpectContact(cs[i], p, Xyz(p.x(), p.y(), 0), Vector3d::UnitZ(), 0.001);
    }
    // Octahedron on a vertex, then on a face (3 contacts).
    const Shape octa = Polyhedron(OctahedronVertices(), prepare);
    cs = Collide(octa, Pose(Xyz(0, 0, 0.998)), HalfSpace(), Isometry3d::Identity(), 0.01);
    ASSERT_EQ(cs.size(), 1u);
    ExpectContact(cs[0], Xyz(0, 0, -0.002), Xyz(0, 0, 0), Vector3d::UnitZ(), -0.002);
    const Matrix3d R = RotFromTo(Xyz(-1, -1, -1).normalized(), -Vector3d::UnitZ());
    const Isometry3d X_WO = Pose(Xyz(2, 1, 1 / std::sqrt(3.0)), R);
    cs = Collide(octa, X_WO, HalfSpace(), Isometry3d::Identity(), 0.01);
    ASSERT_EQ(cs.size(), 3u) << Describe(cs);
    for (const Vector3d& v : {Xyz(-1, 0, 0), Xyz(0, -1, 0), Xyz(0, 0, -1)}) {
      const int i = FindByPA(cs, X_WO * v, 1e-12);
      ASSERT_GE(i, 0) << Describe(cs);
      EXPECT_NEAR(cs[i].gap, 0.0, kTol);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Sphere.

TEST(CollisionTest, SphereSphere) {
  const Vector3d u = Xyz(1, 2, -2) / 3.0;  // unit, from A towards B
  const Vector3d cA(0.3, -0.1, 0.2);
  for (const double dist : {1.2, 0.9}) {
    const Vector3d cB = cA + dist * u;
    const auto cs =
        Collide(Sphere(0.5), Pose(cA), Sphere(0.6), Pose(cB, Rot(2, Xyz(1, 1, 0))), 0.2);
    ASSERT_EQ(cs.size(), 1u);
    ExpectContact(cs[0], cA + 0.5 * u, cB - 0.6 * u, -u, dist - 1.1);
  }
  // Concentric: some unit normal, gap −(rA + rB). (No swap-symmetry check: with identical
  // poses nothing distinguishes the order, so the fallback normal cannot flip with it.)
  std::vector<ContactPoint> cs;
  CollideShapes(Sphere(0.5), Pose(cA), Sphere(0.6), Pose(cA), 0.0, &cs);
  ASSERT_EQ(cs.size(), 1u);
  ExpectInvariants(cs, 0.0, false);
  EXPECT_NEAR(cs[0].gap, -1.1, kTol);
  // Beyond the envelope.
  EXPECT_TRUE(Collide(Sphere(0.5), Pose(cA), Sphere(0.6), Pose(cA + 1.4 * u), 0.2).empty());
}

TEST(CollisionTest, SphereBoxFaceEdgeCornerAndInside) {
  const Shape box = Box(1.0, 0.5, 0.25);
  const Isometry3d X_WB = Pose(Xyz(0.4, -0.3, 1.0), Rot(0.8, Xyz(1, -2, 0.5)));
  const Matrix3d& R = X_WB.linear();
  struct Case {
    const char* region;
    Vector3d centre_B;  // sphere centre in the box frame
    double radius;
    Vector3d closest_B;  // closest box point
    Vector3d normal_B;   // from box to sphere
    double gap;
  };
  const Case cases[] = {
      {"face", Xyz(0.3, 0.1, 0.65), 0.3, Xyz(0.3, 0.1, 0.25), Xyz(0, 0, 1), 0.1},
      {"edge", Xyz(1.3, 0.1, 0.65), 0.3, Xyz(1.0, 0.1, 0.25), Xyz(0.6, 0, 0.8), 0.2},
      {"corner", Xyz(1.2, 0.8, 0.85), 0.3, Xyz(1.0, 0.5, 0.25), Xyz(0.2, 0.3, 0.6) / 0.7, 0.4},
      {"inside", Xyz(0.2, 0.1, 0.15), 0.3, Xyz(0.2, 0.1, 0.25), Xyz(0, 0, 1), -0.4},
      {"inside, -y face", Xyz(-0.5, -0.45, 0.0), 0.05, Xyz(-0.5, -0.5, 0.0), Xyz(0, -1, 0), -0.1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.region);
    const Vector3d centre = X_WB * c.centre_B;
    const Vector3d n = R * c.normal_B;
    const auto cs = Collide(Sphere(c.radius), Pose(centre), box, X_WB, 1.0);
    ASSERT_EQ(cs.size(), 1u);
    ExpectContact(cs[0], centre - c.radius * n, X_WB * c.closest_B, n, c.gap);
  }
}

TEST(CollisionTest, SphereCapsule) {
  const Isometry3d X_WB = Pose(Xyz(0, 0, 0), Rot(kPi / 2, Vector3d::UnitY()));  // axis along x
  const Shape capsule = Capsule(0.2, 0.5);
  // Beside the middle of the axis.
  auto cs = Collide(Sphere(0.1), Pose(Xyz(0.3, 0.4, 0)), capsule, X_WB, 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.3, 0.3, 0), Xyz(0.3, 0.2, 0), Xyz(0, 1, 0), 0.1);
  // Beyond an end.
  cs = Collide(Sphere(0.1), Pose(Xyz(0.9, 0, 0)), capsule, X_WB, 0.5);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.8, 0, 0), Xyz(0.7, 0, 0), Xyz(1, 0, 0), 0.1);
  // Centre on the axis: normal perpendicular to the axis.
  cs = Collide(Sphere(0.1), Pose(Xyz(0.2, 0, 0)), capsule, X_WB, 0.5);
  ASSERT_EQ(cs.size(), 1u);
  EXPECT_NEAR(cs[0].gap, -0.3, kTol);
  EXPECT_NEAR(cs[0].n_W.x(), 0.0, kTol);
}

TEST(CollisionTest, SpherePolyhedronRegions) {
  for (const bool prepare : {true, false}) {
    const Shape octa = Polyhedron(OctahedronVertices(), prepare);
    const Isometry3d X_WB = Pose(Xyz(1, 2, 3), Rot(0.5, Xyz(3, 1, 2)));
    const Vector3d nf = Xyz(1, 1, 1).normalized();
    struct Case {
      Vector3d centre_B;
      double radius;
      Vector3d closest_B;
      Vector3d normal_B;
      double gap;
    };
    const double face_dist = (1.5 - 1.0) / std::sqrt(3.0);
    const double inside_dist = (0.3 - 1.0) / std::sqrt(3.0);
    const Case cases[] = {
        {Xyz(0.5, 0.5, 0.5), 0.1, Xyz(0.5, 0.5, 0.5) - face_dist * nf, nf, face_dist - 0.1},
        {Xyz(1.3, 0, 0), 0.1, Xyz(1, 0, 0), Xyz(1, 0, 0), 0.2},
        {Xyz(0.6, 0.6, 0), 0.05, Xyz(0.5, 0.5, 0), Xyz(1, 1, 0).normalized(),
         std::sqrt(0.02) - 0.05},
        {Xyz(0.1, 0.1, 0.1), 0.1, Xyz(0.1, 0.1, 0.1) - inside_dist * nf, nf, inside_dist - 0.1},
    };
    for (const Case& c : cases) {
      const Vector3d centre = X_WB * c.centre_B;
      const Vector3d n = X_WB.linear() * c.normal_B;
      const auto cs = Collide(Sphere(c.radius), Pose(centre), octa, X_WB, 1.0);
      ASSERT_EQ(cs.size(), 1u);
      ExpectContact(cs[0], centre - c.radius * n, X_WB * c.closest_B, n, c.gap);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Capsule.

TEST(CollisionTest, CapsuleCapsuleCrossing) {
  const Matrix3d along_x = Rot(kPi / 2, Vector3d::UnitY());
  const Matrix3d along_y = Rot(-kPi / 2, Vector3d::UnitX());
  // A along x (y = 0.2) above B along y.
  const auto cs = Collide(Capsule(0.1, 0.5), Pose(Xyz(0.1, 0.2, 0.35), along_x), Capsule(0.2, 0.6),
                          Pose(Xyz(0, 0, 0), along_y), 0.1);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0, 0.2, 0.25), Xyz(0, 0.2, 0.2), Vector3d::UnitZ(), 0.05);

  // Skew axes at 60°: gap from the skew-line distance formula.
  const Vector3d u = Xyz(1, 0, 0), v = Xyz(0.5, std::sqrt(0.75), 0);
  const Vector3d cA(0.05, -0.02, 0.4), cB(0, 0, 0);
  const Matrix3d RA = RotFromTo(Vector3d::UnitZ(), u);
  const Matrix3d RB = RotFromTo(Vector3d::UnitZ(), v);
  const auto cs2 = Collide(Capsule(0.1, 1.0), Pose(cA, RA), Capsule(0.15, 1.0), Pose(cB, RB), 0.5);
  ASSERT_EQ(cs2.size(), 1u);
  const Vector3d w = u.cross(v).normalized();
  EXPECT_NEAR(cs2[0].gap, std::abs((cA - cB).dot(w)) - 0.25, kTol);
  EXPECT_TRUE(Near(cs2[0].n_W, w, kTol));
}

TEST(CollisionTest, CapsuleCapsuleParallelGivesTwoContactsAtTheOverlapEnds) {
  const Matrix3d along_x = Rot(kPi / 2, Vector3d::UnitY());
  // A covers x ∈ [−0.2, 0.8], B covers x ∈ [−0.6, 0.6]: overlap [−0.2, 0.6].
  for (const double flip : {0.0, kPi}) {
    const Matrix3d RB = Rot(flip, Vector3d::UnitZ()) * along_x;  // anti-parallel too
    const auto cs = Collide(Capsule(0.1, 0.5), Pose(Xyz(0.3, 0, 0.35), along_x), Capsule(0.2, 0.6),
                            Pose(Xyz(0, 0, 0), RB), 0.1);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    for (const double x : {-0.2, 0.6}) {
      const int i = FindByPA(cs, Xyz(x, 0, 0.25), kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], Xyz(x, 0, 0.25), Xyz(x, 0, 0.2), Vector3d::UnitZ(), 0.05);
    }
  }
  // Collinear, end to end: one contact between the facing end caps.
  const auto cs = Collide(Capsule(0.1, 0.5), Pose(Xyz(1.22, 0, 0), along_x), Capsule(0.1, 0.6),
                          Pose(Xyz(0, 0, 0), along_x), 0.1);
  ASSERT_EQ(cs.size(), 1u);
  ExpectContact(cs[0], Xyz(0.62, 0, 0), Xyz(0.7, 0, 0), Xyz(1, 0, 0), -0.08);
}

TEST(CollisionTest, CapsuleBox) {
  const Shape box = Box(0.5, 0.4, 0.3);
  const Isometry3d X_WB = Pose(Xyz(0.2, 0.1, -0.3), Rot(0.3, Xyz(0.2, 0.1, 1)));
  const Matrix3d& R = X_WB.linear();
  const Vector3d z = R.col(2);
  const Matrix3d along_x = Rot(kPi / 2, Vector3d::UnitY());
  const Matrix3d along_y = Rot(-kPi / 2, Vector3d::UnitX());
  const double envelope = 0.05;
  {
    SCOPED_TRACE("lying on the top face: the two end spheres");
    const auto cs =
        Collide(Capsule(0.05, 0.2), X_WB * Pose(Xyz(0.1, 0, 0.37), along_x), box, X_WB, envelope);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    for (const double x : {-0.1, 0.3}) {
      const int i = FindByPA(cs, X_WB * Xyz(x, 0, 0.32), kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], X_WB * Xyz(x, 0, 0.32), X_WB * Xyz(x, 0, 0.3), z, 0.02);
    }
  }
  {
    SCOPED_TRACE("lying across, longer than the box: contacts at the two top edges");
    const auto cs =
        Collide(Capsule(0.05, 1.0), X_WB * Pose(Xyz(0.1, 0, 0.37), along_y), box, X_WB, envelope);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    for (const double y : {-0.4, 0.4}) {
      const int i = FindByPA(cs, X_WB * Xyz(0.1, y, 0.32), kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], X_WB * Xyz(0.1, y, 0.32), X_WB * Xyz(0.1, y, 0.3), z, 0.02);
    }
  }
  {
    SCOPED_TRACE("hanging over the +x top edge: one end on the face, one on the edge");
    const auto cs =
        Collide(Capsule(0.02, 0.4), X_WB * Pose(Xyz(0.6, 0.1, 0.35), along_x), box, X_WB, envelope);
    ASSERT_EQ(cs.size(), 2u) << Describe(cs);
    int i = FindByPA(cs, X_WB * Xyz(0.2, 0.1, 0.33), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], X_WB * Xyz(0.2, 0.1, 0.33), X_WB * Xyz(0.2, 0.1, 0.3), z, 0.03);
    i = FindByPA(cs, X_WB * Xyz(0.5, 0.1, 0.33), kTol);
    ASSERT_GE(i, 0) << Describe(cs);
    ExpectContact(cs[i], X_WB * Xyz(0.5, 0.1, 0.33), X_WB * Xyz(0.5, 0.1, 0.3), z, 0.03);
  }
  {
    SCOPED_TRACE("parallel to the +x top edge, diagonally off it: edge contacts, exact gap");
    const Vector3d n_B = Xyz(0.6, 0, 0.8);
    for (const double half_length : {0.2, 0.8}) {  // ends within / beyond the edge
      const auto cs = Collide(Capsule(0.02, half_length), X_WB * Pose(Xyz(0.53, 0, 0.34), along_y),
                              box, X_WB, envelope);
      ASSERT_EQ(cs.size(), 2u) << Describe(cs);
      for (const ContactPoint& c : cs) {
        EXPECT_NEAR(c.gap, 0.03, kTol);
        EXPECT_TRUE(Near(c.n_W, R * n_B, kTol));
        const Vector3d p_B = X_WB.inverse(Eigen::Isometry) * c.p_B_W;
        EXPECT_NEAR(p_B.x(), 0.5, kTol);
        EXPECT_NEAR(p_B.z(), 0.3, kTol);
      }
    }
  }
  {
    SCOPED_TRACE("axis through the box, both ends outside");
    const auto cs =
        Collide(Capsule(0.05, 1.0), X_WB * Pose(Xyz(0, 0, 0.2), along_x), box, X_WB, envelope);
    ASSERT_EQ(cs.size(), 1u) << Describe(cs);
    ExpectContact(cs[0], X_WB * Xyz(0, 0, 0.15), X_WB * Xyz(0, 0, 0.3), z, -0.15);
  }
}

TEST(CollisionTest, CapsuleOnPolyhedronMatchesCapsuleOnBox) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<Vector3d> cube = CubeVertices(0.4);
  cube.push_back(Xyz(0, 0, 0.4));  // a face centre, not a hull corner
  const Shape poly = Polyhedron(cube, true);
  const Shape box = Box(0.4, 0.4, 0.4);
  int with_contacts = 0;
  for (int k = 0; k < 200; ++k) {
    const Isometry3d X_WA =
        Pose(Xyz(U(rng), U(rng), U(rng)) * 0.8, Rot(3 * U(rng), Xyz(U(rng), U(rng), U(rng))));
    const Shape capsule = Capsule(0.1, 0.3);
    const auto with_poly = Collide(capsule, X_WA, poly, Isometry3d::Identity(), 0.1);
    const auto with_box = Collide(capsule, X_WA, box, Isometry3d::Identity(), 0.1);
    EXPECT_TRUE(SameContactSet(with_poly, with_box, 1e-10));
    with_contacts += !with_box.empty();
  }
  EXPECT_GT(with_contacts, 50);  // the poses exercise contacts, not only misses
}

// ---------------------------------------------------------------------------------------------
// Box / polyhedron pairs.

TEST(CollisionTest, StackedEqualBoxesGiveExactlyFourContacts) {
  const Shape box = Box(0.5, 0.4, 0.3);
  const Isometry3d X_WB = Pose(Xyz(1, -2, 0.5), Rot(0.4, Xyz(0.3, -0.2, 1)));
  const Vector3d n = X_WB.linear().col(2);
  for (const double gap : {0.0, -1e-4, 0.004}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    const Isometry3d X_WA = X_WB * Pose(Xyz(0, 0, 0.6 + gap));
    const auto cs = Collide(box, X_WA, box, X_WB, 0.01);
    ASSERT_EQ(cs.size(), 4u) << Describe(cs);
    for (int corner = 0; corner < 4; ++corner) {
      const Vector3d p = X_WA * Xyz((corner & 1) ? 0.5 : -0.5, (corner & 2) ? 0.4 : -0.4, -0.3);
      const int i = FindByPA(cs, p, 1e-12);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], p, p - gap * n, n, gap);
    }
  }
}

TEST(CollisionTest, SmallBoxOnBigBoxGivesItsFourCorners) {
  const Shape big = Box(1, 1, 0.5);
  const Shape small = Box(0.3, 0.2, 0.1);
  const Isometry3d X_WB = Pose(Xyz(0, 0, -0.5), Rot(0.2, Xyz(1, 0, 0.3)));
  const Vector3d n = X_WB.linear().col(2);
  for (const double gap : {0.0, -1e-3}) {
    const Isometry3d X_WA = X_WB * Pose(Xyz(0.3, -0.2, 0.6 + gap), Rot(0.4, Vector3d::UnitZ()));
    const auto cs = Collide(small, X_WA, big, X_WB, 0.01);
    ASSERT_EQ(cs.size(), 4u) << Describe(cs);
    for (int corner = 0; corner < 4; ++corner) {
      const Vector3d p = X_WA * Xyz((corner & 1) ? 0.3 : -0.3, (corner & 2) ? 0.2 : -0.2, -0.1);
      const int i = FindByPA(cs, p, kTol);
      ASSERT_GE(i, 0) << Describe(cs);
      ExpectContact(cs[i], p, p - gap * n, n, gap);
    }
  }
}

TEST(CollisionTest, BoxYawed45DegOnEqualBoxGivesTheEightEdgeCrossings) {
  const Shape cube = Box(0.5, 0.5, 0.5);
  const Isometry3d X_WA = Pose(Xyz(0, 0, 1.0), Rot(kPi / 4, Vector3d::UnitZ()));
  const auto cs = Collide(cube, X_WA, cube, Isometry3d::Identity(), 0.01);
  ASSERT_EQ(cs.size(), 8u) << Describe(cs);
  const double c = std::sqrt(0.5) - 0.5;  // where A's edges cross x = ±0.5, y = ±0.5
  for (const double sx : {-1.0, 1.0}) {
    for (const double sy : {-1.0, 1.0}) {
      for (const Vector3d& p : {Xyz(0.5 * sx, c * sy, 0.5), Xyz(c * sx, 0.5 * sy, 0.5)}) {
        const int i = FindByPA(cs, p, 1e-12);
        ASSERT_GE(i, 0) << p.transpose() << "\n" << Describe(cs);
        ExpectContact(cs[i], p, p, Vector3d::UnitZ(), 0.0);
      }
    }
  }
}

TEST(CollisionTest, CrossedEdgesGiveOneEdgeEdgeContact) {
  // B: cube turned 45° about x (top edge along x at z = √2/2); A: cube turned 45° about y,
  // above it (bottom edge along y), shifted so the edges cross at (0.1, 0).
  const Shape cube = Box(0.5, 0.5, 0.5);
  const double r2 = std::sqrt(0.5);
  const Isometry3d X_WB = Pose(Xyz(0, 0, 0), Rot(kPi / 4, Vector3d::UnitX()));
  for (const double gap : {0.005, 0.0, -0.005}) {
    SCOPED_TRACE("gap " + std::to_string(gap));
    const Isometry3d X_WA = Pose(Xyz(0.1, -0.2, 2 * r2 + gap), Rot(kPi / 4, Vector3d::UnitY()));
    const auto cs = Collide(cube, X_WA, cube, X_WB, 0.01);
    ASSERT_EQ(cs.size(), 1u) << Describe(cs);
    ExpectContact(cs[0], Xyz(0.1, 0, r2 + gap), Xyz(0.1, 0, r2), Vector3d::UnitZ(), gap);
  }
}

TEST(CollisionTest, BoxPairsMatchTheirPolyhedronTwins) {
  // Two boxes near contact (one on the other, tilted, yawed, offset, or edge on crossed edge)
  // against the same boxes as polyhedra: the box pair prunes edge pairs and vertices that cannot
  // touch, the polyhedron pair forms them all, so a wrongly pruned contact shows as a
  // difference.
  std::mt19937 rng(20261202);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  const auto box_twin = [](const Vector3d& h) {
    std::vector<Vector3d> v;
    for (int i = 0; i < 8; ++i)
      v.emplace_back((i & 1) ? h.x() : -h.x(), (i & 2) ? h.y() : -h.y(), (i & 4) ? h.z() : -h.z());
    return Polyhedron(v, true);
  };
  const double envelope = 0.01;
  int contacts = 0, edge_crossings = 0;
  for (int trial = 0; trial < 300; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const Vector3d h_A(uniform(0.1, 0.4), uniform(0.1, 0.4), uniform(0.1, 0.4));
    const Vector3d h_B(uniform(0.1, 0.4), uniform(0.1, 0.4), uniform(0.1, 0.4));
    const int kind = trial % 3;  // 0: resting, 1: tilted, 2: crossed edges
    Matrix3d R_B = Matrix3d::Identity(), R_A = Rot(uniform(0, 2 * kPi), Vector3d::UnitZ());
    if (kind == 1) R_A = Rot(uniform(0, 0.5), Xyz(uniform(-1, 1), uniform(-1, 1), 0)) * R_A;
    if (kind == 2) {
      R_B = Rot(kPi / 4, Vector3d::UnitX());
      R_A = Rot(uniform(-0.4, 0.4), Vector3d::UnitZ()) * Rot(kPi / 4, Vector3d::UnitY());
    }
    const double top_B = h_B.dot((R_B.transpose() * Vector3d::UnitZ()).cwiseAbs());
    const double bottom_A = h_A.dot((R_A.transpose() * Vector3d::UnitZ()).cwiseAbs());
    const double reach = kind == 2 ? 0.1 : h_A.head<2>().norm() + h_B.head<2>().norm();
    const Vector3d p_A(uniform(-reach, reach), uniform(-reach, reach),
                       top_B + bottom_A + uniform(-0.004, 0.012));
    const Isometry3d X_WG = Pose(Xyz(uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)),
                                 Rot(uniform(0, kPi), Xyz(uniform(-1, 1), uniform(-1, 1), 1)));
    const Isometry3d X_WA = X_WG * Pose(p_A, R_A), X_WB = X_WG * Pose(Xyz(0, 0, 0), R_B);
    const Shape box_A = Box(h_A.x(), h_A.y(), h_A.z()), box_B = Box(h_B.x(), h_B.y(), h_B.z());
    const auto boxes = Collide(box_A, X_WA, box_B, X_WB, envelope);
    const auto twins = Collide(box_twin(h_A), X_WA, box_twin(h_B), X_WB, envelope);
    ASSERT_TRUE(SameContactSet(boxes, twins, 1e-9));
    contacts += static_cast<int>(boxes.size());
    if (kind == 2) edge_crossings += static_cast<int>(boxes.size());
  }
  EXPECT_GT(contacts, 300);  // the poses do reach contact
  EXPECT_GT(edge_crossings, 20);
}

TEST(CollisionTest, BoxPolyhedronPairs) {
  for (const bool prepare : {true, false}) {
    SCOPED_TRACE(prepare ? "prepared" : "hull on the fly");
    const Shape table = Box(1, 1, 0.5);  // top face at z = 0.5
    // Tetrahedron point-down 2 mm above the table.
    const Shape tetra = Polyhedron(CornerTetrahedronVertices(), prepare);
    const Matrix3d R = RotFromTo(Xyz(1, 1, 1).normalized(), Vector3d::UnitZ());
    auto cs = Collide(tetra, Pose(Xyz(0.1, 0.2, 0.502), R), table, Isometry3d::Identity(), 0.01);
    ASSERT_EQ(cs.size(), 1u) << Describe(cs);
    ExpectContact(cs[0], Xyz(0.1, 0.2, 0.502), Xyz(0.1, 0.2, 0.5), Vector3d::UnitZ(), 0.002);
    // Octahedron resting on a face: its three lowest corners.
    const Shape octa = Polyhedron(OctahedronVertices(), prepare);
    const Matrix3d Ro = RotFromTo(Xyz(-1, -1, -1).normalized(), -Vector3d::UnitZ());
    const Isometry3d X_WO = Pose(Xyz(-0.2, 0.1, 0.5 + 1 / std::sqrt(3.0)), Ro);
    cs = Collide(octa, X_WO, table, Isometry3d::Identity(), 0.01);
    ASSERT_EQ(cs.size(), 3u) << Describe(cs);
    for (const Vector3d& v : {Xyz(-1, 0, 0), Xyz(0, -1, 0), Xyz(0, 0, -1)}) {
      const int i = FindByPA(cs, X_WO * v, 1e-12);
      ASSERT_GE(i, 0) << Describe(cs);
      EXPECT_NEAR(cs[i].gap, 0.0, 1e-12);
      EXPECT_TRUE(Near(cs[i].n_W, Vector3d::UnitZ(), kTol));
    }
    // Box resting on the octahedron's upper vertex: one contact, normal −z (B = box above).
    cs = Collide(octa, Isometry3d::Identity(), Box(0.3, 0.3, 0.1), Pose(Xyz(0.05, 0, 1.1)), 0.01);
    ASSERT_EQ(cs.size(), 1u) << Describe(cs);
    ExpectContact(cs[0], Xyz(0, 0, 1), Xyz(0, 0, 1), -Vector3d::UnitZ(), 0.0);
  }
}

TEST(CollisionTest, CubePolyhedronMatchesBox) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  std::vector<Vector3d> cube = CubeVertices(0.3);
  cube.push_back(Xyz(0, 0, 0));      // interior
  cube.push_back(Xyz(0.3, 0, 0.1));  // inside a face
  cube.push_back(Xyz(0.3, 0.3, 0));  // inside an edge
  for (const bool prepare : {true, false}) {
    const Shape poly = Polyhedron(cube, prepare);
    const Shape box = Box(0.3, 0.3, 0.3);
    const Shape others[] = {Box(0.2, 0.35, 0.1), Sphere(0.25), Capsule(0.1, 0.3), HalfSpace()};
    int with_contacts = 0;
    for (const Shape& other : others) {
      for (int k = 0; k < 60; ++k) {
        const Isometry3d X_WA =
            Pose(Xyz(U(rng), U(rng), U(rng)) * 0.7, Rot(3 * U(rng), Xyz(U(rng), U(rng), U(rng))));
        const Isometry3d X_WB = Pose(Xyz(0, 0, 0), Rot(U(rng), Xyz(1, 2, 3)));
        const auto cs_poly = Collide(poly, X_WA, other, X_WB, 0.1);
        const auto cs_box = Collide(box, X_WA, other, X_WB, 0.1);
        EXPECT_TRUE(SameContactSet(cs_poly, cs_box, 1e-10));
        with_contacts += !cs_box.empty();
      }
    }
    EXPECT_GT(with_contacts, 60);
  }
}

TEST(CollisionTest, PrepareShapeComputesTheHull) {
  std::vector<Vector3d> pts = CubeVertices(0.5);
  pts.push_back(Xyz(0, 0, 0));
  pts.push_back(Xyz(0.5, 0.1, -0.2));  // inside the +x face
  pts.push_back(Xyz(0.5, 0.5, 0.2));   // inside an edge
  pts.push_back(pts[3]);               // duplicate corner
  Shape s = Polyhedron(pts, false);
  PrepareShape(&s);
  EXPECT_EQ(s.faces.size(), 6u);
  ASSERT_EQ(s.hull_vertices.size(), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(s.hull_vertices[i], i);
  for (const HullFace& f : s.faces) {
    EXPECT_NEAR(f.normal_S.norm(), 1.0, kTol);
    EXPECT_NEAR(f.offset, 0.5, kTol);
    ASSERT_EQ(f.vertices.size(), 4u);
    for (std::size_t k = 0; k < 4; ++k) {  // counter-clockwise about the outward normal
      const Vector3d& a = s.vertices[f.vertices[k]];
      const Vector3d& b = s.vertices[f.vertices[(k + 1) % 4]];
      const Vector3d& c = s.vertices[f.vertices[(k + 2) % 4]];
      EXPECT_GT((b - a).cross(c - b).dot(f.normal_S), 0.0);
      EXPECT_NEAR(f.normal_S.dot(a), f.offset, kTol);
    }
    for (const Vector3d& p : pts) EXPECT_LE(f.normal_S.dot(p), f.offset + kTol);
  }
  // Other kinds are left alone; flat point sets are rejected with the shape's name.
  Shape sphere = Sphere(1);
  PrepareShape(&sphere);
  EXPECT_TRUE(sphere.faces.empty());
  Shape flat = Polyhedron({Xyz(0, 0, 0), Xyz(1, 0, 0), Xyz(0, 1, 0), Xyz(1, 1, 0)}, false);
  try {
    PrepareShape(&flat);
    ADD_FAILURE() << "coplanar polyhedron accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'poly'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("coplanar"), std::string::npos) << e.what();
  }
}

TEST(CollisionTest, EnvelopeIncludesHalfEpsilonAndExcludesTwoEpsilon) {
  const double eps = 1e-3;
  const Shape cube = Box(0.5, 0.5, 0.5);
  struct Case {
    const char* name;
    Shape a, b;
    std::function<Isometry3d(double)> pose_a;  // pose of a at the given gap (b at identity)
    std::size_t count;
  };
  const Case cases[] = {
      {"box/halfspace", cube, HalfSpace(), [](double g) { return Pose(Xyz(0, 0, 0.5 + g)); }, 4},
      {"sphere/sphere", Sphere(0.3), Sphere(0.2), [](double g) { return Pose(Xyz(0.5 + g, 0, 0)); },
       1},
      {"sphere/box", Sphere(0.3), cube, [](double g) { return Pose(Xyz(0.1, 0.2, 0.8 + g)); }, 1},
      {"capsule/capsule", Capsule(0.1, 0.5), Capsule(0.1, 0.5),
       [](double g) { return Pose(Xyz(0, 0.2 + g, 0), Rot(kPi / 2, Vector3d::UnitY())); }, 1},
      {"box/box", cube, Box(1, 1, 0.5), [](double g) { return Pose(Xyz(0, 0, 1 + g)); }, 4},
      {"disc/halfplane", Disc(0.3), HalfPlane(), [](double g) { return PlanarPose(0, 0.3 + g, 0); },
       1},
      {"polygon/polygon", Square(0.5), Square(1),
       [](double g) { return PlanarPose(0, 1.5 + g, 0); }, 2},
      {"segment/polygon", Segment(0.3, 0.0), Square(1),
       [](double g) { return PlanarPose(0, 1 + g, 0); }, 2},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    EXPECT_EQ(Collide(c.a, c.pose_a(0.5 * eps), c.b, Isometry3d::Identity(), eps).size(), c.count);
    EXPECT_EQ(Collide(c.a, c.pose_a(2.0 * eps), c.b, Isometry3d::Identity(), eps).size(), 0u);
  }
}

TEST(CollisionTest, InvalidPairsThrowNamingBothKinds) {
  const std::pair<Shape, Shape> pairs[] = {{Sphere(1), Disc(1)},
                                           {HalfPlane(), Box(1, 1, 1)},
                                           {HalfSpace(), HalfSpace()},
                                           {HalfPlane(), HalfPlane()}};
  const std::pair<const char*, const char*> names[] = {{"kSphere", "kDisc"},
                                                       {"kHalfPlane", "kBox"},
                                                       {"kHalfSpace", "kHalfSpace"},
                                                       {"kHalfPlane", "kHalfPlane"}};
  for (int k = 0; k < 4; ++k) {
    std::vector<ContactPoint> out;
    try {
      CollideShapes(pairs[k].first, Isometry3d::Identity(), pairs[k].second, Isometry3d::Identity(),
                    0.1, &out);
      ADD_FAILURE() << "no exception for " << names[k].first << " / " << names[k].second;
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(names[k].first), std::string::npos) << what;
      EXPECT_NE(what.find(names[k].second), std::string::npos) << what;
    }
  }
}

// Every supported pair of kinds at random nearby poses: the invariants and swap symmetry
// (checked inside Collide), and that the poses produce contacts at all.
TEST(CollisionTest, AllPairsSatisfyInvariantsAndSwapSymmetry) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const std::vector<Shape> spatial = {HalfSpace(),
                                      Sphere(0.3),
                                      Box(0.3, 0.2, 0.25),
                                      Capsule(0.15, 0.3),
                                      Polyhedron(OctahedronVertices(), true),
                                      Polyhedron(CornerTetrahedronVertices(), false)};
  const std::vector<Shape> planar = {
      HalfPlane(),       Disc(0.3),
      Square(0.3),       Polygon({{-0.3, -0.2, 0}, {0.4, -0.1, 0}, {0, 0.5, 0}}),
      Segment(0.4, 0.1), Segment(0.3, 0.0)};
  for (const auto* shapes : {&spatial, &planar}) {
    const bool is_planar = shapes == &planar;
    for (std::size_t i = 0; i < shapes->size(); ++i) {
      for (std::size_t j = i; j < shapes->size(); ++j) {
        if (i == 0 && j == 0) continue;  // two half-spaces / half-planes
        SCOPED_TRACE(std::to_string(i) + " vs " + std::to_string(j) + (is_planar ? " planar" : ""));
        int with_contacts = 0;
        for (int k = 0; k < 40; ++k) {
          Isometry3d X_WA, X_WB;
          if (is_planar) {
            X_WA = PlanarPose(0.5 * U(rng), 0.5 * U(rng), 4 * U(rng));
            X_WB = PlanarPose(0.5 * U(rng), 0.5 * U(rng), 4 * U(rng));
          } else {
            X_WA = Pose(0.5 * Xyz(U(rng), U(rng), U(rng)), Rot(4 * U(rng), Xyz(U(rng), U(rng), 1)));
            X_WB = Pose(0.5 * Xyz(U(rng), U(rng), U(rng)), Rot(4 * U(rng), Xyz(1, U(rng), U(rng))));
          }
          with_contacts += !Collide((*shapes)[i], X_WA, (*shapes)[j], X_WB, 0.1).empty();
        }
        EXPECT_GT(with_contacts, 5);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Randomized comparison with a brute-force distance: alternating projections between the two
// convex sets converge to a closest pair (independent of the contact code's case analysis).

Projector ProjectOnto(const Shape& s, const Isometry3d& X) {
  switch (s.type) {
    case ShapeType::kSphere:
      return [=](const Vector3d& x) -> Vector3d {
        const Vector3d d = x - X.translation();
        return d.norm() <= s.radius ? x : Vector3d(X.translation() + s.radius * d.normalized());
      };
    case ShapeType::kBox:
      return [=](const Vector3d& x) -> Vector3d {
        const Vector3d local = X.inverse(Eigen::Isometry) * x;
        return X * local.cwiseMax(-s.half_extents).cwiseMin(s.half_extents);
      };
    default:  // capsule
      return [=](const Vector3d& x) -> Vector3d {
        const Vector3d a = X * Xyz(0, 0, -s.half_length), b = X * Xyz(0, 0, s.half_length);
        const double t = std::clamp((x - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
        const Vector3d q = a + t * (b - a);
        return (x - q).norm() <= s.radius ? x : Vector3d(q + s.radius * (x - q).normalized());
      };
  }
}

Quaterniond RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> N;
  return Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized();
}

TEST(CollisionTest, RandomizedGapsMatchBruteForceDistance) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const Shape sphere = Sphere(0.3), box = Box(0.4, 0.25, 0.15), capsule = Capsule(0.15, 0.3);
  struct Pair {
    const char* name;
    const Shape* a;
    const Shape* b;
    bool min_gap_is_distance;  // all contacts are true distances (else: some contact is)
  };
  const Pair pairs[] = {
      {"sphere/sphere", &sphere, &sphere, true},   {"sphere/box", &sphere, &box, true},
      {"sphere/capsule", &sphere, &capsule, true}, {"capsule/capsule", &capsule, &capsule, true},
      {"capsule/box", &capsule, &box, true},       {"box/box", &box, &box, false}};
  const double envelope = 0.5;
  for (const Pair& p : pairs) {
    SCOPED_TRACE(p.name);
    int compared = 0;
    for (int k = 0; k < 300; ++k) {
      const Isometry3d X_WA =
          Pose(1.2 * Xyz(U(rng), U(rng), U(rng)), RandomRotation(rng).toRotationMatrix());
      const Isometry3d X_WB = Pose(Vector3d::Zero(), RandomRotation(rng).toRotationMatrix());
      const double d =
          BruteForceDistance(ProjectOnto(*p.a, X_WA), ProjectOnto(*p.b, X_WB), X_WA.translation());
      const auto cs = Collide(*p.a, X_WA, *p.b, X_WB, envelope);
      CheckAgainstDistance(cs, d, envelope, p.min_gap_is_distance, k, &compared);
      if (::testing::Test::HasFatalFailure()) return;
    }
    EXPECT_GT(compared, 40);  // enough separated-within-envelope samples to mean something
  }
}

}  // namespace
}  // namespace vinci::sim
