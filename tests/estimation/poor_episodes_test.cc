// PoorlyFittingEpisodes: the episodes whose fit is far worse than the others' (least_squares.h).
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace vinci::estimation
