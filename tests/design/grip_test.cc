// The grip condition of a success objective (grip.h): overlaps against geometry, the success
// rate against a closed-form probability, and the loader's checks.
#include "vinci/design/grip.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "vinci/design/evaluate.h"
#include "vinci/design/spec.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

DesignSpec Spec(const std::string& body) {
  return ParseDesignSpec("scene: grip_walls.yaml\n" + body, "test.yaml", kData);
}

std::string Error(const std::string& body) {
  try {
    Spec(body);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

// Walls' faces at ±18 mm, disc radius 20 mm: overlaps 2 mm ∓ x, or 0 once the disc leaves a wall.
TEST(DesignGrip, OverlapsMatchTheGeometry) {
  const DesignSpec spec = Spec(
      "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\nduration: 1.0e-6\n"
      "objective: {type: success, body: disc, grip: {jaws: [left, right]}}\n");
  const sim::Simulator simulator(spec.scene);
  sim::Workspace ws;
  const sim::Scene& model = simulator.Resolve(simulator.DefaultParams(), &ws);
  const std::vector<int> jaws = spec.objective.grip.jaw_indices;
  const int disc = model.FindBody("disc");
  for (double x : {-0.0015, 0.0, 0.0007, 0.003}) {
    sim::State s = simulator.InitialState();
    s.q[model.index(disc).q] = x;
    const std::vector<double> d = JawOverlaps(model, s, disc, jaws);
    ASSERT_EQ(d.size(), 2u);
    EXPECT_NEAR(d[0], std::max(0.0, 0.002 - x), 1e-9) << x;
    EXPECT_NEAR(d[1], std::max(0.0, 0.002 + x), 1e-9) << x;
  }
  Grip g;
  g.min_overlap = 0.001;
  g.max_overlap = 0.003;
  EXPECT_TRUE(IsGripped(g, {0.0015, 0.0025}));
  EXPECT_FALSE(IsGripped(g, {0.0005, 0.0025}));  // one jaw barely touches
  EXPECT_FALSE(IsGripped(g, {0.0015, 0.0035}));  // crushed
  EXPECT_FALSE(IsGripped(g, {}));
}

// x ~ U[−a, a]: gripped iff 2 mm − |x| ≥ m (both overlaps ≥ m) and 2 mm + |x| ≤ M, so
// p = (min(2 mm − m, M − 2 mm)) / a.
TEST(DesignGrip, SuccessRateMatchesClosedForm) {
  const int n = 4000;
  const double a = 0.004, m = 0.0005, big = 0.0035;
  const DesignSpec spec = Spec(
      "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\n"
      "uncertain: [{name: initial.disc.x, uniform: [-0.004, 0.004]}]\n"
      "samples: " +
      std::to_string(n) +
      "\nduration: 1.0e-6\n"
      "objective: {type: success, body: disc, grip: {jaws: [left, right], min_overlap: "
      "0.0005, max_overlap: 0.0035}}\n");
  const DesignProblem problem(spec);
  ThreadEvaluator evaluator(problem, 2);
  const Evaluation e = evaluator.Evaluate({{problem.start(), 5, n}})[0];
  const double p = std::min(0.002 - m, big - 0.002) / a;
  EXPECT_EQ(e.failures, 0);
  EXPECT_NEAR(e.objective, p, 4 * std::sqrt(p * (1 - p) / n));
  EXPECT_LE(e.lower, p);
  EXPECT_GE(e.upper, p);
}

TEST(DesignGrip, LoaderRejectsBadGrips) {
  const std::string head = "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\nduration: 1\n";
  EXPECT_NE(Error(head + "objective: {type: success, body: disc, grip: {jaws: [left, lid]}}\n")
                .find("test.yaml:4: objective.grip.jaws[1]: expected the name of a body"),
            std::string::npos);
  EXPECT_NE(Error(head + "objective: {type: success, body: disc, grip: {jaws: [disc]}}\n")
                .find("a body other than"),
            std::string::npos);
  EXPECT_NE(Error(head + "objective: {type: success, body: disc, grip: {jaws: [left, left]}}\n")
                .find("jaw given twice"),
            std::string::npos);
  EXPECT_NE(Error(head + "objective: {type: margin, body: disc, region: {min: [0, 0], max: [1, 1]},"
                         " grip: {jaws: [left]}}\n")
                .find("objective.grip: applies to type success only"),
            std::string::npos);
  EXPECT_NE(Error(head + "objective: {type: success, body: disc, grip: {jaws: [left], "
                         "min_overlap: 0.002, max_overlap: 0.001}}\n")
                .find("objective.grip.max_overlap: expected a number > min_overlap"),
            std::string::npos);
  EXPECT_NE(Error(head + "objective: {type: success, body: disc, grip: {jaws: [left], foo: 1}}\n")
                .find("unknown key 'foo'"),
            std::string::npos);
}

}  // namespace
}  // namespace vinci::design
