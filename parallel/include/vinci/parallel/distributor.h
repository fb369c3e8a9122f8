// Distributing independent work items over processes: the abstraction the application drivers
// (`vinci design`, `vinci field`) program against, so that running under `mpirun` only swaps
// the map function. Knows nothing of simulation and nothing of MPI (vinci/parallel/mpi.h has
// the MPI implementation).
//
// The model: one process, rank 0, runs the job and hands out work; the others (ranks 1..N-1)
// serve it. A unit of work is a chunk [begin, end) of the items of a *job*, an opaque byte
// string rank 0 chose (e.g. the designs to evaluate). Every rank runs the same ChunkFn on the
// job it was sent, so
//
//   Map(job, n, fn) = fn(job, c0, c1) + fn(job, c1, c2) + ...   (byte concatenation, chunk order)
//
// whatever rank ran each chunk. If fn(job, b, e) is a pure function of its arguments (each item
// depends on the job and its index only), Map's result is bit-identical for any number of ranks,
// any chunking and any thread count inside fn.
//
// Usage (the same program on every rank):
//   std::unique_ptr<Distributor> d = MakeDistributor();      // vinci/parallel/mpi.h
//   if (!d->root()) { d->Serve(fn); return; }                // workers: until rank 0 stops
//   Buffer out = d->Map(job, n, fn);                         // rank 0, as often as needed
//   // ~Distributor on rank 0 tells the workers to stop.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace vinci::parallel {

/// Bytes on the wire (jobs and chunk results).
using Buffer = std::string;

/// The work of one chunk: the results of items [begin, end) of `job`, encoded so that the
/// chunks' results concatenated in order decode as the results of all items (wire.h). May throw:
/// std::invalid_argument is re-raised as such on rank 0, anything else as std::runtime_error.
using ChunkFn = std::function<Buffer(const Buffer& job, int begin, int end)>;

/// How Map cuts and reports its items.
struct MapOptions {
  /// Items per chunk; 0: automatic, max(min_chunk, ⌈n / (4 · ranks)⌉) (a few chunks per rank
  /// balance the load without many messages).
  int chunk = 0;
  /// Lower bound of the automatic chunk (e.g. the threads each rank runs a chunk on).
  int min_chunk = 1;
  /// (items done, n) on rank 0 after each chunk, in completion order. May be empty.
  std::function<void(int done, int total)> progress;
  /// On rank 0 after each chunk that succeeded, in completion order: its items [begin, end) and
  /// its result (as Map returns it), before `progress`. May be empty.
  std::function<void(int begin, int end, const Buffer& result)> on_chunk;
};

/// Rank 0's side hands out chunks and collects results; the other ranks serve.
class Distributor {
 public:
  virtual ~Distributor() = default;
  /// Number of processes (1: everything runs here).
  virtual int size() const = 0;
  /// This process' rank, 0 ≤ rank < size; rank 0 runs the job.
  virtual int rank() const = 0;
  bool root() const { return rank() == 0; }

  /// Rank 0 only: runs fn over the items [0, n) of `job` in chunks spread over all ranks (rank 0
  /// included) and returns the chunks' results concatenated in chunk order. If a chunk throws,
  /// no further chunk is handed out, the running ones are collected, and the error of the
  /// lowest-index failing chunk is thrown. Throws std::logic_error on a worker rank.
  virtual Buffer Map(const Buffer& job, int n, const ChunkFn& fn,
                     const MapOptions& options = {}) = 0;

  /// Ranks > 0: runs the chunks rank 0 sends with fn until rank 0 stops (Stop or its
  /// destructor). Returns immediately on rank 0.
  virtual void Serve(const ChunkFn& fn) = 0;

  /// Rank 0: tells the workers to leave Serve (idempotent; the destructor calls it).
  virtual void Stop() = 0;

  /// Items run by each rank so far (rank 0 first); meaningful on rank 0.
  virtual std::vector<long long> ItemsPerRank() const = 0;
};

/// The chunk boundaries Map uses: 0 = b_0 < b_1 < ... < b_k = n (empty for n = 0).
/// Throws std::invalid_argument for n < 0, a negative chunk or min_chunk < 1.
std::vector<int> ChunkBounds(int n, int ranks, const MapOptions& options);

/// One process: Map runs the chunks here, in order (an exception propagates as thrown).
class LocalDistributor : public Distributor {
 public:
  int size() const override { return 1; }
  int rank() const override { return 0; }
  Buffer Map(const Buffer& job, int n, const ChunkFn& fn, const MapOptions& options = {}) override;
  void Serve(const ChunkFn&) override {}
  void Stop() override {}
  std::vector<long long> ItemsPerRank() const override { return {items_}; }

 private:
  long long items_ = 0;
};

}  // namespace vinci::parallel
