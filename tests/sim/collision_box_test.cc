// The box–box narrow phase (sim/src/geometry/collision_box.cc) against the general polytope
// path it replaces (collision_polytope.cc): the same contacts, bit for bit, on random poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "../../sim/src/geometry/collision_internal.h"
#include "vinci/sim/geometry/shape.h"

namespace vinci::sim {
namespace {

using collision_internal::BoxBox;
using collision_internal::Polytope;
using collision_internal::PolytopePolytope;

Matrix3d RandomRotation(std::mt19937_64* rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(*rng), g(*rng), g(*rng), g(*rng));
  q.normalize();
  return q.toRotationMatrix();
}

// A rotation by `angle` about a random axis.
Matrix3d SmallRotation(std::mt19937_64* rng, double angle) {
  std::normal_distribution<double> g(0.0, 1.0);
  const Vector3d axis = Vector3d(g(*rng), g(*rng), g(*rng)).normalized();
  return Eigen::AngleAxisd(angle, axis).toRotationMatrix();
}

// One of the 24 rotations of the cube.
Matrix3d CubeRotation(std::mt19937_64* rng) {
  std::uniform_int_distribution<int> pick(0, 3);
  Matrix3d R = Matrix3d::Identity();
  for (int i = 0; i < 3; ++i)
    R = Eigen::AngleAxisd(0.5 * 3.14159265358979323846 * pick(*rng), Vector3d::Unit(i))
            .toRotationMatrix() *
        R;
  return R.array().round().matrix();  // exact 0 / ±1 entries
}

// Largest separation of the boxes along the 15 SAT axes (> 0: apart; < 0: minus the depth).
double SatSeparation(const Vector3d& h_A, const Isometry3d& X_WA, const Vector3d& h_B,
                     const Isometry3d& X_WB) {
  const Matrix3d& RA = X_WA.linear();
  const Matrix3d& RB = X_WB.linear();
  const Vector3d d = X_WA.translation() - X_WB.translation();
  double best = -1e300;
  const auto axis = [&](const Vector3d& u) {
    const double n = u.norm();
    if (n < 1e-9) return;
    const Vector3d v = u / n;
    const double ra = h_A.dot((RA.transpose() * v).cwiseAbs());
    const double rb = h_B.dot((RB.transpose() * v).cwiseAbs());
    best = std::max(best, std::abs(v.dot(d)) - ra - rb);
  };
  for (int i = 0; i < 3; ++i) {
    axis(RA.col(i));
    axis(RB.col(i));
    for (int j = 0; j < 3; ++j) axis(RA.col(i).cross(RB.col(j)));
  }
  return best;
}

struct Case {
  Vector3d h_A, h_B;
  Isometry3d X_WA, X_WB;
};

// A pose of A against B: A's centre on the ray from B's centre along `u`, at the distance where
// the SAT separation is `target` (bisection).
Isometry3d PlaceAlong(const Vector3d& h_A, const Matrix3d& R_WA, const Vector3d& h_B,
                      const Isometry3d& X_WB, const Vector3d& u, double target) {
  Isometry3d X_WA = Isometry3d::Identity();
  X_WA.linear() = R_WA;
  double lo = 0.0, hi = 2.0 * (h_A.norm() + h_B.norm()) + 1.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    X_WA.translation() = X_WB.translation() + mid * u;
    (SatSeparation(h_A, X_WA, h_B, X_WB) < target ? lo : hi) = mid;
  }
  X_WA.translation() = X_WB.translation() + hi * u;
  return X_WA;
}

std::string Describe(const Case& c) {
  char buf[512];
  std::snprintf(buf, sizeof(buf), "h_A (%g %g %g) h_B (%g %g %g) p_A (%.17g %.17g %.17g)",
                c.h_A.x(), c.h_A.y(), c.h_A.z(), c.h_B.x(), c.h_B.y(), c.h_B.z(),
                c.X_WA.translation().x(), c.X_WA.translation().y(), c.X_WA.translation().z());
  return buf;
}

// Runs both paths; true if they agree bit for bit. Counts the contacts.
bool Agree(const Case& c, double envelope, long* contacts) {
  const Polytope A(c.h_A), B(c.h_B);
  std::vector<ContactPoint> general, box;
  PolytopePolytope(A, c.X_WA, B, c.X_WB, envelope, &general);
  BoxBox(A, c.X_WA, B, c.X_WB, envelope, &box);
  *contacts += static_cast<long>(general.size());
  if (general.size() != box.size()) {
    ADD_FAILURE() << Describe(c) << ": " << general.size() << " vs " << box.size() << " contacts";
    return false;
  }
  for (std::size_t i = 0; i < general.size(); ++i) {
    const ContactPoint& g = general[i];
    const ContactPoint& b = box[i];
    if (g.p_A_W != b.p_A_W || g.p_B_W != b.p_B_W || g.n_W != b.n_W || g.gap != b.gap) {
      ADD_FAILURE() << Describe(c) << ": contact " << i << " differs: gap " << g.gap << " vs "
                    << b.gap << ", n (" << g.n_W.transpose() << ") vs (" << b.n_W.transpose()
                    << ")";
      return false;
    }
  }
  return true;
}

constexpr double kEnvelope = 0.002;
// Separations: touching, penetrating a little, separated within and beyond the envelope.
constexpr double kTargets[] = {0.0,  -1e-9, 1e-9, -1e-6,  1e-6,   -1e-4,
                               1e-4, -1e-3, 1e-3, 1.9e-3, 2.1e-3, -0.01};

TEST(BoxBoxTwin, RandomPosesMatchGeneralPath) {
  std::mt19937_64 rng(20261202);
  std::uniform_real_distribution<double> size(0.05, 0.5), unit(-1.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  long contacts = 0, cases = 0, with_contacts = 0, deep_contacts = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Case c;
    c.h_A = Vector3d(size(rng), size(rng), size(rng));
    c.h_B = trial % 3 == 0 ? c.h_A : Vector3d(size(rng), size(rng), size(rng));
    c.X_WB = Isometry3d::Identity();
    c.X_WB.linear() = RandomRotation(&rng);
    c.X_WB.translation() = Vector3d(unit(rng), unit(rng), unit(rng));
    const Matrix3d R_WA = RandomRotation(&rng);
    const Vector3d u = Vector3d(g(rng), g(rng), g(rng)).normalized();
    for (const double target : kTargets) {
      c.X_WA = PlaceAlong(c.h_A, R_WA, c.h_B, c.X_WB, u, target);
      const long before = contacts;
      ++cases;
      if (!Agree(c, kEnvelope, &contacts)) return;
      with_contacts += contacts > before;
      // The end-of-step penetration check's envelope (−max_penetration), and zero.
      for (const double envelope : {-1e-3, 0.0}) {
        if (!Agree(c, envelope, &deep_contacts)) return;
      }
    }
  }
  // Most poses have contacts (one vertex–face or edge–edge contact for most).
  EXPECT_GT(with_contacts, cases / 2) << with_contacts << " of " << cases;
  EXPECT_GT(contacts, with_contacts);  // some poses have several
  EXPECT_GT(deep_contacts, 0);         // the 1 cm deep poses
}

// Nearly aligned boxes, as in stacks and piles: equal or different sizes, B rotated by a cube
// symmetry, A tilted by 0 to 1e-2 rad, resting on one of B's faces with a sideways offset that is
// zero (corners on corners), small, or large (an edge or corner overhanging), at the separations
// above.
TEST(BoxBoxTwin, NearlyAlignedPosesMatchGeneralPath) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> size(0.05, 0.3), unit(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 5);
  constexpr double kTilts[] = {0.0, 1e-12, 1e-8, 1e-6, 1e-4, 1e-2};
  long contacts = 0, cases = 0, with_contacts = 0;
  for (int trial = 0; trial < 300; ++trial) {
    Case c;
    c.h_B = Vector3d(size(rng), size(rng), size(rng));
    c.h_A = trial % 2 == 0 ? c.h_B : Vector3d(size(rng), size(rng), size(rng));
    c.X_WB = Isometry3d::Identity();
    c.X_WB.linear() = CubeRotation(&rng);
    if (trial % 4 == 1) c.X_WB.translation() = Vector3d(unit(rng), unit(rng), unit(rng));
    const double tilt = kTilts[pick(rng)];
    const Matrix3d R_WA = c.X_WB.linear() * CubeRotation(&rng) * SmallRotation(&rng, tilt);
    const Matrix3d R_BA = c.X_WB.linear().transpose() * R_WA;
    const int face = pick(rng);
    const int k = face / 2;
    const double sign = face % 2 == 0 ? 1.0 : -1.0;
    // Half extent of A along B's axis k (A nearly aligned with B).
    const Vector3d h_A_in_B = (R_BA.cwiseAbs() * c.h_A);
    Vector3d offset = Vector3d::Zero();
    const int mode = trial % 3;
    for (int m = 0; m < 3; ++m) {
      if (m == k) continue;
      if (mode == 1) offset[m] = 1e-3 * unit(rng);
      if (mode == 2) offset[m] = (c.h_B[m] + h_A_in_B[m]) * unit(rng);
    }
    for (const double target : kTargets) {
      Vector3d p_BA = offset;
      p_BA[k] = sign * (c.h_B[k] + h_A_in_B[k] + target);
      c.X_WA = Isometry3d::Identity();
      c.X_WA.linear() = R_WA;
      c.X_WA.translation() = c.X_WB * p_BA;
      const long before = contacts;
      ++cases;
      if (!Agree(c, kEnvelope, &contacts)) return;
      with_contacts += contacts > before;
    }
  }
  EXPECT_GT(with_contacts, cases / 2) << with_contacts << " of " << cases;
}

// The resting stack: equal cubes, corners on corners, faces touching to within round-off.
TEST(BoxBoxTwin, StackedCubesMatchGeneralPath) {
  long contacts = 0;
  for (int i = 1; i < 40; ++i) {
    Case c;
    c.h_A = c.h_B = Vector3d(0.1, 0.1, 0.1);
    c.X_WA = c.X_WB = Isometry3d::Identity();
    c.X_WB.translation() = Vector3d(0.0, 0.0, 0.1 + 0.2 * (i - 1));
    c.X_WA.translation() = Vector3d(1e-7 * (i % 5), -1e-7 * (i % 3), 0.1 + 0.2 * i);
    ASSERT_TRUE(Agree(c, kEnvelope, &contacts));
  }
  EXPECT_GE(contacts, 4 * 39);
}

// Degenerate inputs take the general path: the results still agree.
TEST(BoxBoxTwin, FallbackCasesMatchGeneralPath) {
  long contacts = 0;
  Case c;
  c.h_A = c.h_B = Vector3d(0.1, 0.1, 0.1);
  c.X_WA = c.X_WB = Isometry3d::Identity();
  c.X_WA.translation() = Vector3d(0.0, 0.0, 0.2);
  EXPECT_TRUE(Agree(c, std::numeric_limits<double>::infinity(), &contacts));
  c.h_A = Vector3d(0.1, 0.1, 0.0);  // flat box
  EXPECT_TRUE(Agree(c, kEnvelope, &contacts));
}

}  // namespace
}  // namespace vinci::sim
