// mpec_bench: time and Ipopt iterations of the MPEC estimator (docs/estimation.md) on
// synthetic logs of 500 samples — a block sliding to rest (μ = 0.3) and a box on a vibrating
// plate (μ = 0.2), without and with noise — for both complementarity treatments and 1 / 2
// threads (checking that the two give bit-identical estimates). Prints a table (and writes it as
// CSV with --csv FILE). --quick: 50 samples, one configuration (the ctest smoke run);
// --case NAME: only that case (block, block_noisy, plate, plate_noisy); --method scholtes|penalty;
// --threads 1,2; --raw-guess: the initial guess from the raw log (MpecOptions::
// smooth_initial_guess off); --tracking-guess (MpecOptions::tracking_guess); --penalty START (the
// first ρ); --epsilon START FACTOR; --stall N; --relaxation-curvature 0|1
// (MpecSolverOptions::relaxation_curvature); --push-per-epsilon X
// (MpecSolverOptions::warm_start_push_per_epsilon); --cold-push X
// (MpecSolverOptions::cold_bound_push); --seed N (the noise's generator, default 7); --predictor
// 0|1 (MpecSolverOptions::epsilon_predictor); --early-polish-rise K
// (MpecSolverOptions::early_polish_rise_factor); --early-polish-epsilon E
// (MpecSolverOptions::early_polish_epsilon); --lsq-start N (MpecOptions::least_squares_start,
// N Ceres iterations per fit) with --lsq-horizon H, --lsq-growth G; --ordering auto|scotch|qamd
// (MpecSolverOptions::ordering); --help. An unknown flag or a
// missing value is an error (exit 2). Environment: MPEC_BENCH_VERBOSE=1 (progress lines),
// MPEC_BENCH_IPOPT_PRINT=N (Ipopt's print_level), MPEC_BENCH_SAMPLES=N (N samples instead of 500).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/estimation/log.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace {

using namespace vinci;

const char* kBlock =
    "dimension: 2\n"
    "gravity: [0, -9.81]\n"
    "stepper: {dt: 0.002, envelope: 0.002}\n"
    "friction: {default: 0.5}\n"
    "bodies:\n"
    "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
    "  - name: block\n"
    "    mass: 1.0\n"
    "    pose: {position: [0, 0.1]}\n"
    "    velocity: {linear: [1.5, 0]}\n"
    "    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], "
    "[-0.2, 0.1]]}]\n";

// A 20 g box (4 × 1 cm) on a plate vibrating at 20 Hz (x 20 m/s², y 5 m/s²), sticking and
// slipping twice per cycle; μ = 0.2 (the scene says 0.5). Shared with the MPEC tests.
const std::string kPlateFile =
    std::string(VINCI_SOURCE_DIR) + "/tests/data/scenes/plate_box_planar.yaml";

// Simulates with mu.default = mu and writes `samples` samples (every step) of the body's x, y,
// θ with N(0, sigma²) position noise (angles sigma / 0.1 m).
std::string WriteLog(const sim::Simulator& s, const std::string& body, double mu, int samples,
                     double sigma, unsigned seed, const std::string& path) {
  sim::Params p = s.DefaultParams();
  p.values[s.scene().param_table().Index("mu.default")] = mu;
  const sim::Trajectory tr = s.Rollout(p, s.InitialState(), samples - 1);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int qo = s.scene().index(s.scene().FindBody(body)).q;
  std::ofstream f(path);
  f << "t," << body << ".x," << body << ".y," << body << ".theta\n";
  char buf[160];
  for (const sim::State& x : tr.states) {
    std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g\n", x.t, x.q[qo] + sigma * n01(rng),
                  x.q[qo + 1] + sigma * n01(rng), x.q[qo + 2] + sigma / 0.1 * n01(rng));
    f << buf;
  }
  return path;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string csv, only, only_method;
  std::vector<int> thread_counts{1, 2};
  double epsilon_start = 0.0, epsilon_factor = 0.0;  // 0: the estimator's defaults
  int stall = -1;                                    // < 0: the estimator's default
  double penalty_start = 0.0;  // --penalty START: MpecSolverOptions::penalty_start (0: default)
  bool raw_guess = false;      // --raw-guess: MpecOptions::smooth_initial_guess off
  bool tracking = false;       // --tracking-guess: MpecOptions::tracking_guess on
  int lsq_start = 0;     // --lsq-start N: MpecOptions::least_squares_start, N iterations (0: off)
  int lsq_horizon = -1;  // --lsq-horizon H: MpecOptions::least_squares_horizon
  double lsq_growth = -1.0;  // --lsq-growth G: MpecOptions::least_squares_horizon_growth
  double push = -1.0;        // --push-per-epsilon X: MpecSolverOptions::warm_start_push_per_epsilon
  double cold_push = -1.0;   // --cold-push X: MpecSolverOptions::cold_bound_push
  unsigned seed = 7;         // --seed N: the noise's generator
  int predictor = -1;        // --predictor 0|1: MpecSolverOptions::epsilon_predictor
  double polish_eps = -1.0;  // --early-polish-epsilon E: MpecSolverOptions::early_polish_epsilon
  double rise = -1.0;        // --early-polish-rise K: MpecSolverOptions::early_polish_rise_factor
  int curvature = -1;        // --relaxation-curvature 0|1: MpecSolverOptions::relaxation_curvature
  // --ordering NAME: MpecSolverOptions::ordering (none: the estimator's default).
  std::optional<estimation::MpecSolverOptions::Ordering> ordering;
  const char* usage =
      "usage: mpec_bench [--quick] [--case block|block_noisy|plate|plate_noisy]\n"
      "                  [--method scholtes|penalty] [--threads N[,N...]] [--csv FILE]\n"
      "                  [--raw-guess] [--tracking-guess] [--lsq-start N] [--penalty START]\n"
      "                  [--epsilon START "
      "FACTOR]\n"
      "                  [--stall N] [--push-per-epsilon C] [--cold-push X] [--seed N]\n"
      "                  [--predictor 0|1]\n"
      "                  [--early-polish-rise K] [--early-polish-epsilon E]\n"
      "                  [--relaxation-curvature 0|1] [--ordering auto|scotch|qamd]\n"
      "environment: MPEC_BENCH_SAMPLES=N (default 500), MPEC_BENCH_VERBOSE=1 (stage log),\n"
      "             MPEC_BENCH_IPOPT_PRINT=N (Ipopt's print_level)\n";
  for (int i = 1; i < argc; ++i) {
    // True if argv[i] is `name` with `values` arguments after it.
    auto flag = [&](const char* name, int values) {
      return !std::strcmp(argv[i], name) && i + values < argc;
    };
    if (flag("--quick", 0)) {
      quick = true;
    } else if (flag("--raw-guess", 0)) {
      raw_guess = true;
    } else if (flag("--lsq-start", 1)) {
      lsq_start = std::atoi(argv[++i]);
    } else if (flag("--lsq-horizon", 1)) {
      lsq_horizon = std::atoi(argv[++i]);
    } else if (flag("--lsq-growth", 1)) {
      lsq_growth = std::atof(argv[++i]);
    } else if (flag("--tracking-guess", 0)) {
      tracking = true;
    } else if (flag("--penalty", 1)) {
      penalty_start = std::atof(argv[++i]);
    } else if (flag("--csv", 1)) {
      csv = argv[++i];
    } else if (flag("--case", 1)) {
      only = argv[++i];
    } else if (flag("--method", 1)) {
      only_method = argv[++i];
    } else if (flag("--epsilon", 2)) {
      epsilon_start = std::atof(argv[++i]);
      epsilon_factor = std::atof(argv[++i]);
    } else if (flag("--stall", 1)) {
      stall = std::atoi(argv[++i]);
    } else if (flag("--push-per-epsilon", 1)) {
      push = std::atof(argv[++i]);
    } else if (flag("--cold-push", 1)) {
      cold_push = std::atof(argv[++i]);
    } else if (flag("--seed", 1)) {
      seed = static_cast<unsigned>(std::strtoul(argv[++i], nullptr, 10));
    } else if (flag("--predictor", 1)) {
      predictor = std::atoi(argv[++i]);
    } else if (flag("--early-polish-rise", 1)) {
      rise = std::atof(argv[++i]);
    } else if (flag("--early-polish-epsilon", 1)) {
      polish_eps = std::atof(argv[++i]);
    } else if (flag("--ordering", 1)) {
      try {
        ordering = estimation::ParseMpecOrdering(argv[++i]);
      } catch (const std::invalid_argument& e) {
        std::fprintf(stderr, "mpec_bench: --ordering: %s\n", e.what());
        return 2;
      }
    } else if (flag("--relaxation-curvature", 1)) {
      curvature = std::atoi(argv[++i]);
    } else if (flag("--threads", 1)) {
      thread_counts.clear();
      for (const char* p = argv[++i]; *p;) {
        char* end = nullptr;
        thread_counts.push_back(static_cast<int>(std::strtol(p, &end, 10)));
        p = *end == ',' ? end + 1 : end;
        if (end == p && *p) break;
      }
    } else if (!std::strcmp(argv[i], "--help") || !std::strcmp(argv[i], "-h")) {
      std::fputs(usage, stdout);
      return 0;
    } else {
      std::fprintf(stderr, "mpec_bench: unknown option or missing value '%s'\n%s", argv[i], usage);
      return 2;
    }
  }
  if (!only_method.empty()) {
    try {
      estimation::ParseComplementarityMethod(only_method);
    } catch (const std::invalid_argument& e) {
      std::fprintf(stderr, "mpec_bench: --method: %s\n", e.what());
      return 2;
    }
  }
  // MPEC_BENCH_SAMPLES=N: N samples instead of 500 (experiments).
  const char* ns = std::getenv("MPEC_BENCH_SAMPLES");
  const int samples = quick ? 50 : ns ? std::atoi(ns) : 500;
  const std::string dir = std::filesystem::temp_directory_path().string();
  struct Case {
    const char* name;
    bool plate;  // the plate scene file, else the block
    const char* body;
    double mu;
    double sigma;
  };
  const std::vector<Case> all_cases{{"block", false, "block", 0.3, 0.0},
                                    {"block_noisy", false, "block", 0.3, 1e-3},
                                    {"plate", true, "box", 0.2, 0.0},
                                    {"plate_noisy", true, "box", 0.2, 1e-5}};
  if (!only.empty() && std::none_of(all_cases.begin(), all_cases.end(),
                                    [&](const Case& c) { return only == c.name; })) {
    std::fprintf(stderr,
                 "mpec_bench: --case '%s' (expected block, block_noisy, plate or plate_noisy)\n",
                 only.c_str());
    return 2;
  }
  const std::vector<Case> cases = quick ? std::vector<Case>{all_cases.front()} : all_cases;
  int mismatches = 0;
  std::string table =
      "case,complementarity,threads,samples,steps,unknowns,constraints,pairs,iterations,stages,"
      "time_s,cpu_s,mu_hat,std_error,complementarity_violation,converged\n";
  std::printf("%-12s %-9s %3s %7s %6s %8s %8s %6s %6s %8s %8s %10s %10s %9s %s\n", "case", "method",
              "thr", "samples", "steps", "unknowns", "constr", "iters", "NLPs", "time_s", "cpu_s",
              "mu_hat", "std_err", "compl", "conv");
  for (const Case& c : cases) {
    if (!only.empty() && only != c.name) continue;
    const sim::Simulator s(c.plate ? sim::LoadSceneFile(kPlateFile)
                                   : sim::ParseScene(kBlock, "block.yaml"));
    const std::string path =
        WriteLog(s, c.body, c.mu, samples, c.sigma, seed, dir + "/mpec_bench_" + c.name + ".csv");
    const estimation::Log log = estimation::ReadLog({path}, s.scene());
    for (const auto method : {estimation::ComplementarityMethod::kScholtes,
                              estimation::ComplementarityMethod::kPenalty}) {
      if (!only_method.empty() && only_method != estimation::ToString(method)) continue;
      double mu_first = 0.0;
      for (std::size_t ti = 0; ti < thread_counts.size(); ++ti) {
        const int threads = thread_counts[ti];
        if (quick && (ti > 0 || method != estimation::ComplementarityMethod::kScholtes)) continue;
        estimation::MpecOptions o;
        o.params = {"mu.default"};
        o.noise_sigma = c.sigma > 0 ? c.sigma : (c.plate ? 1e-4 : 1e-3);
        o.threads = threads;
        o.solver.method = method;
        o.smooth_initial_guess = !raw_guess;
        o.tracking_guess = tracking;
        o.least_squares_start = lsq_start > 0;
        if (lsq_start > 0) o.least_squares_iterations = lsq_start;
        if (lsq_horizon >= 0) o.least_squares_horizon = lsq_horizon;
        if (lsq_growth > 0) o.least_squares_horizon_growth = lsq_growth;
        if (const char* pl = std::getenv("MPEC_BENCH_IPOPT_PRINT"))
          o.solver.print_level = std::atoi(pl);
        if (penalty_start > 0) o.solver.penalty_start = penalty_start;
        if (epsilon_start > 0) o.solver.epsilon_start = epsilon_start;
        if (epsilon_factor > 0) o.solver.epsilon_factor = epsilon_factor;
        if (stall >= 0) o.solver.stall_iterations = stall;
        if (push >= 0) o.solver.warm_start_push_per_epsilon = push;
        if (cold_push >= 0) o.solver.cold_bound_push = cold_push;
        if (predictor >= 0) o.solver.epsilon_predictor = predictor != 0;
        if (rise >= 0) o.solver.early_polish_rise_factor = rise;
        if (polish_eps > 0) o.solver.early_polish_epsilon = polish_eps;
        if (curvature >= 0) o.solver.relaxation_curvature = curvature != 0;
        if (ordering) o.solver.ordering = *ordering;
        const std::clock_t cpu0 = std::clock();
        // MPEC_BENCH_VERBOSE=1: the estimator's progress lines with the CPU time so far (setup,
        // each NLP; what follows the last NLP is the standard error).
        if (std::getenv("MPEC_BENCH_VERBOSE")) {
          o.progress = [cpu0](const std::string& line) {
            std::fprintf(stderr, "  [cpu %.3f s] %s\n",
                         static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC, line.c_str());
          };
        }
        const estimation::MpecEstimateResult r = estimation::EstimateMpec(s, log, o);
        const double cpu_s = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
        std::printf("%-12s %-9s %3d %7d %6d %8d %8d %6d %6d %8.3f %8.3f %10.6f %10.2e %9.1e %s\n",
                    c.name, estimation::ToString(method), threads, samples, r.num_steps,
                    r.num_unknowns, r.num_constraints, r.iterations, r.stages, r.time_s, cpu_s,
                    r.estimates[0], r.std_errors[0], r.complementarity_violation,
                    r.converged ? "yes" : "no");
        if (std::getenv("MPEC_BENCH_VERBOSE"))
          std::fprintf(stderr, "  mu_hat %.17g std_err %.17g\n", r.estimates[0], r.std_errors[0]);
        std::fflush(stdout);
        char line[400];
        std::snprintf(
            line, sizeof line, "%s,%s,%d,%d,%d,%d,%d,%d,%d,%d,%.6g,%.6g,%.9g,%.3g,%.3g,%d\n",
            c.name, estimation::ToString(method), threads, samples, r.num_steps, r.num_unknowns,
            r.num_constraints, r.num_pairs, r.iterations, r.stages, r.time_s, cpu_s, r.estimates[0],
            r.std_errors[0], r.complementarity_violation, r.converged ? 1 : 0);
        table += line;
        if (quick && !r.converged) return 1;
        if (ti == 0) mu_first = r.estimates[0];
        if (ti > 0 && r.estimates[0] != mu_first) {
          std::printf("  %d threads differ from the first run: %.17g vs %.17g\n", threads,
                      r.estimates[0], mu_first);
          ++mismatches;
        }
      }
    }
  }
  if (!csv.empty()) std::ofstream(csv) << table;
  return mismatches == 0 ? 0 : 1;
}
