// Closed-form contact rates (geometry/contact_rate.h) against central differences of
// CollideShapes at rigidly moved poses.
#include "vinci/sim/geometry/contact_rate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace vinci::sim {
namespace {

// Central differences with step 1e-6 of unit-size geometry: truncation ~1e-12, round-off ~1e-10.
constexpr double kTol = 1e-7;
constexpr double kStep = 1e-6;

Shape Make(ShapeType type, double radius = 0.0, Vector3d half = Vector3d::Zero()) {
  Shape s;
  s.type = type;
  s.radius = radius;
  s.half_extents = half;
  return s;
}
Shape Polygon() {
  Shape s;
  s.type = ShapeType::kPolygon;
  s.vertices = {Vector3d(-0.3, -0.1, 0), Vector3d(0.25, -0.15, 0), Vector3d(0.3, 0.2, 0),
                Vector3d(-0.2, 0.1, 0)};
  return s;
}
Shape Capsule(double r, double half_length) {
  Shape s = Make(ShapeType::kCapsule, r);
  s.half_length = half_length;
  return s;
}
Shape Segment(double r, double half_length) {
  Shape s = Make(ShapeType::kSegment, r);
  s.half_length = half_length;
  return s;
}

struct Moving {
  Isometry3d X_WB;  // body pose at t = 0
  Isometry3d X_BS;  // shape in body
  BodyRate rate;
  // Shape pose at t: the body origin moves at v, the body turns at ω about its origin.
  Isometry3d ShapeAt(double t) const {
    Isometry3d X = X_WB;
    const double w = rate.w_W.norm();
    if (w > 0.0) X.linear() = Eigen::AngleAxisd(t * w, rate.w_W / w) * X_WB.linear();
    X.translation() = X_WB.translation() + t * rate.v_W;
    return X * X_BS;
  }
};

Moving RandomMoving(std::mt19937* gen, bool planar, const Vector3d& position) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Moving m;
  if (planar) {
    m.X_WB = PlanarPose(position.x(), position.y(), 0.3 * u(*gen));
    m.X_BS = PlanarPose(0.05 * u(*gen), 0.05 * u(*gen), 0.2 * u(*gen));
    m.rate.v_W = Vector3d(u(*gen), u(*gen), 0.0);
    m.rate.w_W = Vector3d(0.0, 0.0, u(*gen));
  } else {
    m.X_WB = Isometry3d::Identity();
    m.X_WB.linear() =
        Eigen::AngleAxisd(0.3 * u(*gen), Vector3d(u(*gen), u(*gen), u(*gen)).normalized())
            .toRotationMatrix();
    m.X_WB.translation() = position;
    m.X_BS = Isometry3d::Identity();
    m.X_BS.linear() = Eigen::AngleAxisd(0.2 * u(*gen), Vector3d::UnitX()).toRotationMatrix();
    m.X_BS.translation() = Vector3d(0.05 * u(*gen), 0.05 * u(*gen), 0.05 * u(*gen));
    m.rate.v_W = Vector3d(u(*gen), u(*gen), u(*gen));
    m.rate.w_W = Vector3d(u(*gen), u(*gen), u(*gen));
  }
  m.rate.o_W = m.X_WB.translation();
  return m;
}

std::vector<ContactPoint> Collide(const Shape& a, const Moving& ma, const Shape& b,
                                  const Moving& mb, double t) {
  std::vector<ContactPoint> out;
  CollideShapes(a, ma.ShapeAt(t), b, mb.ShapeAt(t), 10.0, &out);  // every feature
  return out;
}

// Every contact of the pair at random poses and rates: the closed form against differences.
void ExpectRatesMatch(const Shape& a, const Shape& b, bool planar, const Vector3d& offset_a) {
  std::mt19937 gen(7);
  for (int trial = 0; trial < 5; ++trial) {
    const Moving ma = RandomMoving(&gen, planar, offset_a);
    const Moving mb = RandomMoving(&gen, planar, Vector3d::Zero());
    const std::vector<ContactPoint> c0 = Collide(a, ma, b, mb, 0.0);
    const std::vector<ContactPoint> cp = Collide(a, ma, b, mb, kStep);
    const std::vector<ContactPoint> cm = Collide(a, ma, b, mb, -kStep);
    ASSERT_FALSE(c0.empty());
    ASSERT_EQ(cp.size(), c0.size());
    ASSERT_EQ(cm.size(), c0.size());
    for (std::size_t i = 0; i < c0.size(); ++i) {
      ContactPointRate d;
      ASSERT_TRUE(ContactRate(a, b, c0[i], ma.rate, mb.rate, &d));
      const auto fd = [&](const Vector3d& p, const Vector3d& m) { return (p - m) / (2 * kStep); };
      EXPECT_LE((d.p_A_W - fd(cp[i].p_A_W, cm[i].p_A_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.p_B_W - fd(cp[i].p_B_W, cm[i].p_B_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.n_W - fd(cp[i].n_W, cm[i].n_W)).norm(), kTol) << "trial " << trial;
      EXPECT_NEAR(d.gap, (cp[i].gap - cm[i].gap) / (2 * kStep), kTol) << "trial " << trial;
      if (planar) {
        EXPECT_EQ(d.p_A_W.z(), 0.0);
      }
    }
  }
}

const Vector3d kAbove(0.1, -0.05, 0.4);
const Vector3d kAbove2(0.1, 0.4, 0.0);

TEST(ContactRateTest, SphereOnHalfSpace) {
  ExpectRatesMatch(Make(ShapeType::kSphere, 0.2), Make(ShapeType::kHalfSpace), false, kAbove);
}
TEST(ContactRateTest, HalfSpaceUnderSphere) {  // the flipped order
  ExpectRatesMatch(Make(ShapeType::kHalfSpace), Make(ShapeType::kSphere, 0.2), false, kAbove);
}
TEST(ContactRateTest, BoxCornersOnHalfSpace) {
  const Shape box = Make(ShapeType::kBox, 0.0, Vector3d(0.2, 0.15, 0.1));
  ExpectRatesMatch(box, Make(ShapeType::kHalfSpace), false, kAbove);
  ExpectRatesMatch(Make(ShapeType::kHalfSpace), box, false, kAbove);
}
TEST(ContactRateTest, CapsuleEndsOnHalfSpace) {
  ExpectRatesMatch(Capsule(0.1, 0.2), Make(ShapeType::kHalfSpace), false, kAbove);
}
TEST(ContactRateTest, SphereSphere) {
  ExpectRatesMatch(Make(ShapeType::kSphere, 0.2), Make(ShapeType::kSphere, 0.15), false, kAbove);
}
TEST(ContactRateTest, DiscOnHalfPlane) {
  ExpectRatesMatch(Make(ShapeType::kDisc, 0.2), Make(ShapeType::kHalfPlane), true, kAbove2);
  ExpectRatesMatch(Make(ShapeType::kHalfPlane), Make(ShapeType::kDisc, 0.2), true, kAbove2);
}
TEST(ContactRateTest, PolygonVerticesOnHalfPlane) {
  ExpectRatesMatch(Polygon(), Make(ShapeType::kHalfPlane), true, kAbove2);
}
TEST(ContactRateTest, SegmentEndsOnHalfPlane) {
  ExpectRatesMatch(Segment(0.05, 0.2), Make(ShapeType::kHalfPlane), true, kAbove2);
}
TEST(ContactRateTest, DiscDisc) {
  ExpectRatesMatch(Make(ShapeType::kDisc, 0.2), Make(ShapeType::kDisc, 0.1), true, kAbove2);
}

TEST(ContactRateTest, PairsWithoutClosedFormAreLeftToTheCaller) {
  const Shape sphere = Make(ShapeType::kSphere, 0.2);
  const Shape box = Make(ShapeType::kBox, 0.0, Vector3d(0.2, 0.15, 0.1));
  std::vector<ContactPoint> c;
  CollideShapes(sphere, Isometry3d(Eigen::Translation3d(0, 0, 0.35)), box, Isometry3d::Identity(),
                1.0, &c);
  ASSERT_FALSE(c.empty());
  ContactPointRate d;
  d.gap = 42.0;
  EXPECT_FALSE(ContactRate(sphere, box, c[0], BodyRate{}, BodyRate{}, &d));
  EXPECT_EQ(d.gap, 42.0);  // untouched
  ContactPoint corner = c[0];
  corner.corner = true;
  EXPECT_FALSE(
      ContactRate(sphere, Make(ShapeType::kHalfSpace), corner, BodyRate{}, BodyRate{}, &d));
}

// A box's vertices on a larger box's top face (small tilts, both bodies moving), either order:
// ClassifyPolytopeContact finds which body carries the vertex, and VertexFaceRate (the vertex a
// material point, the face's plane moving with its body) matches differences of CollideShapes.
void ExpectBoxOnBoxRatesMatch(bool small_first) {
  const Shape small = Make(ShapeType::kBox, 0.0, Vector3d(0.1, 0.08, 0.06));
  const Shape large = Make(ShapeType::kBox, 0.0, Vector3d(0.2, 0.15, 0.1));
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    Moving ms, ml;
    ms.X_WB = Isometry3d::Identity();
    ms.X_WB.linear() = Eigen::AngleAxisd(0.02 * u(gen), Vector3d(u(gen), u(gen), 0.1).normalized())
                           .toRotationMatrix();
    ms.X_WB.translation() = Vector3d(0.03 * u(gen), 0.03 * u(gen), 0.1 + 0.06 + 0.01);
    ml.X_WB = Isometry3d::Identity();
    ms.X_BS = ml.X_BS = Isometry3d::Identity();
    for (Moving* m : {&ms, &ml}) {
      m->rate.v_W = Vector3d(u(gen), u(gen), u(gen));
      m->rate.w_W = Vector3d(u(gen), u(gen), u(gen));
      m->rate.o_W = m->X_WB.translation();
    }
    const Shape& a = small_first ? small : large;
    const Shape& b = small_first ? large : small;
    const Moving& ma = small_first ? ms : ml;
    const Moving& mb = small_first ? ml : ms;
    std::vector<ContactPoint> c0, cp, cm;
    CollideShapes(a, ma.ShapeAt(0.0), b, mb.ShapeAt(0.0), 0.05, &c0);
    CollideShapes(a, ma.ShapeAt(kStep), b, mb.ShapeAt(kStep), 0.05, &cp);
    CollideShapes(a, ma.ShapeAt(-kStep), b, mb.ShapeAt(-kStep), 0.05, &cm);
    ASSERT_EQ(c0.size(), 4u) << "the small box's bottom vertices";
    ASSERT_EQ(cp.size(), c0.size());
    ASSERT_EQ(cm.size(), c0.size());
    for (std::size_t i = 0; i < c0.size(); ++i) {
      const PolytopeFeature f =
          ClassifyPolytopeContact(a, ma.ShapeAt(0.0), b, mb.ShapeAt(0.0), c0[i], 1e-6);
      EXPECT_EQ(f.side, small_first ? VertexSide::kA : VertexSide::kB);
      EXPECT_FALSE(f.near_face_boundary);
      ContactPointRate d;
      ASSERT_TRUE(VertexFaceRate(f.side, c0[i], ma.rate, mb.rate, &d));
      const auto fd = [&](const Vector3d& p, const Vector3d& m) { return (p - m) / (2 * kStep); };
      EXPECT_LE((d.p_A_W - fd(cp[i].p_A_W, cm[i].p_A_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.p_B_W - fd(cp[i].p_B_W, cm[i].p_B_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.n_W - fd(cp[i].n_W, cm[i].n_W)).norm(), kTol) << "trial " << trial;
      EXPECT_NEAR(d.gap, (cp[i].gap - cm[i].gap) / (2 * kStep), kTol) << "trial " << trial;
    }
  }
}

TEST(ContactRateTest, BoxVerticesOnBoxFace) { ExpectBoxOnBoxRatesMatch(true); }
TEST(ContactRateTest, BoxFaceUnderBoxVertices) { ExpectBoxOnBoxRatesMatch(false); }

// Flush equal boxes: each contact is a vertex of a on a vertex of b — both readings fit; a's
// vertex is taken (as the collision routine keeps it) and the contact is flagged near the face
// boundary. Edge–edge contacts are not vertex–face contacts.
TEST(ContactRateTest, FlushBoxesAreFlaggedAtTheFeatureSwitch) {
  const Shape box = Make(ShapeType::kBox, 0.0, Vector3d(0.1, 0.1, 0.1));
  const Isometry3d below = Isometry3d::Identity();
  const Isometry3d above(Eigen::Translation3d(0, 0, 0.2005));
  std::vector<ContactPoint> c;
  CollideShapes(box, above, box, below, 0.002, &c);
  ASSERT_EQ(c.size(), 4u);
  for (const ContactPoint& p : c) {
    const PolytopeFeature f = ClassifyPolytopeContact(box, above, box, below, p, 1e-6);
    EXPECT_EQ(f.side, VertexSide::kA);
    EXPECT_TRUE(f.near_face_boundary);
  }
  c.clear();  // crossed boxes: four edge–edge contacts plus vertices inside the other's face
  const Isometry3d crossed(Eigen::Translation3d(0.03, 0.02, 0.2005));
  CollideShapes(box, crossed, box, below, 0.002, &c);
  int vertex_face = 0, edge_edge = 0;
  for (const ContactPoint& p : c) {
    const PolytopeFeature f = ClassifyPolytopeContact(box, crossed, box, below, p, 1e-6);
    vertex_face += f.side != VertexSide::kNone;
    edge_edge += f.edge_edge;
    EXPECT_FALSE(f.near_face_boundary);
  }
  EXPECT_EQ(vertex_face, 2);
  EXPECT_EQ(edge_edge, 2);
  EXPECT_EQ(static_cast<int>(c.size()), 4);
}

// Equal boxes crossed (offset, small random tilts, both moving): vertex–face and edge–edge
// contacts, each classified and moved by its closed form, against differences of CollideShapes.
TEST(ContactRateTest, CrossedBoxesVertexFaceAndEdgeEdge) {
  const Shape box = Make(ShapeType::kBox, 0.0, Vector3d(0.1, 0.1, 0.1));
  std::mt19937 gen(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    Moving ma, mb;
    ma.X_WB = Isometry3d::Identity();
    ma.X_WB.linear() = Eigen::AngleAxisd(0.002 * u(gen), Vector3d(u(gen), u(gen), 0.1).normalized())
                           .toRotationMatrix();
    ma.X_WB.translation() = Vector3d(0.03, 0.02, 0.2 + 0.0005);
    mb.X_WB = Isometry3d::Identity();
    ma.X_BS = mb.X_BS = Isometry3d::Identity();
    for (Moving* m : {&ma, &mb}) {
      m->rate.v_W = Vector3d(u(gen), u(gen), u(gen));
      m->rate.w_W = Vector3d(u(gen), u(gen), u(gen));
      m->rate.o_W = m->X_WB.translation();
    }
    std::vector<ContactPoint> c0, cp, cm;
    CollideShapes(box, ma.ShapeAt(0.0), box, mb.ShapeAt(0.0), 0.002, &c0);
    CollideShapes(box, ma.ShapeAt(kStep), box, mb.ShapeAt(kStep), 0.002, &cp);
    CollideShapes(box, ma.ShapeAt(-kStep), box, mb.ShapeAt(-kStep), 0.002, &cm);
    ASSERT_EQ(cp.size(), c0.size());
    ASSERT_EQ(cm.size(), c0.size());
    int edge_edge = 0;
    for (std::size_t i = 0; i < c0.size(); ++i) {
      const PolytopeFeature f =
          ClassifyPolytopeContact(box, ma.ShapeAt(0.0), box, mb.ShapeAt(0.0), c0[i], 1e-6);
      ContactPointRate d;
      ASSERT_TRUE(VertexFaceRate(f.side, c0[i], ma.rate, mb.rate, &d) ||
                  EdgeEdgeRate(f, c0[i], ma.rate, mb.rate, &d))
          << "contact " << i << " has a closed form";
      edge_edge += f.edge_edge;
      const auto fd = [&](const Vector3d& p, const Vector3d& m) { return (p - m) / (2 * kStep); };
      EXPECT_LE((d.p_A_W - fd(cp[i].p_A_W, cm[i].p_A_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.p_B_W - fd(cp[i].p_B_W, cm[i].p_B_W)).norm(), kTol) << "trial " << trial;
      EXPECT_LE((d.n_W - fd(cp[i].n_W, cm[i].n_W)).norm(), kTol) << "trial " << trial;
      EXPECT_NEAR(d.gap, (cp[i].gap - cm[i].gap) / (2 * kStep), kTol) << "trial " << trial;
    }
    EXPECT_EQ(edge_edge, 2) << "trial " << trial;
  }
}

}  // namespace
}  // namespace vinci::sim
