// The MPEC estimator's tracking initial guess (MpecOptions::tracking_guess): the states,
// impulses and process noise of a simulation that follows the guessed poses, so that the
// starting point satisfies every step equation and complementarity pair.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using sim::VectorXd;

constexpr double kTrueMu = 0.3;

// A noisy log (1 mm, every step): the guessed poses penetrate the floor and their backward
// differences are far from any step's dynamics; the tracking simulation is feasible.
TEST(MpecTrackingGuess, StartsFeasibleOnANoisyLog) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.3, 1, 1e-3, 5, "mpec_tracking_noisy.csv");
  const Log log = ReadLog({path}, sim.scene());
  MpecOptions o;
  o.params = {"mu.default"};
  double c_guess = 0, p_guess = 0, c_track = 0, p_track = 0;
  testing::StartViolation(MpecEstimationProblem(sim, log, o, 1e-3), &c_guess, &p_guess);
  o.tracking_guess = true;
  testing::StartViolation(MpecEstimationProblem(sim, log, o, 1e-3), &c_track, &p_track);
  EXPECT_GT(c_guess, 1e-2);
  EXPECT_LE(c_track, 1e-6) << "guessed poses: " << c_guess;
  EXPECT_LE(p_track, 1e-6);
}

TEST(MpecTrackingGuess, NoiseFreeBlockRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", kTrueMu, 0.6, 5, 0.0, 1, "mpec_tracking_exact.csv");
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = 1e-3;
  o.tracking_guess = true;
  const MpecEstimateResult r = EstimateMpec(sim, ReadLog({path}, sim.scene()), o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-4) << r.reason;
  EXPECT_TRUE(std::isfinite(r.std_errors[0]));
}

}  // namespace
}  // namespace vinci::estimation
