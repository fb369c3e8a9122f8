#include "vinci/design/distributed_evaluator.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "vinci/parallel/wire.h"

namespace vinci::design {
namespace {

// Job: [int32 requests] then per request [uint64 stream][int32 samples][int32 size][doubles].
parallel::Buffer EncodeRequests(const std::vector<EvalRequest>& requests) {
  parallel::Buffer b;
  parallel::Writer w(&b);
  w.Put<std::int32_t>(static_cast<std::int32_t>(requests.size()));
  for (const EvalRequest& r : requests) {
    w.Put<std::uint64_t>(r.stream);
    w.Put<std::int32_t>(r.samples);
    w.Put<std::int32_t>(static_cast<std::int32_t>(r.x.size()));
    for (Eigen::Index k = 0; k < r.x.size(); ++k) w.Put<double>(r.x[k]);
  }
  return b;
}

std::vector<EvalRequest> DecodeRequests(const parallel::Buffer& b) {
  parallel::Reader r(b);
  std::vector<EvalRequest> requests(static_cast<std::size_t>(r.Get<std::int32_t>()));
  for (EvalRequest& q : requests) {
    q.stream = r.Get<std::uint64_t>();
    q.samples = r.Get<std::int32_t>();
    q.x.resize(r.Get<std::int32_t>());
    for (Eigen::Index k = 0; k < q.x.size(); ++k) q.x[k] = r.Get<double>();
  }
  return requests;
}

void PutOutcome(parallel::Writer* w, const SampleOutcome& o) {
  w->Put<bool>(o.ok);
  w->Put<bool>(o.success);
  w->Put<double>(o.value);
  w->PutString(o.failure);
}

SampleOutcome GetOutcome(parallel::Reader* r) {
  SampleOutcome o;
  o.ok = r->Get<bool>();
  o.success = r->Get<bool>();
  o.value = r->Get<double>();
  o.failure = r->GetString();
  return o;
}

}  // namespace

DistributedEvaluator::DistributedEvaluator(const DesignProblem& problem,
                                           parallel::Distributor& distributor, int threads)
    : problem_(&problem), distributor_(&distributor), threads_(std::max(1, threads)) {}

parallel::Buffer DistributedEvaluator::RunChunk(const parallel::Buffer& job, int begin, int end) {
  if (job != job_ || requests_.empty()) {
    requests_ = DecodeRequests(job);
    job_ = job;
    sims_.assign(requests_.size(), nullptr);
  }
  // (design, sample) pair t → request r(t), sample i(t), as in ThreadEvaluator.
  std::vector<SampleTask> tasks;
  tasks.reserve(static_cast<std::size_t>(std::max(0, end - begin)));
  int first = 0;
  for (std::size_t r = 0; r < requests_.size() && first < end; ++r) {
    const int n = requests_[r].samples;
    for (int i = std::max(0, begin - first); i < n && first + i < end; ++i)
      tasks.push_back({static_cast<int>(r), i});
    first += n;
  }
  if (static_cast<int>(tasks.size()) != end - begin)
    throw std::logic_error("DistributedEvaluator: chunk [" + std::to_string(begin) + ", " +
                           std::to_string(end) + ") outside the job");
  for (const SampleTask& t : tasks) {
    auto& s = sims_[static_cast<std::size_t>(t.request)];
    if (!s) s = problem_->SimulatorFor(requests_[static_cast<std::size_t>(t.request)].x);
  }
  const std::vector<SampleOutcome> results =
      RunSampleTasks(*problem_, requests_, sims_, tasks, threads_);
  parallel::Buffer out;
  parallel::Writer w(&out);
  for (const SampleOutcome& r : results) PutOutcome(&w, r);
  return out;
}

std::vector<Evaluation> DistributedEvaluator::Evaluate(const std::vector<EvalRequest>& requests) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  long long total = 0;
  for (const EvalRequest& r : requests) {
    if (r.x.size() != problem_->size())
      throw std::invalid_argument("DistributedEvaluator: design vector of size " +
                                  std::to_string(r.x.size()) + ", expected " +
                                  std::to_string(problem_->size()));
    if (r.samples < 0)
      throw std::invalid_argument("DistributedEvaluator: samples must be >= 0, got " +
                                  std::to_string(r.samples));
    total += r.samples;
  }
  if (total > std::numeric_limits<std::int32_t>::max())
    throw std::invalid_argument("DistributedEvaluator: " + std::to_string(total) +
                                " samples in one call exceed 2^31 - 1");
  parallel::MapOptions options;
  options.min_chunk = threads_;
  const parallel::Buffer out = distributor_->Map(
      EncodeRequests(requests), static_cast<int>(total),
      [this](const parallel::Buffer& job, int b, int e) { return RunChunk(job, b, e); }, options);
  parallel::Reader reader(out);
  const double per = std::chrono::duration<double>(Clock::now() - start).count() /
                     std::max<std::size_t>(1, requests.size());
  std::vector<Evaluation> result;
  result.reserve(requests.size());
  for (const EvalRequest& r : requests) {
    std::vector<SampleOutcome> outcomes;
    outcomes.reserve(static_cast<std::size_t>(r.samples));
    for (int i = 0; i < r.samples; ++i) outcomes.push_back(GetOutcome(&reader));
    result.push_back(problem_->Summarize(r.x, r.stream, outcomes, per));
  }
  if (!reader.done()) throw std::logic_error("DistributedEvaluator: results longer than the job");
  return result;
}

void DistributedEvaluator::Serve() {
  distributor_->Serve(
      [this](const parallel::Buffer& job, int b, int e) { return RunChunk(job, b, e); });
}

}  // namespace vinci::design
