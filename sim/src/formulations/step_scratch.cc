// The per-thread step scratch (sparse_lcp.h): leases, warm-basis scratch by basis size, the
// step record.
#include <cstddef>
#include <memory>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "ncp_internal.h"
#include "sparse_lcp.h"

namespace vinci::sim::internal {

namespace {
// One scratch per thread, leased for the duration of a step (a nested step on the same thread,
// if any, gets its own): reused allocations only, so results do not depend on the thread.
thread_local StepScratch t_scratch;
thread_local bool t_scratch_in_use = false;
}  // namespace

StepScratchLease::StepScratchLease() {
  if (!t_scratch_in_use) {
    t_scratch_in_use = true;
    in_use_ = &t_scratch_in_use;
    scratch_ = &t_scratch;
  } else {
    own_ = std::make_unique<StepScratch>();
    scratch_ = own_.get();
  }
}

WarmBasisScratch& StepScratch::BasisFor(const VectorXd& guess) {
  // nb = #{i : guess_i > 0}, two entries per compare where SSE2 is available.
  int nb = 0;
  const double* g = guess.data();
  const Eigen::Index n = guess.size();
  Eigen::Index i = 0;
#ifdef __SSE2__
  const __m128d zero = _mm_setzero_pd();
  for (; i + 1 < n; i += 2) {
    const int mask = _mm_movemask_pd(_mm_cmpgt_pd(_mm_loadu_pd(g + i), zero));
    nb += (mask & 1) + (mask >> 1);
  }
#endif
  for (; i < n; ++i) nb += g[i] > 0.0;
  if (nb > kDenseWarmBasisMax) return basis;
  if (basis_by_size.size() <= static_cast<std::size_t>(nb)) basis_by_size.resize(nb + 1);
  std::unique_ptr<WarmBasisScratch>& b = basis_by_size[static_cast<std::size_t>(nb)];
  if (!b) b = std::make_unique<WarmBasisScratch>();
  return *b;
}

StepScratchLease::~StepScratchLease() {
  if (in_use_) *in_use_ = false;
}

void ClearStepRecord() {
  if (!t_scratch_in_use) t_scratch.record.Clear();
  ClearNcpStepRecord();
}

void StampStepOwner(const std::shared_ptr<const Scene>& scene) {
  StepRecord& r = t_scratch.record;
  if (!t_scratch_in_use && r.valid && r.model == scene.get()) r.owner = scene;
  StampNcpStepOwner(scene);
}

const StepScratch* IdleThreadStepScratch() { return t_scratch_in_use ? nullptr : &t_scratch; }

const StewartTrinkle::Assembly* StepAssembly(const StewartTrinkle& st,
                                             const std::shared_ptr<const Scene>& scene,
                                             const State& x, const StepInput& u) {
  const StepScratch* step = IdleThreadStepScratch();
  return step && step->record.Holds(st, scene, x, u) ? &step->assembly : nullptr;
}

}  // namespace vinci::sim::internal
