// The global spread of statically indeterminate normal impulses (spread_normals.h,
// SpreadIndeterminateNormalsGlobally) seen through the simulator: a two-layer pile of 4 × 4
// cubes (bench/box_scenes.h's PileYaml; the upper layer shifted so that each of its cubes rests
// on one to four cubes below) has 260 contacts and a 1560-unknown LCP, so its steps take the
// large plain-contact path. Lemke's answer is a vertex of the solution set: some supporting
// pairs carry no load, and a warm basis made of the loaded contacts alone does not hold every
// normal direction of the pile (the supported cube can rock about the loaded ones; the 100-box
// pile failed a step at t = 0.33 s that way, bench/README.md). After the spread, the loaded
// contacts' normal Jacobian columns must span what all touching contacts' columns span.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <vector>

#include "box_scenes.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

// The normal Jacobian columns of `contacts` (those with use[c]) in a per-body velocity layout
// [linear; angular about the body origin] (rank does not depend on the layout).
Eigen::MatrixXd NormalColumns(const Scene& s, const State& x, const std::vector<Contact>& contacts,
                              const std::vector<char>& use) {
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(x.v.size(), 0);
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    if (!use[c]) continue;
    J.conservativeResize(Eigen::NoChange, J.cols() + 1);
    J.col(J.cols() - 1).setZero();
    const Contact& k = contacts[c];
    const Vector3d n = k.point.n_W;
    const int bodies[2] = {k.body_a, k.body_b};
    const Vector3d points[2] = {k.point.p_A_W, k.point.p_B_W};
    for (int side = 0; side < 2; ++side) {
      const int b = bodies[side];
      if (b < 0 || s.bodies[b].kind != BodyKind::kDynamic) continue;
      const double sign = side == 0 ? 1.0 : -1.0;
      const Vector3d origin = x.q.segment<3>(s.index(b).q);
      J.col(J.cols() - 1).segment<3>(s.index(b).v) = sign * n;
      J.col(J.cols() - 1).segment<3>(s.index(b).v + 3) = sign * (points[side] - origin).cross(n);
    }
  }
  return J;
}

Eigen::Index Rank(const Eigen::MatrixXd& J) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(J);
  qr.setThreshold(1e-9);
  return qr.rank();
}

TEST(PileSpreadTest, LoadedContactsOfATwoLayerPileHoldEveryNormalDirection) {
  const Simulator sim(ParseScene(bench::PileYaml(17, 2, 4), "pile32"));
  const Scene& s = sim.scene();
  const Params params = sim.DefaultParams();
  Workspace ws;
  State x = sim.InitialState(), next;
  double worst_speed = 0.0, worst_gap = 0.0;
  for (int k = 0; k < 100; ++k) {
    const StepInfo info = sim.Step(params, x, StepInput{}, &ws, &next);
    ASSERT_TRUE(info.ok) << "step " << k << ": " << info.failure;
    worst_gap = std::min(worst_gap, info.min_gap);
    const int nc = static_cast<int>(ws.contacts.size());
    // The large (sparse) path: at least 1024 unknowns, [p_n; p_f (4 a contact); σ].
    ASSERT_GE(nc * 6, 1024);
    ASSERT_EQ(next.warm_start.size(), nc * 6);
    if (k == 0 || k == 99) {
      // Every contact touches (the pile starts in exact contact): all of them, and the loaded ones.
      std::vector<char> all(nc, 1), loaded(nc, 0);
      int n_loaded = 0;
      for (int c = 0; c < nc; ++c) {
        loaded[c] = next.warm_start[c] > 0.0;
        n_loaded += loaded[c];
      }
      const Eigen::Index rank_all = Rank(NormalColumns(s, x, ws.contacts, all));
      // 32 cubes: heave, roll and pitch each (the yaw rows of vertical normals vanish).
      EXPECT_EQ(rank_all, 3 * 32);
      EXPECT_EQ(Rank(NormalColumns(s, x, ws.contacts, loaded)), rank_all)
          << "step " << k << ": " << n_loaded << " of " << nc << " contacts loaded";
    }
    std::swap(x, next);
    for (int b : s.dynamic_bodies())
      worst_speed = std::max(worst_speed, x.v.segment<6>(s.index(b).v).norm());
  }
  // At rest in exact contact: round-off speeds and gaps.
  EXPECT_LT(worst_speed, 1e-9);
  EXPECT_GT(worst_gap, -1e-12);
}

}  // namespace
}  // namespace vinci::sim
