// The Evaluator over processes (`mpirun -np N vinci design`): the samples of every requested
// design — and the designs themselves, when several are requested at once (validation, Ipopt's
// gradient) — are cut into chunks of (design, sample) pairs and spread over the ranks of a
// parallel::Distributor; each rank runs its chunks on its own threads. Rank 0 runs the search
// and the other ranks call Serve. Each sample is a pure function of (design, stream, index)
// (evaluate.h), so the evaluations are bit-identical to ThreadEvaluator's for any number of
// ranks and threads (only time_s, the wall time, differs).
#pragma once

#include <memory>
#include <vector>

#include "vinci/design/evaluate.h"
#include "vinci/parallel/distributor.h"

namespace vinci::design {

class DistributedEvaluator : public Evaluator {
 public:
  /// `problem` and `distributor` must outlive the evaluator; `threads` ≥ 1 per rank.
  DistributedEvaluator(const DesignProblem& problem, parallel::Distributor& distributor,
                       int threads);

  /// Rank 0: one Evaluation per request, in input order. Throws what a sample threw (the
  /// lowest-index one), std::invalid_argument for a design vector of the wrong size.
  std::vector<Evaluation> Evaluate(const std::vector<EvalRequest>& requests) override;

  /// Ranks > 0: serves rank 0's Evaluate calls until it stops the distributor.
  void Serve();

  /// The chunk function every rank runs: the outcomes of (design, sample) pairs [begin, end)
  /// of the encoded requests `job`, in order (designs in request order, samples 0, 1, ...).
  parallel::Buffer RunChunk(const parallel::Buffer& job, int begin, int end);

 private:
  const DesignProblem* problem_;
  parallel::Distributor* distributor_;
  int threads_;
  // The last job decoded, with the simulators built for its designs (pose designs build their
  // own; reused across the chunks of one job). Touched by the calling thread only.
  parallel::Buffer job_;
  std::vector<EvalRequest> requests_;
  std::vector<std::shared_ptr<const sim::Simulator>> sims_;
};

}  // namespace vinci::design
