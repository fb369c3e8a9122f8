// The forward step derivative on the step LCP's basis (SensitivityOptions::lcp_basis,
// sim/src/simulator/sensitivity_lcp_basis.h) against the general path (the whole step system's
// linearization) on the same steps: the same columns to the central differences' error, the
// same status, and the general path wherever the basis does not apply.
#include <gtest/gtest.h>

#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;

struct Case {
  std::string name;
  Scene scene;
  std::vector<std::string> params;
  int steps;
  int min_on_basis;  // steps the basis must have taken at least
};

// A ball sliding and spinning on a floor (spatial, one contact, 8 friction directions): it slides
// for the whole window (slip 1.2 m/s, μ g = 4.9 m/s²: > 0.2 s to rolling); its spin exercises the
// quaternion block. After ~75 steps the slip has turned onto the normal of a facet of the
// linearized cone, where two friction directions tie (one of them unloaded: a degenerate pair,
// the general path's).
Scene SlidingBall() {
  return ParseScene(R"(
name: sliding-ball
dimension: 3
gravity: [0, 0, -9.81]
stepper: {dt: 0.001, friction_directions: 8, envelope: 0.002}
friction: {default: 0.5}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfspace}]
  - name: ball
    mass: 1.0
    pose: {position: [0, 0, 0.1]}
    velocity: {linear: [1.0, 0.3, 0], angular: [2.0, -1.0, 5.0]}
    shapes: [{type: sphere, radius: 0.1}]
)",
                    "sliding_ball");
}

// block_on_incline.yaml with μ = 0.5 > tan 0.3: the block stays, held by friction.
Scene BlockHeldOnIncline() {
  std::ifstream in(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/block_on_incline.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string from = "friction: {default: 0.2}";
  yaml.replace(yaml.find(from), from.size(), "friction: {default: 0.5}");
  return ParseScene(yaml, "block_held_on_incline");
}

Scene WithFormulation(Scene s, FormulationType f) {
  s.options.formulation = f;
  return s;
}

std::vector<Case> Cases() {
  return {
      // Slides for 509 steps, then sticks on its two corners (degenerate pairs, two-sided).
      {"block_sliding", LoadExample("block_sliding.yaml"), {"mu.default"}, 600, 400},
      {"block_sliding_anitescu_potra",
       WithFormulation(LoadExample("block_sliding.yaml"), FormulationType::kAnitescuPotra),
       {"mu.default"},
       300,
       250},
      {"plate_disc_planar", LoadExample("plate_disc_planar.yaml"), {"mu.default"}, 400, 100},
      {"sliding_ball", SlidingBall(), {"mu.default"}, 150, 70},
      {"first_order_push", LoadExample("first_order_push.yaml"), {"mu.default"}, 150, 50},
      // Sticking contacts: a rolling sphere (one contact, spatial); a box resting on four
      // redundant corners (singular M_BB).
      {"sphere_on_incline", LoadExample("sphere_on_incline.yaml"), {"mu.default"}, 300, 280},
      {"box_on_plane", LoadExample("box_on_plane.yaml"), {"mu.default"}, 300, 290},
      // Held on an incline by friction on four redundant corners: the solver's split puts a
      // corner at its cone's edge (σ = 0 = w_σ), where only a move inside the set of splits (the
      // general path's interior shift) shows that the block keeps sticking.
      {"block_held_on_incline", BlockHeldOnIncline(), {"mu.default"}, 300, 0},
      // Sliding on four redundant corners, one left unloaded by the solver: the split moves the
      // velocities (each corner's friction acts at its own point), the general path's.
      {"block_on_incline", LoadExample("block_on_incline.yaml"), {"mu.default"}, 300, 0},
      // Flush boxes: contacts at a feature switch, the general path's.
      {"box_stack", LoadExample("box_stack.yaml"), {"mu.default"}, 100, 0},
      // Parts on moving supports: a tripod on a vibrating plate (spatial), a planar block on a
      // floor oscillating under it (slips and rides along in turn).
      {"plate_tripod", LoadExample("plate_tripod.yaml"), {"mu.default"}, 300, 150},
      {"moving_floor", LoadExample("moving_floor.yaml"), {"mu.default"}, 300, 250},
      // A mass is not a friction coefficient: always the general path.
      {"block_sliding_mass", LoadExample("block_sliding.yaml"), {"mass.block"}, 100, 0},
  };
}

// The case's scene, its default parameters and selection, and its rollout.
class LcpBasisTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    c_ = std::make_unique<Case>(Cases()[static_cast<std::size_t>(GetParam())]);
    sim_ = std::make_unique<Simulator>(c_->scene);
    p_ = sim_->DefaultParams();
    sel_ = std::make_unique<ParamSelection>(sim_->scene().param_table(), c_->params);
    tr_ = sim_->Rollout(p_, sim_->InitialState(), c_->steps);
  }
  std::unique_ptr<Case> c_;
  std::unique_ptr<Simulator> sim_;
  Params p_;
  std::unique_ptr<ParamSelection> sel_;
  Trajectory tr_;
};

// Along a rollout, each step's PropagateStep with two columns — the parameter's, carrying a
// random sensitivity, and a random state direction — on the basis and by the general path.
TEST_P(LcpBasisTest, MatchesTheGeneralPath) {
  const Case& c = *c_;
  const Simulator& sim = *sim_;
  const Trajectory& tr = tr_;
  SCOPED_TRACE(c.name);
  ASSERT_TRUE(tr.ok) << tr.failure;
  const int nx = static_cast<int>(tr.states[0].q.size() + tr.states[0].v.size());
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  SensitivityOptions general;
  general.lcp_basis = false;
  int on_basis = 0, exact = 0;
  double worst = 0.0;
  for (int k = 0; k < c.steps; ++k) {
    MatrixXd S(nx, 2);
    for (int i = 0; i < S.size(); ++i) S.data()[i] = normal(rng);
    S.col(0) *= 1e-3;  // a carried ∂x/∂μ is small
    MatrixXd fast, slow;
    Workspace ws;
    State next;
    ASSERT_TRUE(sim.Step(p_, tr.states[k], {}, &ws, &next).ok);
    const StepSensitivity a =
        PropagateStep(sim, p_, *sel_, tr.states[k], {}, next, S, &fast, {}, &ws);
    const StepSensitivity b =
        PropagateStep(sim, p_, *sel_, tr.states[k], {}, next, S, &slow, general, &ws);
    EXPECT_FALSE(b.on_lcp_basis);
    on_basis += a.on_lcp_basis;
    exact += a.on_lcp_basis && a.status == SensitivityStatus::kExact;
    EXPECT_EQ(a.status, b.status) << "step " << k << ": " << a.message << " / " << b.message;
    EXPECT_EQ(a.contact_set_changed, b.contact_set_changed) << "step " << k;
    if (!a.on_lcp_basis) {
      // The general path's own result, bit for bit.
      EXPECT_TRUE(fast.isApprox(slow, 0.0) || (fast - slow).cwiseAbs().maxCoeff() == 0.0)
          << "step " << k;
      EXPECT_EQ(a.message, b.message) << "step " << k;
      continue;
    }
    EXPECT_EQ(a.degenerate_pairs, b.degenerate_pairs) << "step " << k;
    for (int j = 0; j < 2; ++j) {
      const double scale = slow.col(j).cwiseAbs().maxCoeff();
      const double err = (fast.col(j) - slow.col(j)).cwiseAbs().maxCoeff();
      worst = std::max(worst, err / std::max(scale, 1e-300));
      EXPECT_LE(err, 1e-6 * scale)
          << "step " << k << " column " << j << "\nbasis   " << fast.col(j).transpose()
          << "\ngeneral " << slow.col(j).transpose();
    }
  }
  std::printf("%s: %d of %d steps on the LCP basis (%d exact), worst relative difference %.2e\n",
              c.name.c_str(), on_basis, c.steps, exact, worst);
  EXPECT_GE(on_basis, c.min_on_basis);
  if (c.min_on_basis == 0) {
    EXPECT_EQ(on_basis, 0);
  }
}

// StepDerivatives on the basis (the parameters' columns without a carried sensitivity, and the
// state Jacobian's unit directions) against the general path, every third step: the same
// columns to the central differences' error, the same status.
TEST_P(LcpBasisTest, StepDerivativesMatchTheGeneralPath) {
  const Case& c = *c_;
  const Simulator& sim = *sim_;
  const Trajectory& tr = tr_;
  SCOPED_TRACE(c.name);
  ASSERT_TRUE(tr.ok) << tr.failure;
  SensitivityOptions general;
  general.lcp_basis = false;
  int on_basis = 0, state_on_basis = 0, steps = 0;
  double worst = 0.0;
  // A column's scale at least `floor`: a zero column is zero up to the central differences'
  // round-off. ∂x_ℓ+1/∂x_ℓ is near the identity: its round-off is ~1e-9 absolute (both paths
  // difference at a relative step of 1e-7, a quaternion at its own), hence floor 1e-2 for d_x.
  const auto compare = [&](const MatrixXd& fast, const MatrixXd& slow, int k, const char* what,
                           double floor) {
    ASSERT_EQ(fast.rows(), slow.rows());
    ASSERT_EQ(fast.cols(), slow.cols());
    for (int j = 0; j < slow.cols(); ++j) {
      const double scale = std::max(slow.col(j).cwiseAbs().maxCoeff(), floor);
      const double err = (fast.col(j) - slow.col(j)).cwiseAbs().maxCoeff();
      worst = std::max(worst, err / std::max(scale, 1e-300));
      EXPECT_LE(err, 1e-6 * scale)
          << "step " << k << " " << what << " column " << j << "\nbasis   "
          << fast.col(j).transpose() << "\ngeneral " << slow.col(j).transpose();
    }
  };
  for (int k = 0; k < c.steps; k += 3) {
    ++steps;
    for (bool with_state : {false, true}) {
      Workspace ws;
      State next;
      ASSERT_TRUE(sim.Step(p_, tr.states[k], {}, &ws, &next).ok);
      const StepSensitivity a =
          StepDerivatives(sim, p_, *sel_, tr.states[k], {}, next, with_state, {}, &ws);
      const StepSensitivity b =
          StepDerivatives(sim, p_, *sel_, tr.states[k], {}, next, with_state, general, &ws);
      EXPECT_FALSE(b.on_lcp_basis);
      EXPECT_EQ(a.status, b.status) << "step " << k << ": " << a.message << " / " << b.message;
      EXPECT_EQ(a.contact_set_changed, b.contact_set_changed) << "step " << k;
      EXPECT_EQ(a.d_x.size(), b.d_x.size()) << "step " << k;
      if (!a.on_lcp_basis) {
        EXPECT_EQ(a.message, b.message) << "step " << k;
        EXPECT_EQ((a.d_theta - b.d_theta).cwiseAbs().maxCoeff(), 0.0) << "step " << k;
        continue;
      }
      (with_state ? state_on_basis : on_basis) += 1;
      EXPECT_EQ(a.degenerate_pairs, b.degenerate_pairs) << "step " << k;
      compare(a.d_theta, b.d_theta, k, "d_theta", 1e-9 * b.d_theta.cwiseAbs().maxCoeff());
      if (with_state) compare(a.d_x, b.d_x, k, "d_x", 1e-2);
    }
  }
  std::printf(
      "%s: StepDerivatives on the LCP basis at %d (with the state Jacobian %d) of %d "
      "steps, worst relative difference %.2e\n",
      c.name.c_str(), on_basis, state_on_basis, steps, worst);
  if (c.min_on_basis == 0) {
    EXPECT_EQ(on_basis, 0);
  } else {
    EXPECT_GE(on_basis, c.min_on_basis / 3);
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, LcpBasisTest,
                         ::testing::Range(0, static_cast<int>(Cases().size())),
                         [](const ::testing::TestParamInfo<int>& param) {
                           return Cases()[static_cast<std::size_t>(param.param)].name;
                         });

// A rollout's forward sensitivity through the steps on the basis (RolloutForward, the sliding
// ball: its first ~75 steps, then the general path) equals the general path's, and both count the
// same exact steps (SensitivityTest.SlidingBlockForwardModeMatchesClosedForm checks the closed form
// of the sliding block with the default options, i.e. on the basis).
TEST(LcpBasis, RolloutMatchesTheGeneralPath) {
  const Simulator sim(SlidingBall());
  const Params p = sim.DefaultParams();
  const ParamSelection sel(sim.scene().param_table(), {"mu.default"});
  constexpr int kSteps = 150;
  SensitivityOptions general;
  general.lcp_basis = false;
  const RolloutSensitivity fast =
      RolloutForward(sim, p, sel, sim.InitialState(), std::vector<StepInput>(kSteps), false);
  const RolloutSensitivity slow = RolloutForward(sim, p, sel, sim.InitialState(),
                                                 std::vector<StepInput>(kSteps), false, general);
  ASSERT_TRUE(fast.trajectory.ok) << fast.trajectory.failure;
  ASSERT_EQ(fast.d_state.size(), slow.d_state.size());
  int on_basis = 0;
  for (const StepSensitivity& st : fast.steps) on_basis += st.on_lcp_basis;
  EXPECT_GE(on_basis, 70);
  EXPECT_EQ(fast.exact_steps, slow.exact_steps);
  const MatrixXd& a = fast.d_state.back();
  const MatrixXd& b = slow.d_state.back();
  for (int j = 0; j < b.cols(); ++j)
    EXPECT_LE((a.col(j) - b.col(j)).cwiseAbs().maxCoeff(),
              1e-6 * std::max(1e-12, b.col(j).cwiseAbs().maxCoeff()))
        << "column " << j;
}

}  // namespace
}  // namespace vinci::sim
