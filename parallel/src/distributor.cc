#include "vinci/parallel/distributor.h"

#include <algorithm>
#include <stdexcept>

namespace vinci::parallel {

std::vector<int> ChunkBounds(int n, int ranks, const MapOptions& options) {
  if (n < 0)
    throw std::invalid_argument("parallel::Map: item count must be >= 0, got " + std::to_string(n));
  if (options.chunk < 0)
    throw std::invalid_argument("parallel::Map: chunk must be >= 0, got " +
                                std::to_string(options.chunk));
  if (options.min_chunk < 1)
    throw std::invalid_argument("parallel::Map: min_chunk must be >= 1, got " +
                                std::to_string(options.min_chunk));
  const long long per = 4LL * std::max(1, ranks);
  const int chunk = options.chunk > 0
                        ? options.chunk
                        : std::max(options.min_chunk, static_cast<int>((n + per - 1) / per));
  std::vector<int> bounds;
  if (n == 0) return bounds;
  for (long long b = 0; b < n; b += chunk) bounds.push_back(static_cast<int>(b));
  bounds.push_back(n);
  return bounds;
}

Buffer LocalDistributor::Map(const Buffer& job, int n, const ChunkFn& fn,
                             const MapOptions& options) {
  const std::vector<int> bounds = ChunkBounds(n, 1, options);
  Buffer out;
  for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
    const Buffer result = fn(job, bounds[k], bounds[k + 1]);
    items_ += bounds[k + 1] - bounds[k];
    if (options.on_chunk) options.on_chunk(bounds[k], bounds[k + 1], result);
    out += result;
    if (options.progress) options.progress(bounds[k + 1], n);
  }
  return out;
}

}  // namespace vinci::parallel
