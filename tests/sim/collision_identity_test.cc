// Bitwise identities the contact detection relies on (contact.cc's FindContactsAt takes a box on
// a half-space straight into its lists, and collides once for both lists where the envelope only
// filters): the box–half-space pass against its corner polyhedron, and EnvelopeOnlyFilters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <vector>

#include "collision_test_util.h"
#include "vinci/sim/geometry/shape.h"

namespace vinci::sim {
namespace {

using namespace collision_test;

bool SameBits(const ContactPoint& a, const ContactPoint& b) {
  const auto same = [](const Vector3d& x, const Vector3d& y) {
    return std::memcmp(x.data(), y.data(), 3 * sizeof(double)) == 0;
  };
  return same(a.p_A_W, b.p_A_W) && same(a.p_B_W, b.p_B_W) && same(a.n_W, b.n_W) &&
         std::memcmp(&a.gap, &b.gap, sizeof a.gap) == 0 && a.corner == b.corner;
}

Isometry3d RandomPose(std::mt19937* rng, double spread) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vector3d axis = Xyz(u(*rng), u(*rng), u(*rng)) + Xyz(0, 0, 1e-3);
  return Pose(spread * Xyz(u(*rng), u(*rng), u(*rng)), Rot(3.0 * u(*rng), axis.normalized()));
}

// The box–half-space pass equals the polyhedron pass on the box's eight corners bit for bit.
TEST(CollisionTest, BoxOnHalfSpaceEqualsItsCornerPolyhedronBitForBit) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> size(0.01, 2.0);
  int compared = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Shape box = Box(size(rng), size(rng), size(rng));
    std::vector<Vector3d> corners;
    for (int i = 0; i < 8; ++i) {
      const Vector3d& h = box.half_extents;
      corners.push_back(
          Xyz(i & 1 ? h.x() : -h.x(), i & 2 ? h.y() : -h.y(), i & 4 ? h.z() : -h.z()));
    }
    const Shape poly = Polyhedron(corners, trial % 2 == 0);
    const Isometry3d X_WA = RandomPose(&rng, 1.0), X_WB = RandomPose(&rng, 1.0);
    std::vector<ContactPoint> from_box, from_poly;
    CollideShapes(box, X_WA, HalfSpace(), X_WB, 10.0, &from_box);
    CollideShapes(poly, X_WA, HalfSpace(), X_WB, 10.0, &from_poly);
    ASSERT_EQ(from_box.size(), from_poly.size());
    for (const ContactPoint& c : from_box) {
      const bool found = std::any_of(from_poly.begin(), from_poly.end(),
                                     [&](const ContactPoint& d) { return SameBits(c, d); });
      EXPECT_TRUE(found) << Describe({c});
      compared += found;
    }
  }
  EXPECT_GT(compared, 400);
}

// Where EnvelopeOnlyFilters says so, the contacts at e are those at E > e with gap ≤ e, in order.
TEST(CollisionTest, EnvelopeOnlyFiltersKindsFilterBitForBit) {
  const Shape shapes[] = {Sphere(0.3), Capsule(0.2, 0.5), Box(0.4, 0.3, 0.2),
                          Polyhedron(OctahedronVertices(), true), HalfSpace()};
  EXPECT_FALSE(EnvelopeOnlyFilters(ShapeType::kBox, ShapeType::kBox));
  EXPECT_FALSE(EnvelopeOnlyFilters(ShapeType::kCapsule, ShapeType::kCapsule));
  EXPECT_FALSE(EnvelopeOnlyFilters(ShapeType::kBox, ShapeType::kPolyhedron));
  EXPECT_FALSE(EnvelopeOnlyFilters(ShapeType::kHalfSpace, ShapeType::kHalfSpace));
  EXPECT_FALSE(EnvelopeOnlyFilters(ShapeType::kDisc, ShapeType::kHalfPlane));
  EXPECT_TRUE(EnvelopeOnlyFilters(ShapeType::kHalfSpace, ShapeType::kBox));
  std::mt19937 rng(5);
  int filtered = 0, pairs = 0;
  for (const Shape& a : shapes) {
    for (const Shape& b : shapes) {
      if (!EnvelopeOnlyFilters(a.type, b.type)) continue;
      ++pairs;
      for (int trial = 0; trial < 200; ++trial) {
        const Isometry3d X_WA = RandomPose(&rng, 0.5), X_WB = RandomPose(&rng, 0.5);
        for (const double e : {-0.2, 0.0, 0.05}) {
          std::vector<ContactPoint> at_e, at_big;
          CollideShapes(a, X_WA, b, X_WB, e, &at_e);
          CollideShapes(a, X_WA, b, X_WB, 1.0, &at_big);
          std::vector<ContactPoint> kept;
          for (const ContactPoint& c : at_big)
            if (!(c.gap > e)) kept.push_back(c);
          filtered += at_big.size() - kept.size();
          ASSERT_EQ(at_e.size(), kept.size());
          for (std::size_t k = 0; k < kept.size(); ++k) EXPECT_TRUE(SameBits(at_e[k], kept[k]));
        }
      }
    }
  }
  EXPECT_EQ(pairs, 15);  // sphere with each kind (9 ordered pairs), half-space with 3 kinds (6)
  EXPECT_GT(filtered, 100);
}

}  // namespace
}  // namespace vinci::sim
