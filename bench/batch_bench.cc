// Batch scaling (simulator/batch.h; issue 16 deliverable 6, bench/README.md "batch_bench"): the
// same batch workloads on 1 and 2 threads (or --threads LIST) in one run, wall and process CPU
// time, and whether the results are bit-identical across thread counts.
//
//   feeder-search      the feeder design search's unit of work (examples/design/feeder.yaml):
//                      ThreadEvaluator::Evaluate of one design on the spec's 20 samples, for D
//                      designs one call after the other (NLopt asks for one design at a time)
//   feeder-screening   the same designs through the spec's short screening stage (5 samples of
//                      0.4 s, `until`): the search's smallest batches
//   feeder-validation  one Evaluate call of the start design on V samples (the final fresh-sample
//                      re-evaluation: many tasks in one batch)
//   field              ComputeVelocityField of plate_whirlpool.yaml, NX x NY points, K cycles
//                      (21 x 21 x 50 is `vinci field examples/scenes/plate_whirlpool.yaml
//                      --grid 21x21 --cycles 50`)
//   rollouts           BatchRollouts of 100 rollouts of block_sliding.yaml, 300 steps each
//
// Besides the timed runs, each workload is run once more on one thread with every task timed
// alone (thread CPU time). From those task times the "schedule bound" is the speedup that
// dynamic scheduling in index order (what RunBatch does) gives on T threads if nothing but the
// split of the work limited it: total / makespan, per batch. It is measured in CPU time, so it is
// meaningful on a loaded machine where the wall times are not. "CPU T/1" is the process CPU of
// the T-thread run over the 1-thread run: above 1, threads slow each other down (contention,
// shared caches, hyper-threads).
//
// Exit status: 0, 1 if a workload's results differ between thread counts or a run fails, 2 for
// bad arguments.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <queue>
#include <sstream>
#include <string>
#include <vector>

#include "vinci/design/evaluate.h"
#include "vinci/design/spec.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/batch.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci {
namespace {

using sim::Vector2d;
using sim::VectorXd;

std::string SourcePath(const std::string& rel) { return std::string(VINCI_SOURCE_DIR "/") + rel; }

double Now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double CpuSeconds(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
double ProcessCpu() { return CpuSeconds(CLOCK_PROCESS_CPUTIME_ID); }
double ThreadCpu() { return CpuSeconds(CLOCK_THREAD_CPUTIME_ID); }

// Appends the bytes of doubles / ints: results are compared bit for bit.
class Fingerprint {
 public:
  void Add(double v) { bytes_.append(reinterpret_cast<const char*>(&v), sizeof v); }
  void Add(long long v) { bytes_.append(reinterpret_cast<const char*>(&v), sizeof v); }
  void Add(const std::string& s) { bytes_ += s; }
  void Add(const VectorXd& v) {
    for (Eigen::Index k = 0; k < v.size(); ++k) Add(v[k]);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// What one workload needs: a run on T threads returning its fingerprint, and the per-task CPU
// times on one thread, grouped by batch (one RunBatch call each).
struct Workload {
  std::string name;
  std::string what;
  long long steps = 0;  // simulated steps per run (at most; rollouts may stop early)
  int tasks = 0;
  std::function<std::string(int threads)> run;
  std::function<std::vector<std::vector<double>>()> task_times;
};

// Makespan of dynamic scheduling in index order on `threads` workers: each task starts on the
// worker that becomes free first.
double Makespan(const std::vector<double>& times, int threads) {
  std::priority_queue<double, std::vector<double>, std::greater<double>> free_at;
  for (int t = 0; t < threads; ++t) free_at.push(0.0);
  double end = 0.0;
  for (const double d : times) {
    const double start = free_at.top();
    free_at.pop();
    free_at.push(start + d);
    end = std::max(end, start + d);
  }
  return end;
}

// ----- feeder ----------------------------------------------------------------------------------

struct Feeder {
  design::DesignSpec spec;
  std::unique_ptr<design::DesignProblem> problem;
  std::vector<VectorXd> designs;  // the start design, then points spread over the design box
};

// The spec's short screening stage as the search runs it (design::Screener's ShortStage): the
// stage's horizon, samples, success set and options.
std::shared_ptr<Feeder> ScreeningStage(const Feeder& full) {
  auto f = std::make_shared<Feeder>();
  f->spec = full.spec;
  f->spec.screening.clear();
  for (const design::ScreeningStage& st : full.spec.screening) {
    if (st.type != design::StageType::kShort) continue;
    f->spec.duration = st.duration;
    f->spec.samples = st.samples;
    f->spec.objective = st.objective;
    f->spec.scene.options = st.options;
    f->problem = std::make_unique<design::DesignProblem>(f->spec);
    f->designs = full.designs;
    return f;
  }
  throw std::runtime_error("feeder.yaml has no short screening stage");
}

std::shared_ptr<Feeder> MakeFeeder(int designs) {
  auto f = std::make_shared<Feeder>();
  f->spec = design::LoadDesignSpec(SourcePath("examples/design/feeder.yaml"));
  f->problem = std::make_unique<design::DesignProblem>(f->spec);
  const VectorXd lo = f->problem->lower(), hi = f->problem->upper();
  f->designs.push_back(f->problem->start());
  // A Kronecker sequence (fractional parts of d·√p): deterministic and spread over the box.
  const double primes[] = {2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37};
  for (int d = 1; d < designs; ++d) {
    VectorXd x(lo.size());
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double a = std::sqrt(primes[k % 12]);
      const double u = d * a - std::floor(d * a);
      x[k] = lo[k] + (hi[k] - lo[k]) * (0.1 + 0.8 * u);
    }
    f->designs.push_back(x);
  }
  return f;
}

void AddEvaluations(const std::vector<design::Evaluation>& es, Fingerprint* fp) {
  for (const design::Evaluation& e : es) {
    fp->Add(e.objective);
    fp->Add(e.loss);
    fp->Add(static_cast<long long>(e.successes));
    fp->Add(static_cast<long long>(e.failures));
    fp->Add(e.first_failure);
  }
}

// Task CPU times of Evaluate(requests), one batch: the samples run one by one as
// RunSampleTasks runs them (a fresh workspace per design).
std::vector<double> SampleTimes(const Feeder& f, const std::vector<design::EvalRequest>& requests) {
  std::vector<double> times;
  for (const design::EvalRequest& r : requests) {
    const std::shared_ptr<const sim::Simulator> s = f.problem->SimulatorFor(r.x);
    sim::Workspace ws;
    for (int i = 0; i < r.samples; ++i) {
      const double t0 = ThreadCpu();
      f.problem->RunSample(*s, r.x, r.stream, i, &ws);
      times.push_back(ThreadCpu() - t0);
    }
  }
  return times;
}

long long FeederSteps(const Feeder& f) {
  return std::max(1L, std::lround(f.spec.duration / f.spec.scene.options.dt));
}

Workload FeederSearch(int designs, bool screening) {
  std::shared_ptr<Feeder> f = MakeFeeder(designs);
  if (screening) f = ScreeningStage(*f);
  Workload w;
  w.name = screening ? "feeder-screening" : "feeder-search";
  const int samples = f->spec.samples;
  w.what = std::to_string(designs) + " designs x " + std::to_string(samples) +
           " samples, one Evaluate call per design";
  w.tasks = designs * samples;
  w.steps = static_cast<long long>(w.tasks) * FeederSteps(*f);
  w.run = [f, samples](int threads) {
    design::ThreadEvaluator ev(*f->problem, threads);
    Fingerprint fp;
    for (const VectorXd& x : f->designs)
      AddEvaluations(ev.Evaluate({design::EvalRequest{x, f->spec.seed, samples}}), &fp);
    return fp.bytes();
  };
  w.task_times = [f, samples]() {
    std::vector<std::vector<double>> batches;
    for (const VectorXd& x : f->designs)
      batches.push_back(SampleTimes(*f, {design::EvalRequest{x, f->spec.seed, samples}}));
    return batches;
  };
  return w;
}

Workload FeederValidation(int samples) {
  const std::shared_ptr<Feeder> f = MakeFeeder(1);
  Workload w;
  w.name = "feeder-validation";
  w.what = "start design x " + std::to_string(samples) + " samples, one Evaluate call";
  w.tasks = samples;
  w.steps = static_cast<long long>(samples) * FeederSteps(*f);
  const design::EvalRequest request{f->designs[0], design::FreshStream(f->spec.seed), samples};
  w.run = [f, request](int threads) {
    design::ThreadEvaluator ev(*f->problem, threads);
    Fingerprint fp;
    AddEvaluations(ev.Evaluate({request}), &fp);
    return fp.bytes();
  };
  w.task_times = [f, request]() {
    return std::vector<std::vector<double>>{SampleTimes(*f, {request})};
  };
  return w;
}

// ----- field -----------------------------------------------------------------------------------

Workload Field(int nx, int ny, int cycles) {
  const std::string path = SourcePath("examples/scenes/plate_whirlpool.yaml");
  auto sim = std::make_shared<const sim::Simulator>(sim::LoadSceneFile(path));
  sim::FieldSpec spec = sim::LoadFieldSpec(path, sim->scene());
  spec.nx = nx;
  spec.ny = ny;
  spec.cycles = cycles;
  spec.average_cycles = std::min(spec.average_cycles, cycles);
  Workload w;
  w.name = "field";
  w.what = "whirlpool " + std::to_string(nx) + "x" + std::to_string(ny) + " points x " +
           std::to_string(cycles) + " cycles";
  w.tasks = nx * ny;
  w.steps = static_cast<long long>(w.tasks) * cycles * spec.StepsPerCycle(sim->scene().options.dt);
  w.run = [sim, spec](int threads) {
    sim::FieldOptions o;
    o.threads = threads;
    const sim::VelocityField f = sim::ComputeVelocityField(*sim, sim->DefaultParams(), spec, o);
    Fingerprint fp;
    for (const sim::FieldPoint& p : f.points) {
      for (const double v : {p.vx, p.vy, p.omega, p.x_mean, p.y_mean, p.averaged_time}) fp.Add(v);
      fp.Add(static_cast<long long>(p.left_plate * 2 + p.failed));
    }
    return fp.bytes();
  };
  w.task_times = [sim, spec]() {
    std::vector<double> times;
    sim::Workspace ws;
    const sim::Params params = sim->DefaultParams();
    for (int i = 0; i < spec.nx * spec.ny; ++i) {
      const Vector2d p = sim::FieldGridPoint(spec, i);
      const double t0 = ThreadCpu();
      sim::ComputeFieldPoint(*sim, params, spec, p.x(), p.y(), &ws);
      times.push_back(ThreadCpu() - t0);
    }
    return std::vector<std::vector<double>>{times};
  };
  return w;
}

// ----- rollouts --------------------------------------------------------------------------------

Workload Rollouts(int n) {
  auto sim = std::make_shared<const sim::Simulator>(
      sim::LoadSceneFile(SourcePath("examples/scenes/block_sliding.yaml")));
  const int mu = sim->scene().param_table().Index("mu.default");
  constexpr int kSteps = 300;
  auto tasks = std::make_shared<std::vector<sim::RolloutTask>>(n);
  for (int i = 0; i < n; ++i) {
    sim::Params p = sim->DefaultParams();
    p.values[mu] = 0.1 + 0.5 * i / std::max(1, n - 1);
    (*tasks)[i].params = p;
    (*tasks)[i].num_steps = kSteps;
  }
  sim::BatchRolloutOptions options;
  options.state_stride = 0;
  options.step_reports = false;
  Workload w;
  w.name = "rollouts";
  w.what =
      std::to_string(n) + " rollouts of block_sliding.yaml x " + std::to_string(kSteps) + " steps";
  w.tasks = n;
  w.steps = static_cast<long long>(n) * kSteps;
  w.run = [sim, tasks, options](int threads) {
    sim::BatchRolloutOptions o = options;
    o.threads = threads;
    Fingerprint fp;
    for (const sim::RolloutResult& r : sim::BatchRollouts(*sim, *tasks, o)) {
      if (r.status != sim::TaskStatus::kOk) throw std::runtime_error("a rollout threw: " + r.error);
      fp.Add(static_cast<long long>(r.steps_done));
      fp.Add(r.trajectory.states.back().q);
      fp.Add(r.trajectory.states.back().v);
    }
    return fp.bytes();
  };
  w.task_times = [sim, tasks, options]() {
    std::vector<double> times;
    sim::Workspace ws;
    sim::RolloutResult r;
    for (const sim::RolloutTask& t : *tasks) {
      const double t0 = ThreadCpu();
      sim::RunRollout(*sim, t, options, &ws, &r);
      times.push_back(ThreadCpu() - t0);
    }
    return std::vector<std::vector<double>>{times};
  };
  return w;
}

// ----- driver ----------------------------------------------------------------------------------

struct Timing {
  double wall = 1e300, cpu = 1e300;  // best (lowest) of the repetitions, each
};

std::vector<int> ParseList(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const int v = std::atoi(item.c_str());
    if (v < 1) throw std::invalid_argument("expected a list of integers >= 1, got '" + text + "'");
    out.push_back(v);
  }
  if (out.empty()) throw std::invalid_argument("expected a non-empty list");
  return out;
}

void Usage() {
  std::cerr << "usage: batch_bench [--quick] [--reps N] [--threads 1,2] [--only NAME,...]\n"
               "                   [--designs D] [--validation V] [--field-grid NXxNY]\n"
               "                   [--field-cycles K] [--rollouts N] [--csv FILE]\n"
               "workloads: feeder-search feeder-screening feeder-validation field rollouts\n"
               "(bench/README.md)\n";
}

int Main(int argc, char** argv) {
  int reps = 3, designs = 8, validation = 200, nx = 21, ny = 21, cycles = 10, rollouts = 100;
  std::vector<int> threads = {1, 2};
  std::vector<std::string> only;
  std::string csv;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + ": expected a value");
      return argv[++i];
    };
    if (a == "--quick") {
      reps = 1;
      designs = 1;
      validation = 8;
      nx = ny = 3;
      cycles = 1;
      rollouts = 8;
    } else if (a == "--reps") {
      reps = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--threads") {
      threads = ParseList(value());
    } else if (a == "--only") {
      std::stringstream ss(value());
      std::string item;
      while (std::getline(ss, item, ',')) only.push_back(item);
    } else if (a == "--designs") {
      designs = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--validation") {
      validation = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--field-grid") {
      const std::string g = value();
      if (std::sscanf(g.c_str(), "%dx%d", &nx, &ny) != 2 || nx < 1 || ny < 1)
        throw std::invalid_argument("--field-grid: expected NXxNY, got '" + g + "'");
    } else if (a == "--field-cycles") {
      cycles = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--rollouts") {
      rollouts = std::max(1, std::atoi(value().c_str()));
    } else if (a == "--csv") {
      csv = value();
    } else {
      Usage();
      return 2;
    }
  }
  const auto wanted = [&](const std::string& name) {
    return only.empty() || std::find(only.begin(), only.end(), name) != only.end();
  };
  std::vector<std::function<Workload()>> makers;
  if (wanted("feeder-search")) makers.push_back([&] { return FeederSearch(designs, false); });
  if (wanted("feeder-screening")) makers.push_back([&] { return FeederSearch(designs, true); });
  if (wanted("feeder-validation")) makers.push_back([&] { return FeederValidation(validation); });
  if (wanted("field")) makers.push_back([&] { return Field(nx, ny, cycles); });
  if (wanted("rollouts")) makers.push_back([&] { return Rollouts(rollouts); });
  if (makers.empty()) {
    Usage();
    return 2;
  }

  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) < 0) load[0] = -1;
  std::printf("batch_bench: %d repetition(s), best wall and best CPU of each; load average %.2f\n",
              reps, load[0]);
  std::printf("%-18s %6s %9s %3s %10s %10s %8s %8s %9s %8s %s\n", "workload", "tasks", "steps", "T",
              "wall (s)", "CPU (s)", "speedup", "CPU T/1", "sched.bnd", "µs/step", "identical");
  std::ofstream csv_out;
  if (!csv.empty()) {
    csv_out.open(csv);
    csv_out << "workload,what,tasks,steps,threads,wall_s,cpu_s,speedup_wall,cpu_ratio,"
               "schedule_bound,cpu_us_per_step,identical\n";
  }
  bool all_identical = true;
  for (const auto& make : makers) {
    const Workload w = make();
    // Task times first (one thread, each task timed alone).
    const std::vector<std::vector<double>> batches = w.task_times();
    double total = 0.0;
    for (const auto& b : batches)
      for (const double t : b) total += t;
    std::string reference;
    Timing one;
    for (const int t : threads) {
      Timing best;
      bool identical = true;
      for (int r = 0; r < reps; ++r) {
        const double w0 = Now(), c0 = ProcessCpu();
        const std::string fp = w.run(t);
        const double wall = Now() - w0, cpu = ProcessCpu() - c0;
        best.wall = std::min(best.wall, wall);
        best.cpu = std::min(best.cpu, cpu);
        if (reference.empty()) reference = fp;
        identical = identical && fp == reference;
      }
      if (t == threads.front()) one = best;
      all_identical = all_identical && identical;
      double makespan = 0.0;
      for (const auto& b : batches) makespan += Makespan(b, t);
      const double bound = makespan > 0.0 ? total / makespan : 1.0;
      const double speedup = one.wall / best.wall, cpu_ratio = best.cpu / one.cpu;
      const double us_per_step = 1e6 * best.cpu / static_cast<double>(std::max(1LL, w.steps));
      std::printf("%-18s %6d %9lld %3d %10.3f %10.3f %7.2fx %8.3f %8.2fx %8.2f %s\n",
                  w.name.c_str(), w.tasks, w.steps, t, best.wall, best.cpu, speedup, cpu_ratio,
                  bound, us_per_step, identical ? "yes" : "NO");
      if (csv_out)
        csv_out << w.name << ",\"" << w.what << "\"," << w.tasks << "," << w.steps << "," << t
                << "," << best.wall << "," << best.cpu << "," << speedup << "," << cpu_ratio << ","
                << bound << "," << us_per_step << "," << (identical ? 1 : 0) << "\n";
    }
    std::printf("%-18s (%s; task CPU on 1 thread: total %.3f s, %zu batch(es))\n", "",
                w.what.c_str(), total, batches.size());
    std::fflush(stdout);
  }
  if (!all_identical) {
    std::fprintf(stderr, "batch_bench: results differ between thread counts\n");
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace vinci

int main(int argc, char** argv) {
  try {
    return vinci::Main(argc, argv);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "batch_bench: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "batch_bench: %s\n", e.what());
    return 1;
  }
}
