// vinci::parallel without MPI: chunking, the wire format and LocalDistributor's contract. The
// MPI distributor runs the same contract across processes (tests/cli/mpi.cmake).
#include "vinci/parallel/distributor.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "vinci/parallel/wire.h"

namespace vinci::parallel {
namespace {

// Chunks tile [0, n) in order without gaps or overlaps, none larger than asked, a few per rank
// when automatic, never smaller than min_chunk except the last.
TEST(ParallelChunkBounds, TileTheItems) {
  for (int n : {0, 1, 7, 100, 1001}) {
    for (int ranks : {1, 2, 5}) {
      for (int min_chunk : {1, 4}) {
        MapOptions o;
        o.min_chunk = min_chunk;
        const std::vector<int> b = ChunkBounds(n, ranks, o);
        if (n == 0) {
          EXPECT_TRUE(b.empty());
          continue;
        }
        ASSERT_GE(b.size(), 2u);
        EXPECT_EQ(b.front(), 0);
        EXPECT_EQ(b.back(), n);
        const int chunk = b[1] - b[0];
        EXPECT_GE(chunk, std::min(n, min_chunk));
        EXPECT_LE(static_cast<int>(b.size()) - 1, std::max(4 * ranks, 1 + n / min_chunk));
        for (std::size_t k = 1; k < b.size(); ++k) {
          EXPECT_GT(b[k], b[k - 1]);
          EXPECT_LE(b[k] - b[k - 1], chunk);
        }
      }
    }
  }
  MapOptions fixed;
  fixed.chunk = 3;
  EXPECT_EQ(ChunkBounds(7, 4, fixed), (std::vector<int>{0, 3, 6, 7}));
}

TEST(ParallelChunkBounds, RejectsBadArguments) {
  MapOptions o;
  EXPECT_THROW(ChunkBounds(-1, 1, o), std::invalid_argument);
  o.chunk = -2;
  EXPECT_THROW(ChunkBounds(5, 1, o), std::invalid_argument);
  o.chunk = 0;
  o.min_chunk = 0;
  EXPECT_THROW(ChunkBounds(5, 1, o), std::invalid_argument);
}

// Doubles travel bit for bit (NaN payloads, signed zeros, denormals), strings with any bytes;
// reading past the end is caught.
TEST(ParallelWire, RoundTripsBitForBit) {
  const double values[] = {0.1, -0.0, std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::quiet_NaN(), 1e308};
  const std::string text("a\0b,\n", 5);
  Buffer b;
  Writer w(&b);
  for (double v : values) w.Put(v);
  w.PutString(text);
  w.Put<bool>(true);
  w.Put<int>(-7);
  Reader r(b);
  for (double v : values) {
    const double got = r.Get<double>();
    EXPECT_EQ(std::memcmp(&got, &v, sizeof v), 0);
  }
  EXPECT_EQ(r.GetString(), text);
  EXPECT_TRUE(r.Get<bool>());
  EXPECT_EQ(r.Get<int>(), -7);
  EXPECT_TRUE(r.done());
  EXPECT_THROW(r.Get<char>(), std::logic_error);
}

// Map = the chunks' results concatenated in order, each chunk seeing the job; progress counts
// items; the items are counted for rank 0; an exception reaches the caller as thrown.
TEST(ParallelLocalDistributor, MapsChunksInOrder) {
  LocalDistributor d;
  EXPECT_TRUE(d.root());
  EXPECT_EQ(d.size(), 1);
  MapOptions o;
  o.chunk = 4;
  std::vector<int> progress;
  o.progress = [&](int done, int total) {
    EXPECT_EQ(total, 10);
    progress.push_back(done);
  };
  const ChunkFn fn = [](const Buffer& job, int begin, int end) {
    Buffer out;
    for (int i = begin; i < end; ++i) out += job + std::to_string(i) + ";";
    return out;
  };
  EXPECT_EQ(d.Map("x", 10, fn, o), "x0;x1;x2;x3;x4;x5;x6;x7;x8;x9;");
  EXPECT_EQ(progress, (std::vector<int>{4, 8, 10}));
  EXPECT_EQ(d.ItemsPerRank(), std::vector<long long>{10});
  EXPECT_EQ(d.Map("x", 0, fn, o), "");
  EXPECT_THROW(
      d.Map("", 3, [](const Buffer&, int, int) -> Buffer { throw std::invalid_argument("bad"); }),
      std::invalid_argument);
}

}  // namespace
}  // namespace vinci::parallel
