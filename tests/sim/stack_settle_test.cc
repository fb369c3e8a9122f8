// Statically indeterminate supports (issue 16): a box face resting on a face touches at four
// coplanar corners whose normal impulses are determined only up to a null-space direction. The
// step spreads them over all four (formulations/spread_normals.h), so the next warm-started
// basis holds every corner and a tall stack neither rocks about a diagonal nor pivots.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "box_scenes.h"
#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

// A resting stack of k 0.2 m, 1 kg cubes on a floor (box_stack.yaml's stepper: μ = 0.6,
// n_d = 4, dt = 1 ms, envelope 2 mm); box i's centre at the double 0.1 + 0.2 i written with 17
// significant digits, so the faces touch to within round-off (which excites any free rocking).
Scene StackScene(int k) { return ParseScene(bench::StackYaml(k, 17), "stack_settle_test"); }

// A cube at rest on the plane: by symmetry each corner carries a quarter of the weight,
// p_n = m g h / 4, not Lemke's vertex solution (two diagonal corners at m g h / 2).
TEST(StackSettleTest, RestingBoxCarriedEquallyByItsFourCorners) {
  const Scene scene = StackScene(1);
  const Simulator sim(scene);
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 5);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const double h = scene.options.dt, weight = 1.0 * 9.81 * h;
  for (std::size_t k = 0; k < tr.steps.size(); ++k) {
    ASSERT_EQ(tr.steps[k].contacts, 4);
    const Eigen::VectorXd& z = tr.states[k + 1].warm_start;
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(z[c], weight / 4.0, 1e-9 * weight) << "step " << k << " corner " << c;
  }
}

// 40 cubes (160 contacts): after the first (cold) step every step is a warm-started solve with
// zero pivots, and the tower stays upright (no tilt, no lateral drift, at rest). Before the
// spreading, Lemke carried each cube on two diagonal corners, the round-off tilt about that
// diagonal grew ~9 % a step and from step ~200 on every step pivoted 126–250 times.
TEST(StackSettleTest, FortyBoxStackStaysUprightWithoutPivots) {
  const int k = 40, steps = 400;
  const Scene scene = StackScene(k);
  const Simulator sim(scene);
  const State x0 = sim.InitialState();
  const Trajectory tr = sim.Rollout(sim.DefaultParams(), x0, steps);
  ASSERT_TRUE(tr.ok) << tr.failure;
  int pivoting_steps = 0;
  double worst_gap = 0.0;
  for (std::size_t i = 1; i < tr.steps.size(); ++i) {
    EXPECT_EQ(tr.steps[i].contacts, 4 * k) << "step " << i;
    pivoting_steps += tr.steps[i].solver.iterations > 0;
    worst_gap = std::min(worst_gap, tr.steps[i].min_gap);
  }
  EXPECT_EQ(pivoting_steps, 0);
  // Tolerances: round-off of the rigid solve (positions ~1, impulses ~0.4 N s at the bottom).
  EXPECT_GT(worst_gap, -1e-12);
  const State& x = tr.states.back();
  for (int bi : scene.dynamic_bodies()) {
    const int o = scene.index(bi).q, ov = scene.index(bi).v;
    // Tilt: the quaternion's vector part is sin(θ/2) about the rotation axis.
    EXPECT_LT(x.q.segment<3>(o + 4).norm(), 1e-12) << scene.bodies[bi].name;
    EXPECT_LT(x.q.segment<2>(o).norm(), 1e-12) << scene.bodies[bi].name;  // lateral drift
    EXPECT_LT(x.v.segment<6>(ov).lpNorm<Eigen::Infinity>(), 1e-9) << scene.bodies[bi].name;
  }
}

}  // namespace
}  // namespace vinci::sim
