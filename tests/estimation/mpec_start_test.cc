// The MPEC estimator started from a simulation (MpecOptions::start_theta, start_states) and
// from a least-squares fit (MpecOptions::least_squares_start): the guess is the model's rollout,
// feasible at the start; the rollout's active set is solved as one NLP and kept only if its χ²
// fits the stated noise and its parameters' standard errors are small against their values, else
// the estimation restarts from the log's poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using sim::VectorXd;

constexpr double kTrueMu = 0.3;

// A noisy log (1 mm): the rollout from the true initial state at the true μ satisfies every step
// equation and complementarity pair, where the log's poses violate them; θ starts at start_theta.
TEST(MpecStart, SimulatedStartIsFeasible) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.3, 1, 1e-3, 5, "mpec_start_noisy.csv");
  const Log log = ReadLog({path}, sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  o.start_theta = VectorXd::Constant(1, kTrueMu);
  o.start_states = {sim.InitialState()};
  const MpecEstimationProblem problem(sim, log, o, 1e-3);
  EXPECT_DOUBLE_EQ(problem.Parameters(problem.StartingPoint())[0], kTrueMu);
  double constraints = 0.0, pairs = 0.0;
  testing::StartViolation(problem, &constraints, &pairs);
  EXPECT_LE(constraints, 1e-9);
  EXPECT_LE(pairs, 1e-12);
}

TEST(MpecStart, LeastSquaresStartRecoversMuOnANoiseFreeLog) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.6, 1, 0.0, 1, "mpec_start_exact.csv");
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-3;
  o.least_squares_start = true;
  const MpecEstimateResult r = EstimateMpec(sim, ReadLog({path}, sim.scene()), o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_TRUE(r.polished);
  EXPECT_TRUE(r.start_kept);
  EXPECT_LE(r.stages, 1) << r.reason;  // the rollout's active set alone (or not even): no homotopy
  EXPECT_NE(r.reason.find("least-squares start"), std::string::npos) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_DOUBLE_EQ(r.initial_values[0], 0.5);  // the scene's, not the fit's
  EXPECT_LE(r.complementarity_violation, 1e-8);
  EXPECT_TRUE(std::isfinite(r.std_errors[0]));
}

// A 10 µm log of the vibrating plate's box (stick–slip twice a cycle, 150 samples): the rollout's
// active set gives the homotopy's answer within its standard error in one NLP. (Before the
// growing horizon kept undetermined parameters, the rough fit ended at μ = 9.1 here, its active
// set's χ² was rejected and the estimation restarted from the log.)
TEST(MpecStart, LeastSquaresStartAgreesWithTheHomotopyOnAStickSlipLog) {
  const sim::Simulator sim(sim::LoadSceneFile(testing::kPlateBoxFile));
  const std::string path =
      testing::SyntheticLog(sim, "box", 0.2, 0.15, 1, 1e-5, 3, "mpec_start_plate.csv");
  const Log log = ReadLog({path}, sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-5;
  const MpecEstimateResult homotopy = EstimateMpec(sim, log, o);
  o.least_squares_start = true;
  const MpecEstimateResult start = EstimateMpec(sim, log, o);
  ASSERT_TRUE(homotopy.converged) << homotopy.reason;
  EXPECT_TRUE(start.converged) << start.reason;
  EXPECT_EQ(start.stages, 1) << start.reason;
  EXPECT_LT(start.iterations, homotopy.iterations / 4);
  EXPECT_NEAR(start.estimates[0], homotopy.estimates[0], homotopy.std_errors[0]) << start.reason;
  EXPECT_NEAR(start.estimates[0], 0.2, 3 * start.std_errors[0]);
}

// A start far from the data (μ = 0.05: the block slides past the log's end) solves its own
// active set with a χ² far above the noise's, so the estimation restarts from the log's poses.
TEST(MpecStart, AStartThatDoesNotFitRestartsFromTheLog) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "mpec_start_far.csv");
  const Log log = ReadLog({path}, sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-3;
  o.start_theta = VectorXd::Constant(1, 0.05);
  o.start_states = {sim.InitialState()};
  const MpecEstimateResult r = EstimateMpec(sim, log, o);
  EXPECT_NE(r.reason.find("restarted from the log's poses"), std::string::npos) << r.reason;
  EXPECT_FALSE(r.start_kept);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
}

// The thesis' particle on the vibrating plate, 50 samples at 0.1 mm: noise large against the
// stick–slip motion, so μ is known to ~10 % and the rollout's contact modes are a guess among
// several that fit (the study measured the start biased low there). The start's standard error
// exceeds 3 % of μ̂, and the result is the homotopy's from the log's poses, to the bit.
TEST(MpecStart, AnUndeterminedParameterRestartsFromTheLog) {
  const sim::Simulator sim(sim::ParseScene(testing::kVibratingPlate, "plate.yaml"));
  const Log log = testing::SampledLog(sim, 0.2, 200, 2, 50, 1e-4, 3);
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-4;
  const MpecEstimateResult homotopy = EstimateMpec(sim, log, o);
  o.least_squares_start = true;
  const MpecEstimateResult r = EstimateMpec(sim, log, o);
  ASSERT_TRUE(homotopy.converged) << homotopy.reason;
  EXPECT_FALSE(r.start_kept);
  EXPECT_NE(r.reason.find("a standard error above 0.03 of its value); "), std::string::npos)
      << r.reason;
  EXPECT_EQ(r.estimates[0], homotopy.estimates[0]) << r.reason;
  EXPECT_EQ(r.std_errors[0], homotopy.std_errors[0]);
  EXPECT_GT(r.iterations, homotopy.iterations);  // the start's NLP counted too
  EXPECT_GT(homotopy.std_errors[0], 0.03 * homotopy.estimates[0]);
  // Without the test the start's solution is kept.
  o.start_max_relative_std_error = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(EstimateMpec(sim, log, o).start_kept);
}

TEST(MpecStart, RejectsInvalidOptions) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.1, 5, 0.0, 1, "mpec_start_bad.csv");
  const Log log = ReadLog({path}, sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  o.least_squares_start = true;
  try {
    o.Validate();
    ADD_FAILURE() << "no noise accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs a stated noise"), std::string::npos) << e.what();
  }
  o.noise_sigma = 1e-3;
  o.episodes = MpecEpisodes::kDecomposed;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.episodes = MpecEpisodes::kJoint;
  o.least_squares_horizon = 1;
  try {
    o.Validate();
    ADD_FAILURE() << "horizon 1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("least_squares_start: "), std::string::npos) << e.what();
  }
  o.least_squares_horizon = 10;
  for (const double bad : {0.0, -1.0, std::nan("")}) {
    o.start_max_relative_std_error = bad;
    EXPECT_THROW(o.Validate(), std::invalid_argument) << bad;
  }
  MpecOptions s;
  s.params = {"mu.default"};
  s.start_theta = VectorXd::Constant(2, 0.3);  // two values for one parameter
  s.start_states = {sim.InitialState()};
  EXPECT_THROW(s.Validate(), std::invalid_argument);
  s.start_theta = VectorXd::Constant(1, 0.3);
  s.start_states = {sim.InitialState(), sim.InitialState()};  // two states for one episode
  EXPECT_THROW(MpecEstimationProblem(sim, log, s, 1e-3), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
