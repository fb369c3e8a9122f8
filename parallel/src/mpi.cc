// MakeDistributor and, when built with MPI (VINCI_HAVE_MPI), the MPI distributor.
//
// Protocol (a duplicate of MPI_COMM_WORLD, rank 0 the master):
//   master → worker  kTagJob    [int64 job id][job bytes]      before a worker's first chunk of a
//   job master → worker  kTagChunk  [int64 job id][int32 begin][int32 end] worker → master
//   kTagResult [uint8 status][result bytes | error message] master → worker  kTagStop   (empty) the
//   worker leaves Serve
// A worker gets up to kDepth chunks ahead so it never waits for the master, which runs chunks
// itself between collecting results. Messages between two ranks arrive in order (MPI's
// non-overtaking rule), so the master knows which chunk each result belongs to. Waiting is done
// by MPI_Iprobe with a growing sleep, not by a blocking receive: Open MPI's blocking calls spin a
// core, which on a small machine would take it from the ranks that compute.
#include "vinci/parallel/mpi.h"

#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>

#ifdef VINCI_HAVE_MPI
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <deque>
#include <exception>
#include <list>
#include <optional>
#include <thread>

#include "vinci/parallel/wire.h"
#endif

namespace vinci::parallel {
namespace {

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  if (!v) return fallback;
  const std::string s(v);
  if (s.empty() || s.size() > 9 || s.find_first_not_of("0123456789") != std::string::npos)
    throw std::invalid_argument(std::string(name) + ": expected a non-negative integer, got '" + s +
                                "'");
  return std::stoi(s);
}

#ifdef VINCI_HAVE_MPI

constexpr int kTagJob = 1, kTagChunk = 2, kTagResult = 3, kTagStop = 4;
constexpr int kDepth = 2;          // chunks a worker holds (one running, one queued)
constexpr int kMaxSleepUs = 1000;  // longest nap between polls
constexpr std::uint8_t kOk = 0, kInvalidArgument = 1, kOtherError = 2;

bool g_initialized = false;

void Check(int code, const char* what) {
  if (code != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

// Sleeps a little longer each time nothing happened; Reset when something did.
class Backoff {
 public:
  void Nap() {
    us_ = us_ == 0 ? 10 : std::min(2 * us_, kMaxSleepUs);
    std::this_thread::sleep_for(std::chrono::microseconds(us_));
  }
  void Reset() { us_ = 0; }

 private:
  int us_ = 0;
};

class MpiDistributor : public Distributor {
 public:
  MpiDistributor() {
    int provided = 0;
    Check(MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    g_initialized = true;
    int initialized = 0;
    MPI_Initialized(&initialized);
    int size = 0, rank = -1;
    if (initialized) {
      MPI_Comm_size(MPI_COMM_WORLD, &size);
      MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    }
    const int want_size = MpirunWorldSize(), want_rank = EnvInt("OMPI_COMM_WORLD_RANK", -1);
    if (!initialized || size != want_size || rank != want_rank) {
      const std::string what =
          "MPI sees rank " + std::to_string(rank) + " of " + std::to_string(size) +
          " but mpirun started rank " + std::to_string(want_rank) + " of " +
          std::to_string(want_size) +
          " (MPI calls bound to a dummy MPI, e.g. sequential MUMPS': link MPI before Ipopt)";
      if (initialized) MPI_Finalize();
      throw std::runtime_error(what);
    }
    if (provided < MPI_THREAD_FUNNELED) {
      MPI_Finalize();
      throw std::runtime_error("MPI: MPI_THREAD_FUNNELED is not supported");
    }
    size_ = size;
    rank_ = rank;
    MPI_Comm_dup(MPI_COMM_WORLD, &comm_);
    items_.assign(static_cast<std::size_t>(size_), 0);
  }

  ~MpiDistributor() override {
    try {
      Stop();
    } catch (...) {  // nothing may escape a destructor; MPI aborts the job on a real failure
    }
    FinishSends();
    MPI_Comm_free(&comm_);
    MPI_Finalize();
  }

  int size() const override { return size_; }
  int rank() const override { return rank_; }
  std::vector<long long> ItemsPerRank() const override { return items_; }

  void Stop() override {
    if (rank_ != 0 || stopped_) return;
    stopped_ = true;
    for (int w = 1; w < size_; ++w)
      Check(MPI_Send(nullptr, 0, MPI_BYTE, w, kTagStop, comm_), "stop");
  }

  Buffer Map(const Buffer& job, int n, const ChunkFn& fn, const MapOptions& options) override {
    if (rank_ != 0)
      throw std::logic_error("parallel::Map: called on worker rank " + std::to_string(rank_));
    if (stopped_) throw std::logic_error("parallel::Map: called after Stop");
    const std::vector<int> bounds = ChunkBounds(n, size_, options);
    const int chunks = bounds.empty() ? 0 : static_cast<int>(bounds.size()) - 1;
    ++job_id_;
    std::vector<Buffer> results(static_cast<std::size_t>(chunks));
    std::vector<std::deque<int>> pending(static_cast<std::size_t>(size_));
    std::vector<bool> has_job(static_cast<std::size_t>(size_), false);
    // The lowest-index failing chunk: a local exception, or a worker's (kind, message).
    int failed_chunk = -1;
    std::exception_ptr local_error, progress_error;
    std::uint8_t failed_kind = kOk;
    std::string failed_what;
    int next = 0, outstanding = 0, done = 0;
    const auto stopping = [&] { return failed_chunk >= 0 || progress_error; };
    const auto give = [&](int w) {
      if (next >= chunks || stopping()) return;
      if (!has_job[static_cast<std::size_t>(w)]) {
        Buffer msg;
        Writer(&msg).Put<std::int64_t>(job_id_);
        msg += job;
        Send(std::move(msg), w, kTagJob);
        has_job[static_cast<std::size_t>(w)] = true;
      }
      Buffer msg;
      Writer wr(&msg);
      wr.Put<std::int64_t>(job_id_);
      wr.Put<std::int32_t>(bounds[static_cast<std::size_t>(next)]);
      wr.Put<std::int32_t>(bounds[static_cast<std::size_t>(next) + 1]);
      Send(std::move(msg), w, kTagChunk);
      pending[static_cast<std::size_t>(w)].push_back(next++);
      ++outstanding;
    };
    const auto finished = [&](int k, int by, bool ok) {
      const int items =
          bounds[static_cast<std::size_t>(k) + 1] - bounds[static_cast<std::size_t>(k)];
      items_[static_cast<std::size_t>(by)] += items;
      done += items;
      if ((options.progress || options.on_chunk) && !progress_error) {
        try {
          if (ok && options.on_chunk)
            options.on_chunk(bounds[static_cast<std::size_t>(k)],
                             bounds[static_cast<std::size_t>(k) + 1],
                             results[static_cast<std::size_t>(k)]);
          if (options.progress) options.progress(done, n);
        } catch (...) {
          progress_error = std::current_exception();
        }
      }
    };
    const auto fail = [&](int k) { return failed_chunk < 0 || k < failed_chunk; };

    for (int d = 0; d < kDepth; ++d)
      for (int w = 1; w < size_; ++w) give(w);
    Backoff backoff;
    while (outstanding > 0 || (next < chunks && !stopping())) {
      bool got = false;
      for (;;) {  // every result that has arrived
        int flag = 0;
        MPI_Status st;
        Check(MPI_Iprobe(MPI_ANY_SOURCE, kTagResult, comm_, &flag, &st), "MPI_Iprobe");
        if (!flag) break;
        const Buffer msg = Receive(st);
        const int w = st.MPI_SOURCE;
        std::deque<int>& q = pending[static_cast<std::size_t>(w)];
        if (q.empty())
          throw std::logic_error("parallel::Map: unexpected result from rank " + std::to_string(w));
        const int k = q.front();
        q.pop_front();
        --outstanding;
        Reader r(msg);
        const auto status = r.Get<std::uint8_t>();
        if (status == kOk) {
          results[static_cast<std::size_t>(k)] = msg.substr(1);
        } else if (fail(k)) {
          failed_chunk = k;
          failed_kind = status;
          failed_what = msg.substr(1);
          local_error = nullptr;
        }
        finished(k, w, status == kOk);
        give(w);
        got = true;
      }
      if (next < chunks && !stopping()) {  // a chunk of our own while the workers compute
        const int k = next++;
        bool ok = true;
        try {
          results[static_cast<std::size_t>(k)] =
              fn(job, bounds[static_cast<std::size_t>(k)], bounds[static_cast<std::size_t>(k) + 1]);
        } catch (...) {
          ok = false;
          if (fail(k)) {
            failed_chunk = k;
            local_error = std::current_exception();
          }
        }
        finished(k, 0, ok);
        backoff.Reset();
        continue;
      }
      if (got)
        backoff.Reset();
      else
        backoff.Nap();
    }
    FinishSends();
    if (progress_error) std::rethrow_exception(progress_error);
    if (failed_chunk >= 0) {
      if (local_error) std::rethrow_exception(local_error);
      if (failed_kind == kInvalidArgument) throw std::invalid_argument(failed_what);
      throw std::runtime_error(failed_what);
    }
    Buffer out;
    for (const Buffer& b : results) out += b;
    return out;
  }

  void Serve(const ChunkFn& fn) override {
    if (rank_ == 0) return;
    Buffer job;
    std::int64_t job_id = -1;
    Backoff backoff;
    for (;;) {
      MPI_Status st;
      for (;;) {
        int flag = 0;
        Check(MPI_Iprobe(0, MPI_ANY_TAG, comm_, &flag, &st), "MPI_Iprobe");
        if (flag) break;
        backoff.Nap();
      }
      backoff.Reset();
      const Buffer msg = Receive(st);
      Reader r(msg);
      if (st.MPI_TAG == kTagStop) break;
      if (st.MPI_TAG == kTagJob) {
        job_id = r.Get<std::int64_t>();
        job = msg.substr(sizeof(std::int64_t));
        continue;
      }
      if (st.MPI_TAG != kTagChunk)
        throw std::logic_error("parallel::Serve: unexpected tag " + std::to_string(st.MPI_TAG));
      const auto id = r.Get<std::int64_t>();
      const auto begin = r.Get<std::int32_t>(), end = r.Get<std::int32_t>();
      if (id != job_id) throw std::logic_error("parallel::Serve: chunk of an unknown job");
      Buffer reply(1, static_cast<char>(kOk));
      try {
        reply += fn(job, begin, end);
      } catch (const std::invalid_argument& e) {
        reply.assign(1, static_cast<char>(kInvalidArgument));
        reply += e.what();
      } catch (const std::exception& e) {
        reply.assign(1, static_cast<char>(kOtherError));
        reply += "rank " + std::to_string(rank_) + ": " + e.what();
      } catch (...) {
        reply.assign(1, static_cast<char>(kOtherError));
        reply += "rank " + std::to_string(rank_) + ": unknown exception";
      }
      items_[static_cast<std::size_t>(rank_)] += end - begin;
      FinishSends();  // the previous result has been taken: one send in flight at a time
      Send(std::move(reply), 0, kTagResult);
    }
    FinishSends();
  }

 private:
  Buffer Receive(const MPI_Status& st) {
    int count = 0;
    Check(MPI_Get_count(&st, MPI_BYTE, &count), "MPI_Get_count");
    Buffer b(static_cast<std::size_t>(count), '\0');
    Check(MPI_Recv(b.data(), count, MPI_BYTE, st.MPI_SOURCE, st.MPI_TAG, comm_, MPI_STATUS_IGNORE),
          "MPI_Recv");
    return b;
  }

  // Non-blocking sends: the buffer lives in sends_ until FinishSends.
  void Send(Buffer msg, int to, int tag) {
    if (msg.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
      throw std::runtime_error("parallel: message of " + std::to_string(msg.size()) +
                               " bytes exceeds MPI's int count");
    sends_.push_back(std::move(msg));
    requests_.emplace_back();
    Check(MPI_Isend(sends_.back().data(), static_cast<int>(sends_.back().size()), MPI_BYTE, to, tag,
                    comm_, &requests_.back()),
          "MPI_Isend");
  }

  void FinishSends() {
    if (requests_.empty()) return;
    // Polite wait (MPI_Waitall spins).
    Backoff backoff;
    for (;;) {
      int flag = 0;
      MPI_Testall(static_cast<int>(requests_.size()), requests_.data(), &flag, MPI_STATUSES_IGNORE);
      if (flag) break;
      backoff.Nap();
    }
    requests_.clear();
    sends_.clear();
  }

  int size_ = 1, rank_ = 0;
  MPI_Comm comm_ = MPI_COMM_NULL;
  bool stopped_ = false;
  std::int64_t job_id_ = 0;
  std::vector<long long> items_;
  std::list<Buffer> sends_;  // stable addresses while their MPI_Isend runs
  std::vector<MPI_Request> requests_;
};

#endif  // VINCI_HAVE_MPI

}  // namespace

int MpirunWorldSize() {
  const int n = EnvInt("OMPI_COMM_WORLD_SIZE", 1);
  if (n < 1) throw std::invalid_argument("OMPI_COMM_WORLD_SIZE: expected an integer >= 1, got 0");
  return n;
}

bool MpiAvailable() {
#ifdef VINCI_HAVE_MPI
  return true;
#else
  return false;
#endif
}

std::unique_ptr<Distributor> MakeDistributor() {
  const int n = MpirunWorldSize();
  if (n == 1) return std::make_unique<LocalDistributor>();
#ifdef VINCI_HAVE_MPI
  if (g_initialized) throw std::logic_error("parallel::MakeDistributor: MPI is initialized once");
  return std::make_unique<MpiDistributor>();
#else
  throw std::invalid_argument("mpirun: started with " + std::to_string(n) +
                              " processes, but this vinci was built without MPI (CMake option "
                              "VINCI_MPI, Debian package libopenmpi-dev)");
#endif
}

}  // namespace vinci::parallel
