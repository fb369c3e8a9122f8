// The design search: `DesignResult RunDesign(spec, options)`.
//
// The design vector x ∈ [lower, upper] is judged by Monte Carlo (evaluate.h) on the search
// stream (spec.seed) and the loss (1 − success rate, mean distance or mean margin) minimized by
// an NLopt global algorithm followed by a local derivative-free polish from the global best:
//   global  direct-l (GN_DIRECT_L), crs2 (GN_CRS2_LM), isres (GN_ISRES), esch (GN_ESCH)
//   local   bobyqa (LN_BOBYQA), cobyla (LN_COBYLA), neldermead (LN_NELDERMEAD), sbplx (LN_SBPLX)
// named "global+local", "global" or "local" (e.g. "direct-l+bobyqa"). The budget counts
// simulations (rollouts): an evaluation costs `samples` of them; the start design is evaluated
// first, the global stage gets 60% of the rest. "ipopt": Ipopt on a margin or distance loss with
// central-difference gradients under common random numbers (one solve per process: Ipopt 3.11
// with sequential MUMPS is not thread-safe). Stochastic algorithms are seeded from spec.seed
// (nlopt::srand), so a run is reproducible.
//
// Statistics: the best design (and the start design, for comparison) are re-evaluated on
// `validation_samples` fresh samples (FreshStream(seed)), so the reported success rate is not
// the optimistically biased value the design was selected on.
//
// Every evaluation is reported through `on_evaluation` as it completes (the CLI appends it to
// history.csv); evaluations given in `replay` (a previous run's history) are returned from it
// instead of being recomputed, so an interrupted run resumes where it stopped. No printing; no
// exception escapes an NLopt callback (a throwing evaluation stops the search and is reported
// in DesignResult::errors).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "vinci/design/evaluate.h"
#include "vinci/design/screening.h"
#include "vinci/design/spec.h"

namespace vinci::design {

/// One line of the history.
struct HistoryEntry {
  int index = 0;  ///< 0, 1, ... in the order evaluated
  /// "start", "global", "local", "ipopt", "validate-best", "validate-start", or
  /// "screened-<stage type>" for a search candidate a screening stage rejected
  std::string phase;
  Evaluation eval;
  bool replayed = false;  ///< not recomputed: from JobOptions::replay or evaluated before
};

/// Progress after each evaluation.
struct Progress {
  int evaluations = 0;      ///< done so far (search + validation)
  int max_evaluations = 0;  ///< the planned total
  double best_objective = 0.0;
  double elapsed_s = 0.0;
};

struct JobOptions {
  std::string optimizer;  ///< empty: spec.optimizer, else DefaultOptimizer(spec)
  int budget = 0;         ///< simulations; 0: spec.budget
  int samples = 0;        ///< per evaluation; 0: spec.samples
  int threads = 1;
  bool has_seed = false;  ///< override spec.seed with `seed`
  std::uint64_t seed = 0;
  /// Previous evaluations (a history.csv read back); matched on (stream, samples, x) exactly.
  std::vector<Evaluation> replay;
  /// The evaluator to use; null: a ThreadEvaluator with `threads`.
  Evaluator* evaluator = nullptr;
  /// Called after each evaluation (serially). Return false to stop the search (cancellation);
  /// the result then holds the best design so far and `cancelled`.
  std::function<bool(const HistoryEntry&, const Progress&)> on_evaluation;
};

struct DesignResult {
  std::string optimizer;
  VectorXd best;            ///< the best design found on the search stream
  Evaluation best_search;   ///< its evaluation on the search stream (biased upward)
  Evaluation best_fresh;    ///< re-evaluated on fresh samples (validation_samples)
  Evaluation start_search;  ///< the start design on the search stream
  Evaluation start_fresh;   ///< the start design on the fresh samples
  bool validated = false;   ///< best_fresh/start_fresh were computed
  int evaluations = 0;      ///< all evaluations (replayed ones included)
  int replayed = 0;  ///< of which not recomputed (in the replay, or a point already evaluated)
  long long simulations = 0;  ///< rollouts actually run in this process (screening included)
  double time_s = 0.0;
  bool cancelled = false;
  std::vector<std::string> errors;  ///< exceptions caught in optimizer callbacks
  /// Hierarchical screening (screening.h): one row per stage, then the full evaluation of the
  /// candidates that passed; empty without stages. Candidates replayed from a history are not
  /// counted (they are not screened again).
  std::vector<StageReport> screening;
};

/// The optimizer names `--optimizer` accepts (combinations "global+local" of these).
std::vector<std::string> OptimizerNames();
std::string DefaultOptimizer(const DesignSpec& spec);
/// Throws std::invalid_argument (listing the names) unless `name` is a valid optimizer.
void CheckOptimizer(const std::string& name);

/// Runs the search. Throws std::invalid_argument for an unknown optimizer name or option value.
DesignResult RunDesign(const DesignSpec& spec, const JobOptions& options);

/// The exact key under which an evaluation is replayed: stream, samples and x (%.17g).
std::string EvaluationKey(std::uint64_t stream, int samples, const VectorXd& x);

}  // namespace vinci::design
