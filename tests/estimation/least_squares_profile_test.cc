// Least squares' profile standard errors (LeastSquaresStdErrors::kProfile): the interval where
// the cost, the initial state fitted again at each value, rises by Δχ² = 9, against the
// linearized standard error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {
namespace {

EstimateResult FitMu(const sim::Simulator& sim, const Log& log, double noise, int horizon,
                     LeastSquaresStdErrors std_errors) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = noise;
  o.horizon_samples = horizon;
  o.threads = 2;
  o.std_errors = std_errors;
  return EstimateLeastSquares(sim, log, o);
}

// A block sliding to rest at 0.1 mm (μ = 0.3): the cost is nearly quadratic in μ over a few
// standard errors, so the profile's standard error is the linearized one within 25 %, its
// interval holds μ̂ about symmetrically, and the fit itself is the linearized run's.
TEST(LeastSquaresProfile, MatchesTheLinearizedStandardErrorWhereTheCostIsQuadratic) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", 0.3, 0.6, 5, 1e-4, 21, "profile_block.csv", false);
  const Log log = ReadLog({path}, sim.scene());
  const EstimateResult lin = FitMu(sim, log, 1e-4, 0, LeastSquaresStdErrors::kLinearized);
  const EstimateResult pro = FitMu(sim, log, 1e-4, 0, LeastSquaresStdErrors::kProfile);
  EXPECT_EQ(lin.std_error_method, "");
  EXPECT_EQ(pro.std_error_method, "profile");
  EXPECT_EQ(pro.estimates[0], lin.estimates[0]);
  EXPECT_EQ(pro.final_cost, lin.final_cost);
  EXPECT_EQ(pro.linearized_std_errors[0], lin.std_errors[0]);
  ASSERT_TRUE(std::isfinite(pro.std_errors[0])) << pro.reason;
  EXPECT_NEAR(pro.std_errors[0] / lin.std_errors[0], 1.0, 0.25);
  const double below = pro.estimates[0] - pro.profile_low[0];
  const double above = pro.profile_high[0] - pro.estimates[0];
  EXPECT_NEAR(below / above, 1.0, 0.25);
  EXPECT_NEAR(pro.std_errors[0], std::max(below, above) / 3.0, 1e-9 * pro.std_errors[0]);
  EXPECT_GT(pro.iterations, lin.iterations);  // the profile's fits are counted
  EXPECT_TRUE(pro.converged) << pro.reason;
}

// The box of examples/scenes/plate_disc_planar.yaml on its vibrating plate (μ = 0.3; 0.2 s,
// every 10th 0.2 ms step, 10 µm / 0.1 mrad noise, tests/data/logs/plate_disc_box_seed8.csv),
// fitted with the growing horizon: it sticks and slips, the cost has a kink at μ̂ = 0.30087,
// and the linearized standard error (1.9e-4, the local curvature) puts the truth 4.5 of them
// away. The profile's, 4.0e-4, covers it (Δχ² = 9 interval [0.29967, 0.30168]).
TEST(LeastSquaresProfile, CoversTheTruthWhereAStickSlipKinkMakesTheLinearizedErrorSmall) {
  const sim::Simulator sim(sim::LoadSceneFile(std::string(VINCI_SOURCE_DIR) +
                                              "/examples/scenes/plate_disc_planar.yaml"));
  const Log log = ReadLog(
      {std::string(VINCI_SOURCE_DIR) + "/tests/data/logs/plate_disc_box_seed8.csv"}, sim.scene());
  const EstimateResult r = FitMu(sim, log, 1e-5, 10, LeastSquaresStdErrors::kProfile);
  EXPECT_TRUE(r.converged) << r.reason;
  const double error = std::abs(r.estimates[0] - 0.3);
  EXPECT_GT(error, 3.0 * r.linearized_std_errors[0]);
  EXPECT_LT(error, 3.0 * r.std_errors[0]);
  EXPECT_GT(r.std_errors[0], 1.5 * r.linearized_std_errors[0]);
  EXPECT_LT(r.profile_low[0], 0.3);
  EXPECT_GT(r.profile_high[0], 0.3);
}

// Two parameters, one the log does not determine (the sliding block's mass: friction and
// gravity both scale with it): μ's profile fits the mass at each point (bounds and the held
// component together), the mass's profile reaches neither Δχ² = 9 nor a usable fit near its
// bound 0, so its interval and standard error are NaN, and that is no local minimum.
TEST(LeastSquaresProfile, AnUndeterminedParameterHasNoInterval) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "block", 0.3, 0.6, 5, 1e-4, 21, "profile_block2.csv", false);
  LeastSquaresOptions o;
  o.params = {"mu.default", "mass.block"};
  o.noise_sigma = 1e-4;
  o.threads = 2;
  o.std_errors = LeastSquaresStdErrors::kProfile;
  const EstimateResult r = EstimateLeastSquares(sim, ReadLog({path}, sim.scene()), o);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(std::abs(r.estimates[0] - 0.3), 3.0 * r.std_errors[0]) << r.std_errors[0];
  EXPECT_LT(r.profile_low[0], r.estimates[0]);
  EXPECT_GT(r.profile_high[0], r.estimates[0]);
  EXPECT_TRUE(std::isnan(r.std_errors[1]));
  EXPECT_EQ(r.reason.find("local minimum"), std::string::npos) << r.reason;
}

TEST(LeastSquaresProfile, NotWithMultipleShooting) {
  LeastSquaresOptions o;
  o.params = {"mu.default"};
  o.shooting = Shooting::kMultiple;
  o.std_errors = LeastSquaresStdErrors::kProfile;
  EXPECT_THROW(o.Validate(), std::invalid_argument);
  o.shooting = Shooting::kSingle;
  EXPECT_NO_THROW(o.Validate());
  EXPECT_EQ(ParseLeastSquaresStdErrors("profile"), LeastSquaresStdErrors::kProfile);
  EXPECT_EQ(ParseLeastSquaresStdErrors("linearized"), LeastSquaresStdErrors::kLinearized);
  EXPECT_THROW(ParseLeastSquaresStdErrors("bootstrap"), std::invalid_argument);
  EXPECT_STREQ(ToString(LeastSquaresStdErrors::kProfile), "profile");
}

}  // namespace
}  // namespace vinci::estimation
