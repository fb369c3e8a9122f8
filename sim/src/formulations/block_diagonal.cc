#include "vinci/sim/formulations/block_diagonal.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace vinci::sim {

void BlockDiagonal::Resize(int n, int block_size) {
  if (block_size < 1 || n < 0 || n % block_size != 0)
    throw std::logic_error("BlockDiagonal: size " + std::to_string(n) +
                           " is not a multiple of the block size " + std::to_string(block_size));
  block_size_ = block_size;
  // setZero's bits, by memset (Eigen's fill loop costs several instructions per entry).
  blocks_.resize(block_size, n);
  if (blocks_.size() > 0) std::memset(blocks_.data(), 0, sizeof(double) * blocks_.size());
}

MatrixXd BlockDiagonal::ToDense() const {
  MatrixXd dense = MatrixXd::Zero(rows(), cols());
  for (int o = 0; o < rows(); o += block_size_)
    dense.block(o, o, block_size_, block_size_) = BlockAt(o);
  return dense;
}

}  // namespace vinci::sim
