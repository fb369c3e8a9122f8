// The ranking of evaluated designs (ranking.h): distinct designs, sorted by success rate with
// the documented tie-breaks, validations attached rather than ranked.
#include "vinci/design/ranking.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace vinci::design {
namespace {

HistoryEntry Entry(int index, const std::string& phase, double x, int successes, int samples,
                   std::uint64_t stream = 1) {
  HistoryEntry h;
  h.index = index;
  h.phase = phase;
  h.eval.x = VectorXd::Constant(1, x);
  h.eval.stream = stream;
  h.eval.samples = samples;
  h.eval.successes = successes;
  h.eval.objective = static_cast<double>(successes) / samples;
  h.eval.loss = 1.0 - h.eval.objective;
  WilsonInterval(successes, samples, &h.eval.lower, &h.eval.upper);
  return h;
}

TEST(DesignRanking, SortsDistinctSearchDesignsBySuccessRate) {
  const std::vector<HistoryEntry> history = {
      Entry(0, "start", 0.1, 5, 20),
      Entry(1, "global", 0.2, 18, 20),
      Entry(2, "global", 0.3, 12, 20),
      Entry(3, "local", 0.2, 18, 20),  // repeat of 1
      Entry(4, "local", 0.4, 18, 20),
      Entry(5, "local", 0.5, 20, 20),
      Entry(6, "validate-best", 0.5, 190, 200, 99),
      Entry(7, "validate-start", 0.1, 60, 200, 99),
  };
  const std::vector<RankedDesign> r = RankDesigns(history, ObjectiveType::kSuccess, 10);
  ASSERT_EQ(r.size(), 5u);  // 0.1 .. 0.5, each once; validations not ranked
  const double order[] = {0.5, 0.2, 0.4, 0.3, 0.1};
  for (std::size_t k = 0; k < r.size(); ++k) {
    EXPECT_EQ(r[k].rank, static_cast<int>(k) + 1);
    EXPECT_EQ(r[k].search.x[0], order[k]) << k;
    EXPECT_EQ(r[k].search.samples, 20);
    if (k > 0) {
      const double prev = static_cast<double>(r[k - 1].search.successes) / 20;
      EXPECT_GE(prev, static_cast<double>(r[k].search.successes) / 20);
    }
  }
  EXPECT_EQ(r[1].index, 1);  // equal rates: the design found first
  ASSERT_TRUE(r[0].fresh.has_value());
  EXPECT_EQ(r[0].fresh->successes, 190);
  ASSERT_TRUE(r[4].fresh.has_value());
  EXPECT_EQ(r[4].fresh->samples, 200);
  EXPECT_FALSE(r[1].fresh.has_value());

  const std::vector<RankedDesign> top2 = RankDesigns(history, ObjectiveType::kSuccess, 2);
  ASSERT_EQ(top2.size(), 2u);
  EXPECT_EQ(top2[1].search.x[0], 0.2);
  EXPECT_THROW(RankDesigns(history, ObjectiveType::kSuccess, 0), std::invalid_argument);
  EXPECT_TRUE(RankDesigns({}, ObjectiveType::kSuccess, 3).empty());
}

// Evaluations on another stream or with another sample count (e.g. a --samples override in a
// resumed history) are not comparable and are left out; distance objectives rank by the loss.
TEST(DesignRanking, OnlyComparableEvaluationsAndLossForDistance) {
  std::vector<HistoryEntry> history = {
      Entry(0, "start", 0.1, 0, 20), Entry(1, "global", 0.2, 0, 20), Entry(2, "global", 0.3, 0, 10),
      Entry(3, "global", 0.4, 0, 20, 7)};
  history[0].eval.loss = 0.5;
  history[1].eval.loss = 0.25;
  const std::vector<RankedDesign> r = RankDesigns(history, ObjectiveType::kDistance, 10);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].search.x[0], 0.2);
  EXPECT_EQ(r[1].search.x[0], 0.1);
  DesignSpec spec;
  spec.objective.type = ObjectiveType::kDistance;
  const std::string table = RankingTable(spec, r);
  EXPECT_NE(table.find("objective"), std::string::npos);
}

// A stand-in evaluator: a design x succeeds on a fraction x of the samples (deterministic), and
// it records what it was asked.
class FakeEvaluator : public Evaluator {
 public:
  std::vector<Evaluation> Evaluate(const std::vector<EvalRequest>& requests) override {
    std::vector<Evaluation> out;
    for (const EvalRequest& r : requests) {
      asked.push_back(r);
      Evaluation e;
      e.x = r.x;
      e.stream = r.stream;
      e.samples = r.samples;
      e.successes = static_cast<int>(std::lround(r.x[0] * r.samples));
      e.objective = static_cast<double>(e.successes) / r.samples;
      e.loss = 1.0 - e.objective;
      WilsonInterval(e.successes, e.samples, &e.lower, &e.upper);
      out.push_back(e);
    }
    return out;
  }
  std::vector<EvalRequest> asked;
};

// Designs tied on the search samples are separated by their fresh rates; an existing validation
// on the same stream and sample count is reused, not recomputed.
TEST(DesignRanking, ValidateRankingReordersByFreshRates) {
  const std::vector<HistoryEntry> history = {
      Entry(0, "start", 0.3, 20, 20), Entry(1, "global", 0.9, 20, 20),
      Entry(2, "global", 0.6, 20, 20), Entry(3, "local", 0.2, 10, 20),
      Entry(4, "validate-best", 0.3, 60, 200, 99)};
  std::vector<RankedDesign> r = RankDesigns(history, ObjectiveType::kSuccess, 10);
  ASSERT_EQ(r.size(), 4u);
  EXPECT_EQ(r[0].search.x[0], 0.3);  // three tie at 20/20: the first found leads
  FakeEvaluator evaluator;
  ValidateRanking(evaluator, 99, 200, ObjectiveType::kSuccess, &r);
  EXPECT_EQ(evaluator.asked.size(), 3u);  // 0.3 was validated already
  for (const EvalRequest& q : evaluator.asked) {
    EXPECT_EQ(q.stream, 99u);
    EXPECT_EQ(q.samples, 200);
    EXPECT_NE(q.x[0], 0.3);
  }
  const double order[] = {0.9, 0.6, 0.3, 0.2};
  for (std::size_t k = 0; k < r.size(); ++k) {
    EXPECT_EQ(r[k].rank, static_cast<int>(k) + 1);
    EXPECT_EQ(r[k].search.x[0], order[k]) << k;
    ASSERT_TRUE(r[k].fresh.has_value());
    EXPECT_EQ(r[k].fresh->samples, 200);
  }
  EXPECT_EQ(r[2].fresh->successes, 60);  // the reused validation
}

}  // namespace
}  // namespace vinci::design
