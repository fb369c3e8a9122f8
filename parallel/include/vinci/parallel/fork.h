// Distributing independent work items over forked processes of this machine: a Distributor
// (distributor.h) without MPI, for work that cannot share one process' threads (Ipopt 3.11 with
// sequential MUMPS is not thread-safe: docs/estimation.md, "Episodes: joint or decomposed").
#pragma once

#include <vector>

#include "vinci/parallel/distributor.h"

namespace vinci::parallel {

/// Map runs each chunk in a child process forked for it, at most `processes` at once (with 1,
/// the chunks run here, in order, as LocalDistributor's do). fn runs in a copy of the caller as
/// it is at the fork: it may read any of the caller's state (it need not be a pure function of
/// the job), its side effects stay in the child, and only its result comes back. A forked child
/// has only the forking thread: call Map with no other thread of the caller holding a lock fn
/// needs. Errors as Distributor::Map: the lowest-index failing chunk's exception is re-raised
/// after the running chunks are collected; a chunk whose process ends without a result (a
/// crash, a signal) fails with std::runtime_error naming its items and how the process ended.
/// There are no worker ranks: Serve and Stop do nothing.
class ForkDistributor : public Distributor {
 public:
  /// Throws std::invalid_argument for processes < 1.
  explicit ForkDistributor(int processes);
  int size() const override { return processes_; }
  int rank() const override { return 0; }
  Buffer Map(const Buffer& job, int n, const ChunkFn& fn, const MapOptions& options = {}) override;
  void Serve(const ChunkFn&) override {}
  void Stop() override {}
  /// Items run in each of the `processes` slots (a slot is reused by the next child).
  std::vector<long long> ItemsPerRank() const override { return items_; }

 private:
  int processes_;
  std::vector<long long> items_;
};

}  // namespace vinci::parallel
