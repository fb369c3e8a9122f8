// State helpers: reading and setting a body's pose and velocity by name (round trips in the
// planar and spatial conventions), the state hash, and bit-identical replays under both
// warm-start policies.
#include "vinci/sim/model/state_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_util.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

constexpr double kRoundTrip = 1e-14;  // a few ulps through the rotation/quaternion conversions

TEST(StateUtilTest, PlanarPoseAndVelocityRoundTrip) {
  const Simulator sim(LoadExample("block_sliding.yaml"));
  const Scene& s = sim.scene();
  ASSERT_EQ(s.dim, Dim::kPlanar);
  State x = sim.InitialState();
  SetPlanarBodyPose(s, "block", 0.3, -0.2, 7.0, &x);  // θ beyond π is kept, not wrapped
  SetBodyVelocity(s, "block", Vector3d(1.5, -0.5, 0.0), Vector3d(0, 0, 2.0), &x);
  const int q = s.index(s.FindBody("block")).q, v = s.index(s.FindBody("block")).v;
  EXPECT_EQ(x.q.segment<3>(q), Vector3d(0.3, -0.2, 7.0));
  EXPECT_EQ(x.v.segment<3>(v), Vector3d(1.5, -0.5, 2.0));
  const BodyKinematics k = GetBodyKinematics(s, x, "block");
  EXPECT_EQ(k.X_WB.translation(), Vector3d(0.3, -0.2, 0.0));
  EXPECT_NEAR(k.X_WB.linear()(1, 0), std::sin(7.0), kRoundTrip);
  EXPECT_EQ(k.v_WB, Vector3d(1.5, -0.5, 0.0));
  EXPECT_EQ(k.w_WB, Vector3d(0, 0, 2.0));
  // Through an Isometry the angle comes back wrapped to (−π, π].
  SetBodyPose(s, "block", PlanarPose(0.1, 0.2, 3.0), &x);
  EXPECT_NEAR(x.q[q + 2], 3.0, kRoundTrip);
}

TEST(StateUtilTest, SpatialPoseAndVelocityRoundTrip) {
  const Simulator sim(LoadExample("box_on_plane.yaml"));
  const Scene& s = sim.scene();
  ASSERT_EQ(s.dim, Dim::kSpatial);
  const std::string body = s.bodies[s.dynamic_bodies()[0]].name;
  State x = sim.InitialState();
  Isometry3d X = Isometry3d::Identity();
  X.translation() = Vector3d(0.4, -0.1, 0.3);
  X.linear() = Eigen::AngleAxisd(1.1, Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  const Vector3d v_W(0.2, -0.3, 0.5), w_W(1.0, -2.0, 0.5);
  SetBodyPose(s, body, X, &x);
  SetBodyVelocity(s, body, v_W, w_W, &x);
  const BodyKinematics k = GetBodyKinematics(s, x, body);
  EXPECT_TRUE(k.X_WB.isApprox(X, kRoundTrip));
  EXPECT_TRUE(k.v_WB.isApprox(v_W, kRoundTrip));
  EXPECT_TRUE(k.w_WB.isApprox(w_W, kRoundTrip));
  // The state holds ν = (v_W, ω_B): the angular part in the body frame.
  const int v = s.index(s.dynamic_bodies()[0]).v;
  EXPECT_TRUE(x.v.segment<3>(v + 3).isApprox(X.linear().transpose() * w_W, kRoundTrip));
  EXPECT_FALSE(x.v.segment<3>(v + 3).isApprox(w_W, 1e-3));  // not the world-frame vector
}

TEST(StateUtilTest, NonDynamicBodiesAndMisuse) {
  const Simulator sim(LoadExample("moving_floor.yaml"));
  const Scene& s = sim.scene();
  int prescribed = -1;
  for (std::size_t i = 0; i < s.bodies.size(); ++i)
    if (s.bodies[i].kind == BodyKind::kPrescribed) prescribed = static_cast<int>(i);
  ASSERT_GE(prescribed, 0);
  const Body& b = s.bodies[prescribed];
  State x = sim.InitialState();
  x.t = 0.37;
  const BodyKinematics k = GetBodyKinematics(s, x, b.name);
  const BodyKinematics e = EvaluateMotion(b.motion, b.X_WB0, s.dim == Dim::kPlanar, 0.37);
  EXPECT_TRUE(k.X_WB.isApprox(e.X_WB, 1e-15));
  EXPECT_TRUE(k.v_WB.isApprox(e.v_WB, 1e-15));
  EXPECT_THROW(SetBodyPose(s, b.name, Isometry3d::Identity(), &x), std::invalid_argument);
  try {
    GetBodyKinematics(s, x, "nobody");
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find(b.name), std::string::npos)
        << error.what();  // lists names
  }
  State wrong;
  EXPECT_THROW(SetBodyVelocity(s, s.bodies[s.dynamic_bodies()[0]].name, Vector3d::Zero(),
                               Vector3d::Zero(), &wrong),
               std::invalid_argument);
}

TEST(StateUtilTest, HashIsBitwise) {
  State a;
  a.t = 0.5;
  a.q = VectorXd::LinSpaced(7, 0.0, 1.0);
  a.v = VectorXd::Ones(6);
  State b = a;
  EXPECT_EQ(StateHash(a), StateHash(b));
  b.q[3] = std::nextafter(b.q[3], 2.0);  // one ulp
  EXPECT_NE(StateHash(a), StateHash(b));
  b = a;
  b.q[0] = -0.0;  // numerically equal, bitwise different
  EXPECT_NE(StateHash(a), StateHash(b));
  b = a;
  b.warm_start = VectorXd::Zero(0);
  EXPECT_EQ(StateHash(a), StateHash(b));
  b.warm_start = VectorXd::Zero(1);
  EXPECT_NE(StateHash(a), StateHash(b));
  // Sizes are hashed: moving an entry from q to v changes the hash.
  b = a;
  b.q.conservativeResize(6);
  b.v.conservativeResize(7);
  b.v << a.q[6], a.v;
  EXPECT_NE(StateHash(a), StateHash(b));
  // Stable across runs and platforms: FNV-1a of the documented byte sequence (t, |q|, q, |v|,
  // |warm_start|, each 8 bytes little-endian), computed independently (Python struct + FNV-1a).
  State one;
  one.t = 0.5;
  one.q = VectorXd::Ones(1);
  EXPECT_EQ(StateHash(one), 0x680ae506ebd52fb4ull);
}

std::vector<std::uint64_t> Hashes(const Trajectory& t) {
  std::vector<std::uint64_t> h;
  for (const State& x : t.states) h.push_back(StateHash(x));
  return h;
}

// A replayed plan is bit-identical: from a stored state (carrying its warm start) under kKeep,
// and from (t, q, v) alone under kCold.
TEST(StateUtilTest, ReplayIsBitIdentical) {
  const Simulator sim(LoadExample("box_stack.yaml"));
  const Params p = sim.DefaultParams();
  constexpr int kSteps = 60, kSplit = 30;
  const std::vector<StepInput> inputs(kSteps);
  for (WarmStartPolicy policy : {WarmStartPolicy::kKeep, WarmStartPolicy::kCold}) {
    RolloutOptions o;
    o.warm_start = policy;
    const Trajectory full = sim.Rollout(p, sim.InitialState(), inputs, o);
    ASSERT_TRUE(full.ok) << full.failure;
    ASSERT_GT(full.states[kSplit].warm_start.size(), 0);  // the stack is in contact
    const Trajectory again = sim.Rollout(p, sim.InitialState(), inputs, o);
    EXPECT_EQ(Hashes(full), Hashes(again));
    // Continue from the stored state at kSplit.
    const std::vector<StepInput> rest(kSteps - kSplit);
    const Trajectory tail = sim.Rollout(p, full.states[kSplit], rest, o);
    ASSERT_TRUE(tail.ok);
    for (int k = 0; k <= kSteps - kSplit; ++k)
      ASSERT_EQ(StateHash(tail.states[k]), StateHash(full.states[kSplit + k])) << k;
    if (policy == WarmStartPolicy::kCold) {
      // Cold: the warm start carried by the state does not matter.
      State bare = full.states[kSplit];
      bare.warm_start.resize(0);
      const Trajectory from_bare = sim.Rollout(p, bare, rest, o);
      ASSERT_TRUE(from_bare.ok);
      for (int k = 1; k <= kSteps - kSplit; ++k)
        ASSERT_EQ(StateHash(from_bare.states[k]), StateHash(full.states[kSplit + k])) << k;
    }
  }
}

}  // namespace
}  // namespace vinci::sim
