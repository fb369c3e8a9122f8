// PoorlyFittingEpisodes: the episodes whose fit is far worse than the others'; and
// EpisodeContradictsNoise: an episode's residuals against a stated noise (least_squares.h).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/estimation/least_squares.h"

namespace vinci::estimation {
namespace {

std::vector<EpisodeEstimate> Episodes(const std::vector<double>& rms) {
  std::vector<EpisodeEstimate> out;
  for (std::size_t i = 0; i < rms.size(); ++i) {
    EpisodeEstimate e;
    e.file = "toss" + std::to_string(i) + ".csv";
    e.rms_residual = rms[i];
    out.push_back(e);
  }
  return out;
}

// Against the median (robust to the outliers themselves): 50 tosses at 1.4e-4 m ± 20 % and
// one at 4.8e-4 m (3.4×, as toss 30 of the 50 tossed cubes) — only that one; at 2.5× — none.
TEST(PoorlyFittingEpisodes, FlagsFitsFarWorseThanTheMedian) {
  std::vector<double> rms;
  for (int i = 0; i < 50; ++i) rms.push_back(1.4e-4 * (0.8 + 0.4 * (i % 7) / 6.0));
  EXPECT_TRUE(PoorlyFittingEpisodes(Episodes(rms)).empty());
  rms[30] = 4.8e-4;
  EXPECT_EQ(PoorlyFittingEpisodes(Episodes(rms)), std::vector<int>{30});
  rms[30] = 3.5e-4;
  EXPECT_TRUE(PoorlyFittingEpisodes(Episodes(rms)).empty());
  // Several outliers, an even count: the median of 4 is the mean of the middle two (2, 3).
  EXPECT_EQ(PoorlyFittingEpisodes(Episodes({1.0, 2.0, 3.0, 8.0}), 3.0), std::vector<int>{3});
  EXPECT_EQ(PoorlyFittingEpisodes(Episodes({1.0, 2.0, 3.0, 7.0}), 3.0), std::vector<int>{});
  EXPECT_EQ(PoorlyFittingEpisodes(Episodes({1.0, 9.0, 1.2, 1.1, 20.0}), 5.0),
            (std::vector<int>{1, 4}));
}

// Too few episodes to call one an outlier, residuals at rounding level (noise-free logs), a
// non-finite residual: nothing flagged; a factor ≤ 1 is rejected.
TEST(PoorlyFittingEpisodes, NeedsThreeEpisodesAndResidualsAboveRounding) {
  EXPECT_TRUE(PoorlyFittingEpisodes(Episodes({1e-4, 1e-2})).empty());
  EXPECT_TRUE(PoorlyFittingEpisodes(Episodes({1e-13, 1e-13, 5e-11})).empty());
  EXPECT_TRUE(
      PoorlyFittingEpisodes(Episodes({1e-4, 1e-4, 1e-2, std::numeric_limits<double>::quiet_NaN()}))
          .empty());
  EXPECT_THROW(PoorlyFittingEpisodes(Episodes({1.0, 1.0, 1.0}), 1.0), std::invalid_argument);
}

// The χ² test at 4 standard deviations (p < 1e-4): 600 rows less 13 state unknowns at σ = 30 µm
// is 587 ± 34.3 d.o.f., so Σ r²/σ² up to 724 agrees (rms 32.9 µm), beyond it contradicts.
TEST(EpisodeContradictsNoise, ChiSquareOverTheEpisodesDegreesOfFreedom) {
  EpisodeEstimate e;
  e.num_residuals = 600;
  e.num_state_unknowns = 13;
  const double limit = 3e-5 * std::sqrt((587 + 4 * std::sqrt(2.0 * 587)) / 600.0);
  e.rms_residual = 0.999 * limit;
  EXPECT_FALSE(EpisodeContradictsNoise(e, 3e-5));
  e.rms_residual = 1.001 * limit;
  EXPECT_TRUE(EpisodeContradictsNoise(e, 3e-5));
  EXPECT_FALSE(EpisodeContradictsNoise(e, 0.0));  // no stated noise: nothing to contradict
  e.num_state_unknowns = 600;                     // no degrees of freedom
  EXPECT_FALSE(EpisodeContradictsNoise(e, 3e-5));
  e.num_state_unknowns = 13;
  e.rms_residual = std::numeric_limits<double>::quiet_NaN();  // a failed rollout
  EXPECT_FALSE(EpisodeContradictsNoise(e, 3e-5));
}

}  // namespace
}  // namespace vinci::estimation
