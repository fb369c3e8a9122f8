#include "distributed.h"

#include <cstdint>
#include <exception>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "vinci/design/distributed_evaluator.h"
#include "vinci/design/spec.h"
#include "vinci/parallel/wire.h"
#include "vinci/sim/simulator/batch.h"

namespace vinci::cli {
namespace {

// What a worker serves when its setup failed: the error, to every chunk rank 0 sends.
parallel::ChunkFn Failing(int rank, const std::string& what, bool bad_input) {
  return [=](const parallel::Buffer&, int, int) -> parallel::Buffer {
    const std::string m = "rank " + std::to_string(rank) + ": " + what;
    if (bad_input) throw std::invalid_argument(m);
    throw std::runtime_error(m);
  };
}

// The grid points [begin, end) on `threads` threads, encoded.
parallel::Buffer FieldChunk(const sim::Simulator& simulator, const sim::Params& params,
                            const sim::FieldSpec& spec, int threads, int begin, int end) {
  sim::BatchOptions batch;
  batch.threads = threads;
  batch.stop_on_error = true;
  const auto results = sim::BatchMap<sim::Workspace>(
      end - begin,
      [&](int k, sim::Workspace& ws) {
        const sim::Vector2d p = sim::FieldGridPoint(spec, begin + k);
        return sim::ComputeFieldPoint(simulator, params, spec, p.x(), p.y(), &ws);
      },
      batch);
  sim::RethrowFirstError(results);
  parallel::Buffer out;
  parallel::Writer w(&out);
  for (const auto& r : results) {
    const sim::FieldPoint& p = r.value;
    for (double v : {p.x, p.y, p.vx, p.vy, p.omega, p.averaged_time, p.x_mean, p.y_mean})
      w.Put<double>(v);
    w.Put<bool>(p.left_plate);
    w.Put<bool>(p.failed);
    w.PutString(p.failure);
  }
  return out;
}

}  // namespace

ExitCode ServeDesign(const DesignOptions& o, parallel::Distributor& ranks) {
  std::optional<design::DesignSpec> spec;
  std::unique_ptr<design::DesignProblem> problem;
  std::unique_ptr<design::DistributedEvaluator> evaluator;
  try {
    spec = design::LoadDesignSpec(o.spec_path);
    problem = std::make_unique<design::DesignProblem>(*spec);
    evaluator = std::make_unique<design::DistributedEvaluator>(*problem, ranks, o.threads);
  } catch (const std::invalid_argument& e) {
    ranks.Serve(Failing(ranks.rank(), e.what(), true));
    return ExitCode::kOk;
  } catch (const std::exception& e) {
    ranks.Serve(Failing(ranks.rank(), e.what(), false));
    return ExitCode::kOk;
  }
  evaluator->Serve();
  return ExitCode::kOk;
}

sim::VelocityField DistributedVelocityField(parallel::Distributor& ranks,
                                            const sim::Simulator& simulator,
                                            const sim::Params& params, const sim::FieldSpec& spec,
                                            const sim::FieldOptions& options) {
  spec.Validate(simulator.scene());
  if (options.threads < 1)
    throw std::invalid_argument("field: threads must be >= 1, got " +
                                std::to_string(options.threads));
  const int total = spec.nx * spec.ny;
  parallel::MapOptions map;
  map.min_chunk = options.threads;
  map.progress = options.progress;
  const int threads = options.threads;
  const parallel::Buffer out = ranks.Map(
      {}, total,
      [&](const parallel::Buffer&, int b, int e) {
        return FieldChunk(simulator, params, spec, threads, b, e);
      },
      map);
  sim::VelocityField field;
  field.spec = spec;
  field.points.resize(static_cast<std::size_t>(total));
  parallel::Reader r(out);
  for (sim::FieldPoint& p : field.points) {
    for (double* v : {&p.x, &p.y, &p.vx, &p.vy, &p.omega, &p.averaged_time, &p.x_mean, &p.y_mean})
      *v = r.Get<double>();
    p.left_plate = r.Get<bool>();
    p.failed = r.Get<bool>();
    p.failure = r.GetString();
    field.left_plate += p.left_plate ? 1 : 0;
    field.failed += p.failed ? 1 : 0;
  }
  if (!r.done()) throw std::logic_error("DistributedVelocityField: results longer than the grid");
  return field;
}

ExitCode ServeField(const std::function<FieldSetup()>& setup, int threads,
                    parallel::Distributor& ranks) {
  FieldSetup s;
  try {
    s = setup();
  } catch (const std::invalid_argument& e) {
    ranks.Serve(Failing(ranks.rank(), e.what(), true));
    return ExitCode::kOk;
  } catch (const std::exception& e) {
    ranks.Serve(Failing(ranks.rank(), e.what(), false));
    return ExitCode::kOk;
  }
  const sim::Params params = s.simulator->DefaultParams();
  ranks.Serve([&](const parallel::Buffer&, int b, int e) {
    return FieldChunk(*s.simulator, params, s.spec, std::max(1, threads), b, e);
  });
  return ExitCode::kOk;
}

}  // namespace vinci::cli
