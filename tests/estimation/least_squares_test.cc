// Least-squares friction estimation on synthetic logs: exact recovery without noise, honest
// standard errors with noise.
#include "vinci/estimation/least_squares.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "estimation_test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {
namespace {

using testing::SyntheticLog;

constexpr double kTrueMu = 0.3;

TEST(LeastSquares, PlanarBlockNoiseFreeRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  // The block stops at v0 / (μ g) = 0.51 s; the log covers the slide and some rest.
  const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "block_exact.csv");
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  ASSERT_EQ(r.estimates.size(), 1);
  EXPECT_EQ(r.initial_values[0], 0.5);
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_LT(r.episodes[0].rms_residual, 1e-6);
  EXPECT_TRUE(std::isfinite(r.std_errors[0]));
  // The block rests on the floor: a vertical velocity into it is removed by the first step, so
  // that component is held (at least it; the others are estimated).
  EXPECT_GE(r.frozen_state_components, 1);
  EXPECT_EQ(r.num_unknowns + r.frozen_state_components, 1 + 6);
}

TEST(LeastSquares, PlanarBlockKnownInitialStateRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "block_known.csv");
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.estimate_initial_state = false;  // x0 from the first sample; v0 differenced (biased)
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_EQ(r.num_unknowns, 1);
  // Without velocity columns the initial velocity is a finite difference of the first two
  // samples, which the deceleration biases by μ g Δt / 2: μ̂ is close, not exact.
  EXPECT_NEAR(r.estimates[0], kTrueMu, 0.02) << r.reason;
}

TEST(LeastSquares, SpatialBoxNoiseFreeRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  const std::string path = SyntheticLog(sim, "box", kTrueMu, 0.45, 6, 0.0, 1, "box_exact.csv");
  const Log log = ReadLog({path}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_EQ(r.num_unknowns + r.frozen_state_components, 1 + 12);
}

TEST(LeastSquares, SeveralEpisodesShareMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string a = SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "ep_a.csv");
  const std::string b = SyntheticLog(sim, "block", kTrueMu, 0.3, 3, 0.0, 1, "ep_b.csv");
  const Log log = ReadLog({a, b}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.threads = 2;  // results do not depend on it (ThreadCountDoesNotChangeTheBits)
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_EQ(r.num_unknowns + r.frozen_state_components, 1 + 2 * 6);
  EXPECT_EQ(r.episodes.size(), 2u);
}

// Bit-identical results for any thread count (the segments are evaluated in parallel into
// their own storage, and a lone segment's finite-difference columns; Ceres itself runs on one
// thread): several noisy episodes, single and multiple shooting (finite-difference and
// sensitivity Jacobians), one episode by single shooting (its columns in parallel), 1, 2 and 3
// threads, and a repeat of the 2-thread run.
TEST(LeastSquares, ThreadCountDoesNotChangeTheBits) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string a = SyntheticLog(sim, "block", kTrueMu, 0.3, 4, 1e-3, 11, "bits_a.csv", false);
  const std::string b = SyntheticLog(sim, "block", kTrueMu, 0.2, 3, 1e-3, 12, "bits_b.csv", false);
  const Log two = ReadLog({a, b}, sim.scene()), lone = ReadLog({a}, sim.scene());
  const std::tuple<Shooting, LeastSquaresJacobian, const Log*> cases[] = {
      {Shooting::kSingle, LeastSquaresJacobian::kFiniteDifference, &two},
      {Shooting::kMultiple, LeastSquaresJacobian::kFiniteDifference, &two},
      {Shooting::kMultiple, LeastSquaresJacobian::kSensitivity, &two},
      {Shooting::kSingle, LeastSquaresJacobian::kFiniteDifference, &lone}};
  for (const auto& [shooting, jacobian, log_ptr] : cases) {
    const Log& log = *log_ptr;
    auto run = [&, shooting = shooting, jacobian = jacobian](int threads) {
      LeastSquaresOptions o;
      o.params = {"mu.default"};
      o.shooting = shooting;
      o.jacobian = jacobian;
      o.segment_samples = 12;
      o.max_iterations = 8;
      o.threads = threads;
      return EstimateLeastSquares(sim, log, o);
    };
    const EstimateResult one = run(1);
    ASSERT_TRUE(std::isfinite(one.estimates[0])) << one.reason;
    for (int threads : {2, 3, 2}) {  // 2 twice: run to run
      const EstimateResult r = run(threads);
      SCOPED_TRACE(std::string(ToString(shooting)) + ", " + ToString(jacobian) + ", " +
                   std::to_string(log.episodes.size()) + " episode(s), threads " +
                   std::to_string(threads));
      EXPECT_EQ(r.iterations, one.iterations);
      EXPECT_EQ(r.estimates[0], one.estimates[0]);  // bits, not a tolerance
      EXPECT_EQ(r.std_errors[0], one.std_errors[0]);
      EXPECT_EQ(r.final_cost, one.final_cost);
      EXPECT_EQ(r.sigma_residual, one.sigma_residual);
      EXPECT_EQ(r.reason, one.reason);  // including the first failed evaluation, if any
      EXPECT_EQ(r.jacobian_note, one.jacobian_note);
      ASSERT_EQ(r.episodes.size(), one.episodes.size());
      for (size_t e = 0; e < r.episodes.size(); ++e) {
        EXPECT_EQ(r.episodes[e].x0.q, one.episodes[e].x0.q);
        EXPECT_EQ(r.episodes[e].x0.v, one.episodes[e].x0.v);
      }
    }
  }
}

// Log times off the estimator's time grid: a log simulated with dt = 1 ms, sampled at odd
// milliseconds, fitted with the scene's dt = 2 ms (the rollout is interpolated at the logged
// times). The two discretizations differ by O(h): μ̂ within 1% and residuals of a millimetre.
TEST(LeastSquares, LogOffTheSimulationGrid) {
  std::string fine_yaml = testing::kPlanarBlock;
  fine_yaml.replace(fine_yaml.find("dt: 0.002"), 9, "dt: 0.001");
  const sim::Simulator fine(sim::ParseScene(fine_yaml, "fine.yaml"));
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path = SyntheticLog(fine, "block", kTrueMu, 0.6, 7, 0.0, 1, "offgrid.csv");
  const Log log = ReadLog({path}, sim.scene());
  int off_grid = 0;
  for (double t : log.episodes[0].t) off_grid += std::abs(std::remainder(t, 0.002)) > 1e-9;
  ASSERT_GT(off_grid, log.episodes[0].num_samples() / 4);
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  const EstimateResult r = EstimateLeastSquares(sim, log, o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 0.01 * kTrueMu) << r.reason;
  EXPECT_LT(r.episodes[0].rms_residual, 1e-3);
  EXPECT_GT(r.episodes[0].rms_residual, 0.0);
}

TEST(LeastSquares, RejectsParametersItCannotDifferentiate) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log =
      ReadLog({SyntheticLog(sim, "block", kTrueMu, 0.1, 5, 0.0, 1, "short.csv")}, sim.scene());
  LeastSquaresOptions o;
  o.params = {"pose.floor.y"};  // exists, not differentiable
  EXPECT_THROW(EstimateLeastSquares(sim, log, o), std::invalid_argument);
  o.params = {"mu.nothing"};
  EXPECT_THROW(EstimateLeastSquares(sim, log, o), std::invalid_argument);
}

// The studies' tossed cube with a launch (one of 300 seeded draws) on which it lands flat, on
// four corners at once, where the LCP's split of the impulse among them is not unique: a rollout
// whose every step starts cold leaves the simulator's (each step from the last one's solution)
// by 0.6 mm. The estimators' rollout from a state is the simulator's, to the bit, whatever warm
// start the state carries.
TEST(LeastSquares, RollsOutAsTheSimulatorWhereContactIsNotUnique) {
  const sim::Simulator sim(sim::ParseScene(R"(dimension: 3
stepper: {dt: 0.001, duration: 1, friction_directions: 8, envelope: 0.002}
friction: {default: 0.4}
bodies:
  - {name: table, kind: static, shapes: [{type: halfspace}]}
  - name: cube
    mass: 0.1
    pose: {position: [0, 0, 0.12], rotation: {axis: [1, 1, 0], angle: 0.4}}
    velocity:
      linear: [1.0728626146488778, 0.078166178883343373, 0.5]
      angular: [1.9865190092298564, 1.6339941479844851, 5.5263168058665677]
    shapes: [{type: box, half_extents: [0.025, 0.025, 0.025]}]
)",
                                           "toss.yaml"));
  const sim::Params p = sim.DefaultParams();
  const int steps = 700;
  const sim::Trajectory tr = sim.Rollout(p, sim.InitialState(), steps);
  sim::RolloutOptions cold;
  cold.warm_start = sim::WarmStartPolicy::kCold;
  const sim::Trajectory tc =
      sim.Rollout(p, sim.InitialState(), std::vector<sim::StepInput>(steps), cold);
  ASSERT_TRUE(tr.ok && tc.ok);
  const int body = sim.scene().FindBody("cube");
  const int qo = sim.scene().index(body).q;
  double parted = 0.0;
  for (int k = 0; k <= steps; ++k)
    parted =
        std::max(parted, (tr.states[k].q.segment<3>(qo) - tc.states[k].q.segment<3>(qo)).norm());
  ASSERT_GT(parted, 1e-4) << "the cold rollout should leave the simulator's";

  // The noise-free log of every 7th step's pose.
  Episode ep;
  ep.file = "toss";
  BodyTrack& b = ep.bodies.emplace_back();
  b.body = "cube";
  b.body_index = body;
  b.dynamic = true;
  b.has_orientation = true;
  const int samples = steps / 7 + 1;
  b.pose.resize(samples, 7);
  for (int i = 0; i < samples; ++i) {
    ep.t.push_back(tr.states[7 * i].t);
    ep.lines.push_back(i + 2);
    b.pose.row(i) = tr.states[7 * i].q.segment<7>(qo).transpose();
  }
  sim::State x0 = tr.states[0];
  x0.warm_start = tr.states[300].warm_start;  // a stale one: not used
  sim::VectorXd r;
  std::string failure;
  ASSERT_TRUE(EpisodeResiduals(sim, p, ep, x0, 0.1, &r, &failure)) << failure;
  ASSERT_EQ(r.size(), 6 * samples);
  EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-12);
}

}  // namespace
}  // namespace vinci::estimation
