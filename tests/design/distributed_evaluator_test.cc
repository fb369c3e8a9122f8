// The Evaluator over a parallel::Distributor: the same evaluations as ThreadEvaluator however the
// (design, sample) pairs are chunked and in whatever order the chunks complete; the whole search
// through it is the same search. (Across real MPI ranks: tests/cli/mpi.cmake.)
#include "vinci/design/distributed_evaluator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include "vinci/design/optimize.h"
#include "vinci/design/spec.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

// A stand-in for several ranks: small chunks, run last to first, results put back in order.
class ScrambledDistributor : public parallel::LocalDistributor {
 public:
  explicit ScrambledDistributor(int chunk) : chunk_(chunk) {}
  parallel::Buffer Map(const parallel::Buffer& job, int n, const parallel::ChunkFn& fn,
                       const parallel::MapOptions& options) override {
    parallel::MapOptions o = options;
    o.chunk = chunk_;
    const std::vector<int> b = parallel::ChunkBounds(n, 3, o);
    std::vector<parallel::Buffer> parts(b.empty() ? 0 : b.size() - 1);
    for (std::size_t k = parts.size(); k-- > 0;) parts[k] = fn(job, b[k], b[k + 1]);
    parallel::Buffer out;
    for (const auto& p : parts) out += p;
    ++maps;
    return out;
  }
  int maps = 0;

 private:
  int chunk_;
};

DesignSpec SlideSpec(const std::string& extra) {
  return ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.05, upper: 0.6}]\n"
      "uncertain: [{name: initial.block.vx, uniform: [0.8, 1.2]}, {name: mass.block, "
      "normal: [1, 0.1], truncate: [0.7, 1.3]}]\n"
      "duration: 0.6\n"
      "objective: {type: margin, body: block, region: {min: [0.2, 0], max: [0.4, 0.1]}}\n" +
          extra,
      "test.yaml", kData);
}

void ExpectSame(const Evaluation& a, const Evaluation& b) {
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.stream, b.stream);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.objective, b.objective);
  EXPECT_EQ(a.loss, b.loss);
  EXPECT_EQ(a.successes, b.successes);
  EXPECT_EQ(a.lower, b.lower);
  EXPECT_EQ(a.upper, b.upper);
  EXPECT_EQ(a.failures, b.failures);
  EXPECT_EQ(a.first_failure, b.first_failure);
}

// Several designs at once (as in Ipopt's gradient and the validation), sample counts that do not
// divide the chunk, one design with no samples: identical to ThreadEvaluator for 1 and 2 threads.
TEST(DesignDistributedEvaluator, SameEvaluationsAsThreads) {
  const DesignSpec spec = SlideSpec("samples: 7\n");
  const DesignProblem problem(spec);
  std::vector<EvalRequest> requests;
  requests.push_back({VectorXd::Constant(1, 0.2), 3, 7});
  requests.push_back({VectorXd::Constant(1, 0.4), 3, 0});
  requests.push_back({VectorXd::Constant(1, 0.4), 5, 11});
  requests.push_back({VectorXd::Constant(1, 0.6), 3, 7});
  ThreadEvaluator reference(problem, 1);
  const std::vector<Evaluation> want = reference.Evaluate(requests);
  for (int chunk : {1, 3, 100}) {
    for (int threads : {1, 2}) {
      ScrambledDistributor d(chunk);
      DistributedEvaluator e(problem, d, threads);
      const std::vector<Evaluation> got = e.Evaluate(requests);
      ASSERT_EQ(got.size(), want.size());
      for (std::size_t k = 0; k < want.size(); ++k) {
        SCOPED_TRACE("chunk " + std::to_string(chunk) + ", threads " + std::to_string(threads) +
                     ", request " + std::to_string(k));
        ExpectSame(got[k], want[k]);
      }
    }
  }
  // The designs differ (the test would not see a mix-up otherwise).
  EXPECT_NE(want[0].objective, want[3].objective);
  EXPECT_NE(want[2].objective, want[3].objective);
}

TEST(DesignDistributedEvaluator, RejectsAWrongSizedDesign) {
  const DesignSpec spec = SlideSpec("samples: 2\n");
  const DesignProblem problem(spec);
  parallel::LocalDistributor d;
  DistributedEvaluator e(problem, d, 1);
  EXPECT_THROW(e.Evaluate({{VectorXd::Constant(2, 0.3), 1, 2}}), std::invalid_argument);
}

// A whole search through the distributed evaluator retraces the threaded one, Ipopt's
// several-designs-at-once gradients included.
TEST(DesignDistributedEvaluator, SameSearch) {
  const DesignSpec spec = SlideSpec("samples: 5\nbudget: 100\nvalidation_samples: 9\n");
  for (const std::string optimizer : {"direct-l+bobyqa", "ipopt"}) {
    SCOPED_TRACE(optimizer);
    JobOptions threads;
    threads.optimizer = optimizer;
    const DesignResult a = RunDesign(spec, threads);
    ASSERT_TRUE(a.errors.empty());

    const DesignProblem problem(spec);
    ScrambledDistributor d(2);
    DistributedEvaluator e(problem, d, 2);
    JobOptions distributed = threads;
    distributed.evaluator = &e;
    std::vector<Evaluation> history;
    distributed.on_evaluation = [&](const HistoryEntry& h, const Progress&) {
      history.push_back(h.eval);
      return true;
    };
    const DesignResult b = RunDesign(spec, distributed);
    ASSERT_TRUE(b.errors.empty());
    EXPECT_GT(d.maps, 0);
    EXPECT_EQ(b.evaluations, a.evaluations);
    EXPECT_EQ(b.simulations, a.simulations);
    EXPECT_EQ(b.best, a.best);
    ExpectSame(b.best_search, a.best_search);
    ExpectSame(b.best_fresh, a.best_fresh);
    ExpectSame(b.start_fresh, a.start_fresh);
    EXPECT_EQ(static_cast<int>(history.size()), b.evaluations);
  }
}

}  // namespace
}  // namespace vinci::design
