// The MPEC estimator decomposed by episode (mpec_decomposed.h): on noise-free logs of a planar
// block launched at three speeds it recovers μ, agrees with the joint NLP (the same MPEC: the
// same μ̂ and, the episodes coupling only through μ, the same Laplace standard error), and is
// bitwise the same for any thread count.
#include "vinci/estimation/mpec_decomposed.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "estimation_test_util.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

constexpr double kTrueMu = 0.3;

// The test block (testing::kPlanarBlock, μ = 0.5 in the scene) launched at `speed` (m/s).
std::string BlockAt(double speed) {
  std::string s = testing::kPlanarBlock;
  const std::string from = "velocity: {linear: [1.5, 0]}";
  s.replace(s.find(from), from.size(), "velocity: {linear: [" + std::to_string(speed) + ", 0]}");
  return s;
}

// Three noise-free episodes: the block launched at 1.5, 1.2 and 1.8 m/s, logged every 5th step
// (10 ms) for 0.2–0.3 s (sliding throughout: it stops after v / (μ g) = 0.41–0.61 s), each
// simulated with its own μ (kTrueMu unless given).
Log ThreeEpisodes(const sim::Simulator& model, double sigma = 0.0,
                  std::array<double, 3> mu = {kTrueMu, kTrueMu, kTrueMu}) {
  std::vector<std::string> paths;
  const double speeds[] = {1.5, 1.2, 1.8};
  const double durations[] = {0.3, 0.2, 0.25};
  for (int e = 0; e < 3; ++e) {
    const sim::Simulator truth(sim::ParseScene(BlockAt(speeds[e]), "block.yaml"));
    paths.push_back(testing::SyntheticLog(truth, "block", mu[e], durations[e], 5, sigma, 7 + e,
                                          "mpec_dec_" + std::to_string(e) + ".csv", false));
  }
  return ReadLog(paths, model.scene());
}

MpecOptions Options(MpecEpisodes episodes, int threads = 1, double sigma = 1e-3) {
  MpecOptions o;
  o.params = {"mu.default"};
  o.noise_sigma = sigma;
  o.episodes = episodes;
  o.threads = threads;
  return o;
}

TEST(MpecDecomposed, NoiseFreeEpisodesRecoverMuAndMatchTheJointNlp) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const Log log = ThreeEpisodes(sim);
  const MpecEstimateResult dec = EstimateMpec(sim, log, Options(MpecEpisodes::kDecomposed));
  const MpecEstimateResult joint = EstimateMpec(sim, log, Options(MpecEpisodes::kJoint));
  ASSERT_TRUE(dec.converged) << dec.reason;
  ASSERT_TRUE(joint.converged) << joint.reason;
  EXPECT_EQ(dec.initial_values[0], 0.5);
  EXPECT_NEAR(dec.estimates[0], kTrueMu, 1e-4) << dec.reason;
  // The same MPEC: the same solution to the solvers' tolerances.
  EXPECT_NEAR(dec.estimates[0], joint.estimates[0], 1e-6);
  // Σ_e C_e⁻¹ is the joint Schur complement in θ: the same standard error (to the
  // reduced-Hessian solves' precision).
  ASSERT_TRUE(std::isfinite(dec.std_errors[0]));
  EXPECT_NEAR(dec.std_errors[0], joint.std_errors[0], 1e-3 * joint.std_errors[0]);
  // Noise-free episodes of one μ agree: their gradients at θ̂ vanish, and so does the robust s.e.
  // The joint NLP has none.
  EXPECT_LT(dec.robust_std_errors[0], 1e-2 * dec.std_errors[0]);
  EXPECT_TRUE(std::isnan(joint.robust_std_errors[0]));
  EXPECT_LE(dec.complementarity_violation, 1e-8);
  EXPECT_LE(dec.equality_violation, 1e-8);
  ASSERT_EQ(dec.episodes.size(), 3u);
  for (const EpisodeEstimate& e : dec.episodes) EXPECT_LT(e.rms_residual, 1e-6) << e.file;
  // Sizes: the episodes' problems, θ counted once.
  EXPECT_EQ(dec.num_unknowns, joint.num_unknowns);
  EXPECT_EQ(dec.num_steps, joint.num_steps);
  EXPECT_EQ(dec.num_pairs, joint.num_pairs);
}

// Episodes simulated with different μ (0.28, 0.30, 0.32) but estimated with a shared one: the
// model's standard error (from a stated 10 µm noise) ignores their disagreement, the robust
// one carries it. Its closed form from each episode alone (μ̂_e, s.e._e: f_e ≈ (μ − μ̂_e)² /
// s.e._e², nearly exact for a block sliding throughout, whose positions are linear in μ):
// μ̂ = Σ w_e μ̂_e, w_e ∝ s.e._e⁻², the jackknife C_robust = 2/3 Σ (d_e − d̄)², d_e the shift of
// μ̂ without episode e.
TEST(MpecDecomposed, RobustStandardErrorCarriesTheEpisodesDisagreement) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  const std::array<double, 3> mu = {0.28, 0.30, 0.32};
  const Log log = ThreeEpisodes(sim, 0.0, mu);
  constexpr double kSigma = 1e-5;  // stated: a model s.e. ~100× below the μ's scatter
  const MpecEstimateResult dec =
      EstimateMpec(sim, log, Options(MpecEpisodes::kDecomposed, 1, kSigma));
  ASSERT_TRUE(dec.converged) << dec.reason;
  double sum_w = 0.0, sum_wmu = 0.0;
  std::array<double, 3> mu_e{}, w{};
  for (int e = 0; e < 3; ++e) {
    Log one;
    one.episodes.push_back(log.episodes[e]);
    const MpecEstimateResult alone =
        EstimateMpec(sim, one, Options(MpecEpisodes::kJoint, 1, kSigma));
    ASSERT_TRUE(alone.converged) << alone.reason;
    EXPECT_NEAR(alone.estimates[0], mu[e], 1e-4);
    mu_e[e] = alone.estimates[0];
    w[e] = 1 / (alone.std_errors[0] * alone.std_errors[0]);
    sum_w += w[e];
    sum_wmu += w[e] * mu_e[e];
  }
  const double mu_hat = sum_wmu / sum_w;
  double c = 0.0;
  std::array<double, 3> d{};  // μ̂ without episode e, minus μ̂: w_e / (1 − w_e) (μ̂ − μ̂_e)
  for (int e = 0; e < 3; ++e) d[e] = w[e] / (sum_w - w[e]) * (mu_hat - mu_e[e]);
  const double d_mean = (d[0] + d[1] + d[2]) / 3;
  for (int e = 0; e < 3; ++e) c += 2.0 / 3.0 * std::pow(d[e] - d_mean, 2);
  EXPECT_NEAR(dec.estimates[0], mu_hat, 2e-2 * 0.02);  // measured 1.2 % of the spread
  ASSERT_TRUE(std::isfinite(dec.robust_std_errors[0]));
  EXPECT_NEAR(dec.robust_std_errors[0], std::sqrt(c), 0.02 * std::sqrt(c));  // measured 0.14 %
  EXPECT_GT(dec.robust_std_errors[0], 5 * dec.std_errors[0]);
}

// Episodes whose results are relaxed iterates (here: polish off) get their curvature from
// their profiles (mpec_internal::ProfileCovariance) and later θ from the homotopy's warm-started
// tail: the same μ̂ and standard error as the polished decomposition.
TEST(MpecDecomposed, RelaxedEpisodesUseTheirProfiles) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  Log log = ThreeEpisodes(sim);
  log.episodes.pop_back();
  const auto [polished, relaxed] =
      testing::EstimatePolishedAndRelaxed(sim, log, Options(MpecEpisodes::kDecomposed));
  EXPECT_NEAR(relaxed.estimates[0], kTrueMu, 1e-4) << relaxed.reason;
  ASSERT_TRUE(std::isfinite(relaxed.std_errors[0])) << relaxed.reason;
  EXPECT_NEAR(relaxed.std_errors[0], polished.std_errors[0], 0.1 * polished.std_errors[0]);
  EXPECT_LE(relaxed.complementarity_violation, 1e-6);
}

// With noise the episodes' own estimates differ, so the profile's Newton steps (envelope
// gradients, summed reduced Hessians) must move θ from their weighted mean to the joint optimum.
TEST(MpecDecomposed, NoisyEpisodesReachTheJointOptimum) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  constexpr double kSigma = 1e-4;  // m, positions only
  Log log = ThreeEpisodes(sim, kSigma);
  log.episodes.pop_back();
  const MpecEstimateResult dec =
      EstimateMpec(sim, log, Options(MpecEpisodes::kDecomposed, 1, kSigma));
  const MpecEstimateResult joint = EstimateMpec(sim, log, Options(MpecEpisodes::kJoint, 1, kSigma));
  ASSERT_TRUE(dec.converged) << dec.reason;
  ASSERT_TRUE(joint.converged) << joint.reason;
  ASSERT_TRUE(std::isfinite(joint.std_errors[0]));
  // The same optimum to 1% of a standard error, the same standard error to 1%.
  EXPECT_NEAR(dec.estimates[0], joint.estimates[0], 0.01 * joint.std_errors[0]) << dec.reason;
  EXPECT_NEAR(dec.std_errors[0], joint.std_errors[0], 0.01 * joint.std_errors[0]);
  EXPECT_NEAR(dec.final_cost, joint.final_cost, 1e-3 * joint.final_cost);
}

// Episodes are solved one after the other; each episode's steps are evaluated on `threads`
// threads into disjoint slots: the result is bitwise the same for 1 and 2 threads.
TEST(MpecDecomposed, BitIdenticalForAnyThreadCount) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  Log log = ThreeEpisodes(sim);
  log.episodes.pop_back();
  const MpecEstimateResult a = EstimateMpec(sim, log, Options(MpecEpisodes::kDecomposed, 1));
  const MpecEstimateResult b = EstimateMpec(sim, log, Options(MpecEpisodes::kDecomposed, 2));
  ASSERT_TRUE(a.converged) << a.reason;
  EXPECT_EQ(a.estimates[0], b.estimates[0]);
  EXPECT_EQ(a.std_errors[0], b.std_errors[0]);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.final_cost, b.final_cost);
}

// The first two of ThreeEpisodes (into *log) estimated decomposed with a homotopy that stops at
// ε = epsilon_end without the polish (and without the continuation below it) against
// `tolerance`; the progress lines into *lines.
MpecEstimateResult RelaxedTwoEpisodes(const sim::Simulator& sim, double tolerance, Log* log,
                                      std::vector<std::string>* lines, double epsilon_end = 1e-4) {
  *log = ThreeEpisodes(sim);
  log->episodes.pop_back();
  MpecOptions o = Options(MpecEpisodes::kDecomposed);
  o.solver.polish = false;
  o.solver.epsilon_end = epsilon_end;
  o.solver.epsilon_floor = 0.0;
  o.solver.complementarity_tolerance = tolerance;
  o.progress = [lines](const std::string& l) { lines->push_back(l); };
  return EstimateMpec(sim, *log, o);
}

// An episode whose solution ends above the complementarity tolerance (here every episode: the
// homotopy stops at ε = 1e-4 without the polish, against a tolerance of 1e-12) does not stop
// the outer loop: its relaxed iterate enters the model, θ moves from the scene's 0.5 (no
// episode converged alone, so no weighted mean) to the relaxed problems' optimum, and the
// result says it is not converged, naming the episodes and their violations.
TEST(MpecDecomposed, EpisodesAboveTheToleranceDoNotStopTheOuterLoop) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  Log log;
  std::vector<std::string> lines;
  const MpecEstimateResult r = RelaxedTwoEpisodes(sim, 1e-12, &log, &lines);
  EXPECT_FALSE(r.converged);
  const std::string expect =
      "2 episodes above the complementarity tolerance 1e-12 at the estimate:";
  EXPECT_NE(r.reason.find(expect), std::string::npos) << r.reason;
  EXPECT_NE(r.reason.find(log.episodes[1].file + " ("), std::string::npos) << r.reason;
  EXPECT_EQ(r.reason.find("an episode failed"), std::string::npos) << r.reason;
  EXPECT_EQ(r.reason.find(" 0 Newton steps"), std::string::npos) << r.reason;
  EXPECT_GT(r.complementarity_violation, 1e-12);
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-2) << r.reason;  // the relaxation's bias
  int kept = 0;
  for (const std::string& l : lines)
    kept += l.find("above the complementarity tolerance here") != std::string::npos;
  EXPECT_GE(kept, 4);  // both episodes, at θ_0 and at least one accepted step
}

// A relaxed episode whose warm-started tail ends within 10× the complementarity tolerance is
// kept as it is at each θ of the outer loop (no homotopy from the start after the tail); once
// the loop converges, each such episode is solved again in full at θ̂, once. Two block
// episodes whose homotopy stops at ε = 1e-3 without the polish, against a tolerance of 4e-3:
// alone they end at 5.6e-3 … 5.8e-3 (so θ_0 is the scene's 0.5), their tails along the run at
// 2.1e-2 … 2.2e-2, within 10× the tolerance. These violations depend on the solver's warm-start
// pushes and differ between CPUs in their second digit, so the tolerance keeps a margin of
// ≥ 40 % on each side. (Stopping at ε = 1e-4 instead, as before session 32, left a window of
// 5 % between the alone runs and the tails/10 at the session's pushes.)
TEST(MpecDecomposed, LooseTailsAreKeptUntilTheFinalPass) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  Log log;
  std::vector<std::string> lines;
  const MpecEstimateResult r = RelaxedTwoEpisodes(sim, 4e-3, &log, &lines, 1e-3);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reason.find("an episode failed"), std::string::npos) << r.reason;
  EXPECT_NEAR(r.estimates[0], kTrueMu, 1e-2) << r.reason;
  // The homotopy from the start: each episode alone, then only in the final pass.
  int from_start = 0, kept = 0, passes = 0, from_start_after = 0;
  std::string all;
  for (const std::string& l : lines) {
    all += l + "\n";
    const bool start = l.rfind("scholtes eps 0.01:", 0) == 0;
    if (passes == 0) {
      from_start += start;
      kept += l.find("above the complementarity tolerance here") != std::string::npos;
    } else {
      from_start_after += start;
    }
    passes += l.find("solved again in full") != std::string::npos;
  }
  EXPECT_EQ(passes, 1) << all;
  EXPECT_EQ(from_start, 2) << all;
  EXPECT_GE(kept, 2) << all;
  EXPECT_GE(from_start_after, 1) << all;
}

// An episode fitting far worse than the others on its own (PoorlyFittingEpisodes; here a log
// with 30× the others' noise) is left out of θ_0 — the weighted mean of the other episodes'
// own estimates, bit for bit that of a run without it — and solved again from its guess there.
TEST(MpecDecomposed, PoorlyFittingEpisodeIsLeftOutOfTheStartAndRestarted) {
  const sim::Simulator sim(sim::ParseScene(testing::kPlanarBlock, "block.yaml"));
  constexpr double kSigma = 1e-4;
  const Log three = ThreeEpisodes(sim, kSigma);
  Log four = three;
  {
    const sim::Simulator truth(sim::ParseScene(BlockAt(1.4), "block.yaml"));
    const std::string path = testing::SyntheticLog(truth, "block", kTrueMu, 0.25, 5, 30 * kSigma,
                                                   11, "mpec_dec_noisy.csv", false);
    four.episodes.push_back(ReadLog({path}, sim.scene()).episodes[0]);
  }
  auto first_theta = [&sim](const Log& log, std::vector<std::string>* lines) {
    MpecOptions o = Options(MpecEpisodes::kDecomposed, 1, kSigma);
    o.progress = [lines](const std::string& l) { lines->push_back(l); };
    EstimateMpec(sim, log, o);
    for (const std::string& l : *lines)
      if (l.rfind("mpec decomposed 0: theta ", 0) == 0) return l.substr(25, l.find(',') - 25);
    return std::string("none");
  };
  std::vector<std::string> lines3, lines4;
  const std::string theta3 = first_theta(three, &lines3);
  const std::string theta4 = first_theta(four, &lines4);
  EXPECT_NE(theta3, "none");
  EXPECT_EQ(theta4, theta3);
  int flagged = 0, restarted = 0;
  for (const std::string& l : lines4) {
    flagged += l.rfind("mpec decomposed: episode 3 alone fits poorly", 0) == 0;
    restarted += l.rfind("mpec decomposed: episode 3 also solved from its guess", 0) == 0;
  }
  EXPECT_EQ(flagged, 1);
  EXPECT_EQ(restarted, 1);
  for (const std::string& l : lines3) EXPECT_EQ(l.find("fits poorly"), std::string::npos) << l;
}

TEST(MpecDecomposed, ParsesTheModeName) {
  EXPECT_EQ(ParseMpecEpisodes("joint"), MpecEpisodes::kJoint);
  EXPECT_EQ(ParseMpecEpisodes("decomposed"), MpecEpisodes::kDecomposed);
  EXPECT_STREQ(ToString(MpecEpisodes::kDecomposed), "decomposed");
  try {
    ParseMpecEpisodes("split");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'split': expected joint or decomposed"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace vinci::estimation
