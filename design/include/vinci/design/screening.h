// Hierarchical screening (thesis §4.3, Table 4.1; docs/design.md): the spec's `screening:`
// stages, cheapest first, each a test a search candidate must pass before the next one and,
// after the last, the full Monte Carlo evaluation.
//
//   geometric  at the start (t = 0) of the scene's own initial state, or of samples [0, n) of
//              the search stream with their uncertain numbers drawn, the simulator's contact
//              detection (FindContacts) finds no two bodies, one of them dynamic, that
//              penetrate deeper than `tolerance`: −ψ_n ≤ tolerance for every contact (a corner
//              contact: −max(ψ_n, ψ_n2)). A part that does not fit its chute overlaps its walls.
//   short      the candidate runs `samples` samples of the search stream (common random
//              numbers) for `duration` seconds, optionally with another formulation and step
//              (a quasistatic stage) and its own success set; it passes iff its success rate is
//              at least `min_success`.
//
// A rejected candidate is never simulated in full: it is given the worst success rate (0) and a
// loss above every simulated one, lower for later stages (so the optimizer sees how far it got):
//   loss = 2 + (K − 1 − k) for a candidate rejected by stage k of K.
// Decisions depend on the candidate and the seed only (not on threads or evaluation order).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vinci/design/evaluate.h"
#include "vinci/design/spec.h"

namespace vinci::design {

/// One row of the screening report (the shape of the thesis' Table 4.1).
struct StageReport {
  std::string stage;  ///< "geometric", "short" or "full" (the full evaluation, last row)
  int candidates_in = 0;
  int candidates_out = 0;     ///< passed (the full row: evaluated)
  long long simulations = 0;  ///< rollouts run by the stage (geometric: 0)
  double time_s = 0.0;        ///< wall time spent in the stage
};

/// Runs the stages of spec.screening on candidates. Not thread-safe (it uses `threads` worker
/// threads itself); one per search.
class Screener {
 public:
  /// `problem` judges the full evaluation (its spec is `spec`); both must outlive the screener.
  Screener(const DesignSpec& spec, const DesignProblem& problem, int threads);
  ~Screener();

  /// True if the spec has stages.
  bool active() const { return !spec_->screening.empty(); }

  /// Runs the stages on design x with the samples of `stream`, in order, until one rejects it.
  /// Returns the index of the rejecting stage, or −1 if x passed them all. Counts it in the
  /// report. Throws what a rollout throws (std::invalid_argument for values the scene rejects).
  int Screen(const VectorXd& x, std::uint64_t stream);

  /// The evaluation given to a candidate rejected by stage k (`samples`: the search's, so that
  /// a replayed history finds it): success rate 0 and the loss above.
  Evaluation Rejected(const VectorXd& x, std::uint64_t stream, int samples, int k) const;

  /// Counts candidates evaluated in full (the report's last row).
  void CountFull(int candidates, long long simulations, double time_s);

  /// One row per stage, then the full evaluation; empty if there are no stages.
  std::vector<StageReport> Report() const;

  /// The history phase of a candidate rejected by stage k: "screened-<type>".
  std::string Phase(int k) const;

 private:
  bool Overlaps(const VectorXd& x, std::uint64_t stream, const ScreeningStage& st) const;

  struct ShortStage;
  const DesignSpec* spec_;
  const DesignProblem* problem_;
  int threads_;
  std::vector<std::unique_ptr<ShortStage>> short_;  // per stage; null for geometric stages
  std::vector<StageReport> rows_;                   // stages, then "full"
};

}  // namespace vinci::design
