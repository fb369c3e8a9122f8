// Judging a design by Monte Carlo: sample i of stream s draws every uncertain number from a
// generator seeded by (s, i), so designs compared on the same stream see the same samples
// (common random numbers) and results do not depend on thread count or evaluation order.
//
// Per sample the rollout runs to the spec's duration (or, with `until`, stops when the success
// set is reached); a failed step ends the sample, which is counted in `failures` (a failure for
// `success`; `distance` and `margin` use the last good state).
//
//   success   s_i ∈ {0, 1}: body in the region and |wrap(θ − θ*) mod symmetry| ≤ tolerance;
//             p̂ = Σ s_i / S with the 95% Wilson interval
//             (p̂ + z²/2S ± z √(p̂(1−p̂)/S + z²/4S²)) / (1 + z²/S), z = 1.96. The loss
//             1 − p̂ + T(m̄)/S breaks ties on p̂ by the mean margin m̄ (below; a failed sample's
//             is ≥ 0), T(m) = (1 + m/(|m| + angle_scale))/2 ∈ (0, 1) increasing: of two designs
//             with the same rate the one whose samples end deeper inside the success set (or
//             nearer to it) ranks first, and an optimizer sees a slope where the rate is flat.
//             The term is < 1/S, so it never reorders different rates.
//   distance  d_i = ‖p_i − target‖, objective mean d_i (minimized).
//   margin    m_i = max(sd_box(p_i), angle_scale (|Δθ| − tolerance)), sd_box the signed distance
//             to the region (negative inside); with `until` the minimum over the rollout;
//             objective mean m_i (minimized; < 0 means inside with room to spare).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vinci/design/spec.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::design {

/// One sample of one design.
struct SampleOutcome {
  bool ok = true;        ///< false: a step failed (the sample is a failure)
  bool success = false;  ///< success objective (and margin < 0 for margin)
  double value = 0.0;    ///< distance d_i or margin m_i (success: the margin, for ties)
  std::string failure;   ///< reason when !ok
};

/// One design judged on samples [0, samples) of `stream`.
struct Evaluation {
  VectorXd x;
  std::uint64_t stream = 0;
  int samples = 0;
  double objective = 0.0;  ///< success rate, mean distance or mean margin
  /// What optimizers minimize: 1 − rate + T(mean margin)/S (ties broken, above), mean
  /// distance, mean margin.
  double loss = 0.0;
  int successes = 0;
  double lower = 0.0, upper = 0.0;  ///< 95% Wilson interval of the success rate
  int failures = 0;                 ///< samples with a failed step
  std::string first_failure;        ///< the first failed sample's reason
  double time_s = 0.0;              ///< wall time of the evaluation
};

/// 95% Wilson score interval for k successes in n trials.
void WilsonInterval(int k, int n, double* lower, double* upper);

/// The generator seed of sample i of stream s (SplitMix64 of both).
std::uint64_t SampleSeed(std::uint64_t stream, int i);

/// The stream of the final re-evaluation: fresh samples, distinct from `seed`'s.
std::uint64_t FreshStream(std::uint64_t seed);

/// A spec turned into something that runs samples. Immutable and thread-safe after construction.
class DesignProblem {
 public:
  /// Builds the base simulator from spec.scene. The spec must outlive the problem.
  explicit DesignProblem(const DesignSpec& spec);

  const DesignSpec& spec() const { return *spec_; }
  int size() const { return static_cast<int>(spec_->parameters.size()); }
  VectorXd lower() const;
  VectorXd upper() const;
  VectorXd start() const;

  /// The simulator for design x. Every design number is a Params entry (poses included), so
  /// this is the one shared simulator; the design enters through RunSample's Params.
  std::shared_ptr<const sim::Simulator> SimulatorFor(const VectorXd& x) const;
  /// The scene's parameters with design x written in (no uncertain number drawn).
  sim::Params ParamsFor(const VectorXd& x) const;
  /// The scene of design x (ParamsFor(x) applied). Throws std::invalid_argument if the scene
  /// rejects the values.
  sim::Scene SceneFor(const VectorXd& x) const;
  /// Sample i of `stream` before it runs: design x's parameters and the initial state with the
  /// sample's uncertain numbers drawn (in the order of the spec).
  void SampleStart(const sim::Simulator& simulator, const VectorXd& x, std::uint64_t stream, int i,
                   sim::Params* params, sim::State* state) const;

  /// Runs sample i of `stream` for design x on `simulator` (= SimulatorFor(x)) with the
  /// caller's workspace (one per thread; reset it when the simulator changes).
  SampleOutcome RunSample(const sim::Simulator& simulator, const VectorXd& x, std::uint64_t stream,
                          int i, sim::Workspace* ws) const;

  /// Sample outcomes → the evaluation's statistics (outcomes in sample order).
  Evaluation Summarize(const VectorXd& x, std::uint64_t stream,
                       const std::vector<SampleOutcome>& outcomes, double time_s) const;

 private:
  const DesignSpec* spec_;
  std::shared_ptr<const sim::Simulator> base_;
};

/// A batch of designs to judge.
struct EvalRequest {
  VectorXd x;
  std::uint64_t stream = 0;
  int samples = 0;
};

/// One (design, sample) pair of a batch: sample `sample` of requests[request].
struct SampleTask {
  int request = 0;
  int sample = 0;
};

/// Runs `tasks` on `threads` threads (sim::BatchMap: dynamic, in index order; one Workspace per
/// thread, reset when the thread moves on to another design's simulator) and returns their
/// outcomes in task order, bit-identical for any thread count. sims[r] is the simulator of
/// requests[r] (DesignProblem::SimulatorFor). Stops at the first task that throws and rethrows
/// the lowest-index task's exception. The core of ThreadEvaluator and DistributedEvaluator.
std::vector<SampleOutcome> RunSampleTasks(
    const DesignProblem& problem, const std::vector<EvalRequest>& requests,
    const std::vector<std::shared_ptr<const sim::Simulator>>& sims,
    const std::vector<SampleTask>& tasks, int threads);

/// What the optimizers see. Implementations return one Evaluation per request, in input order,
/// identical for any degree of parallelism (the MPI driver implements the same interface).
class Evaluator {
 public:
  virtual ~Evaluator() = default;
  virtual std::vector<Evaluation> Evaluate(const std::vector<EvalRequest>& requests) = 0;
};

/// Runs the (request, sample) pairs on `threads` threads, one Workspace per thread.
class ThreadEvaluator : public Evaluator {
 public:
  ThreadEvaluator(const DesignProblem& problem, int threads);
  std::vector<Evaluation> Evaluate(const std::vector<EvalRequest>& requests) override;

 private:
  const DesignProblem* problem_;
  int threads_;
};

}  // namespace vinci::design
