#include "vinci/design/ranking.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>

namespace vinci::design {
namespace {

bool IsValidation(const std::string& phase) { return phase.rfind("validate", 0) == 0; }

double Rate(const Evaluation& e) {
  return e.samples > 0 ? static_cast<double>(e.successes) / e.samples : 0.0;
}

}  // namespace

std::vector<RankedDesign> RankDesigns(const std::vector<HistoryEntry>& history, ObjectiveType type,
                                      int k) {
  if (k < 1) throw std::invalid_argument("RankDesigns: k: expected >= 1, got " + std::to_string(k));
  // The search stream and sample count: those of the first non-validation evaluation.
  const HistoryEntry* first = nullptr;
  for (const HistoryEntry& h : history)
    if (!IsValidation(h.phase) && (first == nullptr || h.index < first->index)) first = &h;
  if (first == nullptr) return {};
  const std::uint64_t stream = first->eval.stream;
  const int samples = first->eval.samples;

  // Distinct designs (keyed exactly) with their earliest search evaluation.
  std::map<std::string, RankedDesign> designs;
  for (const HistoryEntry& h : history) {
    if (IsValidation(h.phase) || h.eval.stream != stream || h.eval.samples != samples) continue;
    const std::string key = EvaluationKey(0, 0, h.eval.x);
    auto it = designs.find(key);
    if (it == designs.end() || h.index < it->second.index) {
      RankedDesign d;
      d.index = h.index;
      d.phase = h.phase;
      d.search = h.eval;
      designs[key] = d;
    }
  }
  for (const HistoryEntry& h : history) {
    if (!IsValidation(h.phase)) continue;
    auto it = designs.find(EvaluationKey(0, 0, h.eval.x));
    if (it != designs.end() && (!it->second.fresh || h.eval.samples > it->second.fresh->samples))
      it->second.fresh = h.eval;
  }

  std::vector<RankedDesign> ranked;
  for (auto& [key, d] : designs) ranked.push_back(d);
  const bool by_rate = type != ObjectiveType::kDistance;
  std::sort(ranked.begin(), ranked.end(), [by_rate](const RankedDesign& a, const RankedDesign& b) {
    if (by_rate) {
      const double ra = Rate(a.search), rb = Rate(b.search);
      if (ra != rb) return ra > rb;
      if (a.search.lower != b.search.lower) return a.search.lower > b.search.lower;
    }
    if (a.search.loss != b.search.loss) return a.search.loss < b.search.loss;
    return a.index < b.index;
  });
  if (static_cast<int>(ranked.size()) > k) ranked.resize(static_cast<std::size_t>(k));
  for (std::size_t i = 0; i < ranked.size(); ++i) ranked[i].rank = static_cast<int>(i) + 1;
  return ranked;
}

void ValidateRanking(Evaluator& evaluator, std::uint64_t stream, int samples, ObjectiveType type,
                     std::vector<RankedDesign>* ranking) {
  if (samples < 1)
    throw std::invalid_argument("ValidateRanking: samples: expected >= 1, got " +
                                std::to_string(samples));
  std::vector<EvalRequest> requests;
  std::vector<std::size_t> which;
  for (std::size_t i = 0; i < ranking->size(); ++i) {
    const RankedDesign& d = (*ranking)[i];
    if (d.fresh && d.fresh->stream == stream && d.fresh->samples == samples) continue;
    requests.push_back({d.search.x, stream, samples});
    which.push_back(i);
  }
  if (!requests.empty()) {
    const std::vector<Evaluation> fresh = evaluator.Evaluate(requests);
    for (std::size_t k = 0; k < which.size(); ++k) (*ranking)[which[k]].fresh = fresh[k];
  }
  const bool by_rate = type != ObjectiveType::kDistance;
  std::stable_sort(ranking->begin(), ranking->end(),
                   [by_rate](const RankedDesign& a, const RankedDesign& b) {
                     if (by_rate) return Rate(*a.fresh) > Rate(*b.fresh);
                     return a.fresh->loss < b.fresh->loss;
                   });
  for (std::size_t i = 0; i < ranking->size(); ++i) (*ranking)[i].rank = static_cast<int>(i) + 1;
}

std::string RankingTable(const DesignSpec& spec, const std::vector<RankedDesign>& ranking) {
  const bool by_rate = spec.objective.type != ObjectiveType::kDistance;
  char buf[256];
  std::string out = by_rate
                        ? "rank  success  95% interval        samples  fresh                     "
                        : "rank  objective     samples  ";
  for (const DesignParameter& p : spec.parameters) out += "  " + p.name;
  out += "\n";
  for (const RankedDesign& d : ranking) {
    const Evaluation& e = d.search;
    if (by_rate) {
      std::snprintf(buf, sizeof buf, "%4d  %6.1f%%  [%5.1f%%, %5.1f%%]  %7d  ", d.rank,
                    100.0 * Rate(e), 100.0 * e.lower, 100.0 * e.upper, e.samples);
      out += buf;
      if (d.fresh) {
        std::snprintf(buf, sizeof buf, "%5.1f%% [%5.1f%%, %5.1f%%] of %d", 100.0 * Rate(*d.fresh),
                      100.0 * d.fresh->lower, 100.0 * d.fresh->upper, d.fresh->samples);
        std::string f = buf;
        f.resize(std::max<std::size_t>(f.size(), 26), ' ');
        out += f;
      } else {
        out += std::string(26, ' ');
      }
    } else {
      std::snprintf(buf, sizeof buf, "%4d  %-12.6g  %7d  ", d.rank, e.objective, e.samples);
      out += buf;
    }
    for (Eigen::Index k = 0; k < e.x.size(); ++k) {
      std::snprintf(buf, sizeof buf, "  %.6g", e.x[k]);
      out += buf;
    }
    out += "\n";
  }
  return out;
}

}  // namespace vinci::design
