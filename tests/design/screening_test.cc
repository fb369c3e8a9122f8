// Hierarchical screening (screening.h) and the margin tie-break of success objectives
// (evaluate.h), on a block that slides along a floor into a wall whose position within its body
// (pose.stops.wall.x) is designed: the block rests against the wall's face at x = wall.x − 0.05,
// and a wall placed over the block's start overlaps it.
#include "vinci/design/screening.h"

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "vinci/design/optimize.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

DesignSpec Spec(const std::string& lower, const std::string& upper, const std::string& region,
                const std::string& screening) {
  return ParseDesignSpec(
      "scene: block_stop.yaml\n"
      "parameters: [{name: pose.stops.wall.x, lower: " +
          lower + ", upper: " + upper +
          "}]\n"
          "uncertain: [{name: initial.block.vx, uniform: [0.9, 1.1]}]\n"
          "samples: 4\nvalidation_samples: 4\nduration: 1.0\n"
          "objective: {type: success, body: block, region: " +
          region + "}\n" + screening,
      "screening.yaml", kData);
}

const char* kStages =
    "screening:\n"
    "  - {type: geometric}\n"
    // By 0.25 s a free block has passed x = 0.1; a wall closer than that stops it before.
    "  - {type: short, duration: 0.25, samples: 2, min_success: 1.0,\n"
    "     objective: {type: success, body: block, region: {min: [0.1, -1], max: [1, 1]}}}\n";

// The geometric stage rejects a wall over the block's start without simulating (the block
// spans −0.05 < x < 0.05, the wall is 0.02 wide: −0.07 < wall.x < 0.05); the short stage rejects
// a wall that stops the block before x = 0.1 (wall.x < 0.15).
TEST(DesignScreening, StagesRejectOverlapAndEarlyStops) {
  const DesignSpec spec = Spec("-0.1", "0.4", "{min: [0.2, -1], max: [0.3, 1]}", kStages);
  ASSERT_EQ(spec.screening.size(), 2u);
  const DesignProblem problem(spec);
  Screener screener(spec, problem, 2);
  const std::map<double, int> expected = {{-0.09, -1}, {-0.06, 0}, {0.0, 0},   {0.04, 0},
                                          {0.06, 1},   {0.14, 1},  {0.16, -1}, {0.3, -1}};
  for (const auto& [x, stage] : expected)
    EXPECT_EQ(screener.Screen(VectorXd::Constant(1, x), spec.seed), stage) << "wall.x = " << x;
  const std::vector<StageReport> rows = screener.Report();
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].stage, "geometric");
  EXPECT_EQ(rows[0].candidates_in, 8);
  EXPECT_EQ(rows[0].candidates_out, 5);
  EXPECT_EQ(rows[0].simulations, 0);
  EXPECT_EQ(rows[1].candidates_in, 5);
  EXPECT_EQ(rows[1].candidates_out, 3);
  EXPECT_EQ(rows[1].simulations, 5 * 2);
  const Evaluation r = screener.Rejected(VectorXd::Constant(1, 0.0), spec.seed, 4, 0);
  EXPECT_EQ(r.objective, 0.0);
  EXPECT_EQ(r.loss, 3.0);  // worse than any simulated loss (< 1 + 1/S), worst for stage 0
}

// A search with screening: the counts add up (each stage's output is the next one's input, the
// rejected candidates are the history's screened rows, the full row the simulated ones), the
// rollouts add up to `simulations`, and the result does not depend on the thread count.
TEST(DesignScreening, SearchCountsAddUpAndAreThreadIndependent) {
  const DesignSpec spec = Spec("-0.1", "0.4", "{min: [0.2, -1], max: [0.3, 1]}", kStages);
  std::vector<std::string> phases[2];
  DesignResult result[2];
  for (int threads : {1, 2}) {
    JobOptions options;
    options.threads = threads;
    options.optimizer = "direct-l+sbplx";
    options.budget = 4 * 24;
    options.on_evaluation = [&](const HistoryEntry& h, const Progress&) {
      if (!h.replayed)
        phases[threads - 1].push_back(h.phase);  // a revisited point is not
                                                 // screened again
      return true;
    };
    result[threads - 1] = RunDesign(spec, options);
  }
  const DesignResult& r = result[0];
  ASSERT_TRUE(r.errors.empty()) << r.errors[0];
  ASSERT_EQ(r.screening.size(), 3u);
  int screened[2] = {0, 0}, full = 0;
  for (const std::string& p : phases[0]) {
    screened[0] += p == "screened-geometric";
    screened[1] += p == "screened-short";
    full += p == "start" || p == "global" || p == "local";
  }
  EXPECT_GT(screened[0], 0);
  EXPECT_GT(screened[1], 0);
  EXPECT_EQ(r.screening[0].candidates_in, screened[0] + screened[1] + full);
  EXPECT_EQ(r.screening[0].candidates_in - r.screening[0].candidates_out, screened[0]);
  EXPECT_EQ(r.screening[1].candidates_in, r.screening[0].candidates_out);
  EXPECT_EQ(r.screening[1].candidates_in - r.screening[1].candidates_out, screened[1]);
  EXPECT_EQ(r.screening[2].stage, "full");
  EXPECT_EQ(r.screening[2].candidates_in, r.screening[1].candidates_out);
  EXPECT_EQ(r.screening[2].candidates_in, full);
  EXPECT_EQ(r.screening[2].simulations, 4LL * full);
  EXPECT_EQ(r.simulations, r.screening[1].simulations + r.screening[2].simulations + 2 * 4);
  // The best design is a simulated one that delivers every sample.
  EXPECT_EQ(r.best_search.objective, 1.0);
  EXPECT_GT(r.best[0], 0.25);
  EXPECT_LT(r.best[0], 0.35);
  // 1 vs 2 threads: the same search.
  EXPECT_EQ(phases[0], phases[1]);
  EXPECT_EQ(result[1].best, r.best);
  EXPECT_EQ(result[1].best_search.loss, r.best_search.loss);
  for (std::size_t k = 0; k < r.screening.size(); ++k) {
    EXPECT_EQ(result[1].screening[k].candidates_out, r.screening[k].candidates_out);
    EXPECT_EQ(result[1].screening[k].simulations, r.screening[k].simulations);
  }
}

// Ties on the success rate are broken by the mean margin: every wall in [0.2, 0.36] delivers
// every sample into x ∈ [0.15, 0.35] (the block rests at wall.x − 0.05), and the most robust
// design puts it in the middle (wall.x = 0.30). Without the tie-break every design would tie
// with the start and the start would stay the best.
TEST(DesignScreening, TiesOnTheRateAreBrokenByTheMargin) {
  // The start (0.21) delivers every sample too, near the edge: the tie-break must leave it.
  const DesignSpec spec = Spec("0.2", "0.36, start: 0.21", "{min: [0.15, -1], max: [0.35, 1]}", "");
  const DesignProblem problem(spec);
  ThreadEvaluator evaluator(problem, 2);
  const std::vector<Evaluation> e = evaluator.Evaluate({{VectorXd::Constant(1, 0.22), 1, 4},
                                                        {VectorXd::Constant(1, 0.26), 1, 4},
                                                        {VectorXd::Constant(1, 0.30), 1, 4}});
  for (const Evaluation& ev : e) {
    EXPECT_EQ(ev.objective, 1.0);
    EXPECT_GE(ev.loss, 0.0);        // 1 − rate + T/S with T ∈ (0, 1)
    EXPECT_LT(ev.loss, 1.0 / 4.0);  // never reaches the next rate's loss
  }
  EXPECT_LT(e[1].loss, e[0].loss);
  EXPECT_LT(e[2].loss, e[1].loss);

  JobOptions options;
  options.threads = 2;
  options.optimizer = "direct-l+sbplx";
  options.budget = 4 * 30;
  const DesignResult r = RunDesign(spec, options);
  ASSERT_TRUE(r.errors.empty()) << r.errors[0];
  EXPECT_EQ(r.best_search.objective, 1.0);
  EXPECT_NEAR(r.best[0], 0.30, 0.01);
}

// Bad stages are rejected with file:line and the field.
TEST(DesignScreening, BadStagesAreRejected) {
  const auto error = [](const std::string& screening) {
    try {
      Spec("-0.1", "0.4", "{min: [0.2, -1], max: [0.3, 1]}", screening);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  struct Case {
    std::string text, expected;
  };
  const Case cases[] = {
      {"screening: [{type: grid}]\n",
       "screening.yaml:8: screening[0].type: expected one of geometric, short, got 'grid'"},
      {"screening: [{type: short, duration: 0.1}]\n",
       "screening.yaml:8: screening[0].min_success: expected a value (required)"},
      {"screening:\n  - {type: geometric}\n  - {type: short, duration: 0.1, min_success: 2}\n",
       "screening.yaml:10: screening[1].min_success: expected a number in [0, 1]"},
      {"screening: [{type: geometric, tolerance: -1}]\n",
       "screening.yaml:8: screening[0].tolerance: expected a number >= 0"},
      {"screening: [{type: short, duration: 0.1, min_success: 0.5, formulation: warp}]\n",
       "screening.yaml:8: screening[0].formulation:"},
      {"screening: [{type: geometric, keep: 0.5}]\n",
       "screening.yaml:8: screening[0].keep: expected one of the keys"},
  };
  for (const Case& c : cases) {
    const std::string e = error(c.text);
    EXPECT_NE(e.find(c.expected), std::string::npos)
        << "got: " << e << "\nexpected: " << c.expected;
  }
  try {
    ParseDesignSpec(
        "scene: block_stop.yaml\n"
        "parameters: [{name: pose.stops.wall.x, lower: 0.2, upper: 0.3}]\n"
        "duration: 1\nobjective: {type: distance, body: block, target: [0.2, 0.05]}\n"
        "screening: [{type: geometric}]\n",
        "d.yaml", kData);
    ADD_FAILURE() << "accepted screening on a distance objective";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("d.yaml:5: screening: applies to objectives of type "
                                         "success only"),
              std::string::npos)
        << e.what();
  }
}

// A short stage with another formulation runs that formulation: quasistatically (no inertia) the
// launched block does not move, so a stage asking for x ≥ 0.05 after 0.1 s rejects the design that
// passes it with the scene's own (dynamic) formulation.
TEST(DesignScreening, ShortStageRunsItsOwnFormulation) {
  const std::string stage =
      "  - {type: short, duration: 0.1, samples: 1, min_success: 1.0,\n"
      "     objective: {type: success, body: block, region: {min: [0.05, -1], max: [1, 1]}}";
  const DesignSpec dynamic =
      Spec("0.2", "0.4", "{min: [0.2, -1], max: [0.3, 1]}", "screening:\n" + stage + "}\n");
  const DesignSpec quasistatic =
      Spec("0.2", "0.4", "{min: [0.2, -1], max: [0.3, 1]}",
           "screening:\n" + stage + ",\n     formulation: quasistatic-dqc, dt: 0.01}\n");
  const DesignProblem pd(dynamic), pq(quasistatic);
  Screener sd(dynamic, pd, 1), sq(quasistatic, pq, 1);
  EXPECT_EQ(sd.Screen(VectorXd::Constant(1, 0.3), dynamic.seed), -1);
  EXPECT_EQ(sq.Screen(VectorXd::Constant(1, 0.3), quasistatic.seed), 0);
  // Rejected because the block stays put, not because the quasistatic steps failed.
  DesignSpec q = quasistatic;
  q.scene.options = q.screening[0].options;
  q.duration = 0.1;
  q.objective = q.screening[0].objective;
  q.screening.clear();
  const DesignProblem problem(q);
  ThreadEvaluator evaluator(problem, 1);
  const Evaluation e = evaluator.Evaluate({{VectorXd::Constant(1, 0.3), q.seed, 1}})[0];
  EXPECT_EQ(e.failures, 0) << e.first_failure;
  EXPECT_EQ(e.successes, 0);
}

}  // namespace
}  // namespace vinci::design
