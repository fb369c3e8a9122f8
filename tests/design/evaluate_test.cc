// Monte Carlo evaluation: statistics against closed forms, determinism across threads.
#include "vinci/design/evaluate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/design/spec.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

DesignSpec Spec(const std::string& body) {
  return ParseDesignSpec("scene: block_rest.yaml\n" + body, "test.yaml", kData);
}

// Standard error of a rate p over n samples.
double Sigma(double p, int n) { return std::sqrt(p * (1 - p) / n); }

TEST(DesignEvaluate, WilsonIntervalMatchesClosedForm) {
  double lo = 0, hi = 0;
  WilsonInterval(8, 10, &lo, &hi);  // textbook: (0.4902, 0.9433)
  EXPECT_NEAR(lo, 0.4902, 1e-4);
  EXPECT_NEAR(hi, 0.9433, 1e-4);
  WilsonInterval(0, 20, &lo, &hi);  // z²/(n + z²) = 0.1611
  EXPECT_EQ(lo, 0.0);
  EXPECT_NEAR(hi, 0.1611, 1e-4);
}

// The block rests where it is put: with x ~ U[0, 1] and the region [0.2, 0.5], p = 0.3; with
// x ~ N(0, 0.1) and the region [−0.1, 0.1], p = erf(1/√2) = 0.6827; θ ∈ {0, π} 50/50 with the
// target 0 (tolerance 0.3), p = 0.5.
TEST(DesignEvaluate, SuccessRateMatchesClosedFormProbabilities) {
  const int n = 4000;
  struct Case {
    std::string uncertain, objective;
    double p;
  };
  const Case cases[] = {
      {"[{name: initial.block.x, uniform: [0, 1]}]",
       "{type: success, body: block, region: {min: [0.2, 0], max: [0.5, 0.1]}}", 0.3},
      {"[{name: initial.block.x, normal: [0, 0.1]}]",
       "{type: success, body: block, region: {min: [-0.1, 0], max: [0.1, 0.1]}}",
       std::erf(1 / std::sqrt(2.0))},
      {"[{name: initial.block.theta, choice: [0, 3.141592653589793]}]",
       "{type: success, body: block, angle: {target: 0, tolerance: 0.3}}", 0.5},
      {"[{name: initial.block.x, normal: [0, 0.1], truncate: [0, 1]}]",
       "{type: success, body: block, region: {min: [0, 0], max: [0.1, 0.1]}}",
       std::erf(1 / std::sqrt(2.0))},
  };
  for (const Case& c : cases) {
    const DesignSpec spec = Spec(
        "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\nuncertain: " + c.uncertain +
        "\nsamples: " + std::to_string(n) + "\nduration: 0.002\nobjective: " + c.objective + "\n");
    const DesignProblem problem(spec);
    ThreadEvaluator evaluator(problem, 2);
    const Evaluation e = evaluator.Evaluate({{problem.start(), 7, n}})[0];
    EXPECT_EQ(e.failures, 0);
    EXPECT_NEAR(e.objective, c.p, 4 * Sigma(c.p, n)) << c.uncertain;
    EXPECT_LE(e.lower, c.p) << c.uncertain;
    EXPECT_GE(e.upper, c.p) << c.uncertain;
  }
}

// Sample i depends only on (stream, i): 1 and 2 threads give identical evaluations, and two
// designs on one stream see the same draws (common random numbers).
TEST(DesignEvaluate, ThreadCountDoesNotChangeResults) {
  const DesignSpec spec = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\n"
      "uncertain: [{name: initial.block.vx, uniform: [0.5, 1.5]}, {name: mass.block, "
      "normal: [1, 0.1], truncate: [0.5, 1.5]}]\n"
      "samples: 16\nduration: 0.3\n"
      "objective: {type: margin, body: block, region: {min: [0.2, 0], max: [0.4, 0.1]}}\n",
      "test.yaml", kData);
  const DesignProblem problem(spec);
  std::vector<EvalRequest> requests;
  for (double mu : {0.2, 0.4, 0.6}) requests.push_back({VectorXd::Constant(1, mu), 3, 16});
  ThreadEvaluator one(problem, 1), two(problem, 2);
  const std::vector<Evaluation> a = one.Evaluate(requests), b = two.Evaluate(requests);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].objective, b[k].objective);
    EXPECT_EQ(a[k].successes, b[k].successes);
  }
  // More friction, shorter slide, farther from the region (which lies ahead of every stopping
  // point for μ ≥ 0.4, d ≤ v²/(2 μ g) = 0.29 m): the mean margin grows with μ.
  EXPECT_LT(a[0].objective, a[1].objective);
  EXPECT_LT(a[1].objective, a[2].objective);
}

// RunSampleTasks (the batch under both evaluators): outcome k is RunSample of task k with a
// fresh workspace, bit for bit, for any thread count and any interleaving of designs (a thread
// moving between designs resets its workspace); a sample that throws is rethrown.
TEST(DesignEvaluate, RunSampleTasksMatchesSerialSamplesForAnyThreadCount) {
  const DesignSpec spec = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.1, upper: 1}]\n"
      "uncertain: [{name: initial.block.vx, uniform: [0.5, 1.5]}]\n"
      "samples: 4\nduration: 0.2\n"
      "objective: {type: margin, body: block, region: {min: [0.2, 0], max: [0.4, 0.1]}}\n",
      "test.yaml", kData);
  const DesignProblem problem(spec);
  const std::vector<EvalRequest> requests = {{VectorXd::Constant(1, 0.2), 5, 4},
                                             {VectorXd::Constant(1, 0.7), 9, 4}};
  std::vector<std::shared_ptr<const sim::Simulator>> sims;
  for (const EvalRequest& r : requests) sims.push_back(problem.SimulatorFor(r.x));
  // Designs interleaved task by task, samples out of order.
  const std::vector<SampleTask> tasks = {{0, 3}, {1, 0}, {0, 0}, {1, 2}, {1, 1},
                                         {0, 1}, {1, 3}, {0, 2}, {0, 3}};
  std::vector<SampleOutcome> serial;
  for (const SampleTask& t : tasks) {
    sim::Workspace ws;
    const EvalRequest& q = requests[static_cast<std::size_t>(t.request)];
    serial.push_back(problem.RunSample(*sims[static_cast<std::size_t>(t.request)], q.x, q.stream,
                                       t.sample, &ws));
  }
  // The two designs end at different places: a mix-up of designs would show.
  EXPECT_NE(serial[0].value, serial[1].value);
  for (int threads : {1, 2, 3, 16}) {
    const std::vector<SampleOutcome> out = RunSampleTasks(problem, requests, sims, tasks, threads);
    ASSERT_EQ(out.size(), tasks.size()) << threads;
    for (std::size_t k = 0; k < tasks.size(); ++k) {
      EXPECT_EQ(out[k].ok, serial[k].ok) << threads << " " << k;
      EXPECT_EQ(out[k].success, serial[k].success) << threads << " " << k;
      EXPECT_EQ(std::memcmp(&out[k].value, &serial[k].value, sizeof(double)), 0)
          << threads << " " << k << ": " << out[k].value << " vs " << serial[k].value;
    }
  }
  EXPECT_TRUE(RunSampleTasks(problem, requests, sims, {}, 2).empty());
  // A task naming a request that does not exist throws (std::out_of_range from the lookup).
  EXPECT_THROW(RunSampleTasks(problem, requests, sims, {{0, 0}, {2, 0}}, 2), std::out_of_range);
}

}  // namespace
}  // namespace vinci::design
