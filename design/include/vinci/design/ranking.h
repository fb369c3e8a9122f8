// The ranking of a design search's evaluated designs ("the ranking of grasps by success
// probability"): the top-k distinct designs judged on the search stream, best first.
//
// Only evaluations on the search stream with the search's sample count take part (phases start,
// global, local, ipopt): they saw the same samples (common random numbers), so their rates are
// comparable; the fresh-sample validations of the best and start designs are attached to their
// entries, not ranked. A design evaluated twice (the same x) appears once.
//
// Order: success and margin objectives by success rate k/n, descending; ties by the 95% Wilson
// lower bound, descending (equal rates on more samples rank higher), then by the loss
// (ascending), then by the evaluation index (the design found first). Distance objectives by
// the loss (the mean distance), ascending, then the index.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "vinci/design/evaluate.h"
#include "vinci/design/optimize.h"

namespace vinci::design {

/// One ranked design.
struct RankedDesign {
  int rank = 0;                     ///< 1 = best
  int index = 0;                    ///< its first evaluation's HistoryEntry::index
  std::string phase;                ///< that evaluation's phase
  Evaluation search;                ///< on the search stream
  std::optional<Evaluation> fresh;  ///< its fresh-sample validation, if it was validated
};

/// The top `k` (k ≥ 1; fewer if fewer distinct designs were evaluated) distinct designs of
/// `history` (HistoryEntry records in any order), ranked as in the file comment. `type` selects
/// the order (success rate or loss). Throws std::invalid_argument if k < 1.
std::vector<RankedDesign> RankDesigns(const std::vector<HistoryEntry>& history, ObjectiveType type,
                                      int k);

/// Judges every ranked design that has no fresh evaluation with `samples` samples on `samples`
/// samples of `stream` (one batch through `evaluator`), so that each entry has an unbiased rate,
/// then reorders the ranking by the fresh rate (ties: the search order) and renumbers it. With
/// stream = FreshStream(seed) and samples = the validation count, the best and start designs'
/// validations are reused. Distance objectives are reordered by the fresh loss.
void ValidateRanking(Evaluator& evaluator, std::uint64_t stream, int samples, ObjectiveType type,
                     std::vector<RankedDesign>* ranking);

/// The ranking as a text table for the terminal: rank, success rate (distance objectives: the
/// mean distance), its 95% Wilson interval and sample count, the fresh-sample rate of validated
/// designs, then the design values (columns named by spec.parameters). One line per design.
std::string RankingTable(const DesignSpec& spec, const std::vector<RankedDesign>& ranking);

}  // namespace vinci::design
