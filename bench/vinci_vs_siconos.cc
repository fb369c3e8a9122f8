// vinci's LCP solvers vs Siconos numerics (Debian libsiconos-numerics-dev 4.4) on the same
// problems: contact LCPs of the Stewart–Trinkle step taken from box stacks (1..20 boxes), box
// pyramids and the box pile (examples/scenes/box_pile.yaml), the recorded files
// tests/data/lcp/*.lcp, and the MCPs Josephy, Kojima–Shindo and the 4×4 box MCP. Prints success
// counts and median time ratios per solver pair and size bucket.
//
//   vinci_vs_siconos [--quick] [--reps N] [--max-n N] [--csv FILE]
//
// --max-n N keeps only the LCPs with at most N unknowns (default 500), for repeated runs of the
// small-size buckets.
//
// Every solve is cold (no warm start). Success is judged independently of both libraries:
// vinci::sim::LcpResidual(original problem, z) ≤ 1e-8 · max(1, ‖q‖_∞) (McpResidual ≤ 1e-8 for
// the MCPs). Times are the median over the repetitions of the solver call alone (problem
// copies are made outside the timed region), as wall time and this thread's CPU time.
#include <LCP_Solvers.h>
#include <LinearComplementarityProblem.h>
#include <MCP_Solvers.h>
#include <MCP_cst.h>
#include <MixedComplementarityProblem.h>
#include <NonSmoothDrivers.h>
#include <NumericsMatrix.h>
#include <NumericsVerbose.h>
#include <SolverOptions.h>
#include <lcp_cst.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lcp_file.h"
#include "vinci/sim/solvers/mcp.h"

namespace {

using vinci::sim::LcpProblem;
using vinci::sim::MatrixXd;
using vinci::sim::VectorXd;

constexpr double kSuccessTol = 1e-8;  // LcpResidual ≤ kSuccessTol · max(1, ‖q‖_∞)
constexpr double kSiconosIterativeTol = 1e-10;  // Siconos' own (relative) stopping tolerance

// Wall time and this thread's CPU time (s).
double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}
double WallSeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 == 1 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// ------------------------------------------------------------------------------------------------
// Problems

struct Problem {
  std::string name;
  std::string source;  // stack / pyramid / file
  LcpProblem lcp;
};

std::string SourcePath(const std::string& rel) { return std::string(VINCI_SOURCE_DIR "/") + rel; }

// Steps `sim` from its initial state and records the step LCP before each step in `at`
// (ascending). Stops early if a step fails.
void CollectStepLcps(const vinci::sim::Simulator& sim, const std::string& label,
                     const std::string& source, const std::vector<int>& at,
                     std::vector<Problem>* out) {
  const auto& st = dynamic_cast<const vinci::sim::StewartTrinkle&>(sim.formulation());
  const vinci::sim::Params params = sim.DefaultParams();
  vinci::sim::Workspace ws;
  vinci::sim::State x = sim.InitialState();
  vinci::sim::State next;
  int step = 0;
  for (const int target : at) {
    for (; step < target; ++step) {
      const vinci::sim::StepInfo info = sim.Step(params, x, vinci::sim::StepInput{}, &ws, &next);
      if (!info.ok) {
        std::cerr << label << ": step " << step << " failed; stopping this scene\n";
        return;
      }
      std::swap(x, next);
    }
    const auto a = st.Assemble(sim.scene(), x, vinci::sim::StepInput{});
    VectorXd v_star;
    vinci::sim::StewartTrinkle::JointElimination joints;
    LcpProblem lcp = st.BuildLcp(sim.scene(), a, x.v, &v_star, &joints);
    if (lcp.size() == 0) continue;
    out->push_back({label + "@" + std::to_string(target), source, std::move(lcp)});
  }
}

vinci::sim::Body BoxBody(const std::string& name, const vinci::sim::Body& like,
                         const vinci::sim::Isometry3d& pose) {
  vinci::sim::Body b = like;
  b.name = name;
  b.X_WB0 = pose;
  return b;
}

// Stacks of k boxes from box_stack.yaml (10 boxes): remove boxes from the end, or add more of
// the same kind on top (k > 10).
void StackProblems(const std::vector<int>& heights, const std::vector<int>& at,
                   std::vector<Problem>* out) {
  const vinci::sim::Scene base =
      vinci::sim::LoadSceneFile(SourcePath("examples/scenes/box_stack.yaml"));
  for (const int k : heights) {
    vinci::sim::Scene scene = base;
    // bodies[0] is the floor, bodies[1..10] the boxes.
    while (static_cast<int>(scene.bodies.size()) > k + 1) scene.bodies.pop_back();
    while (static_cast<int>(scene.bodies.size()) < k + 1) {
      const vinci::sim::Body& top = scene.bodies.back();
      vinci::sim::Isometry3d pose = top.X_WB0;
      pose.translation().z() += 0.2;
      scene.bodies.push_back(BoxBody("box" + std::to_string(scene.bodies.size() - 1), top, pose));
    }
    const vinci::sim::Simulator sim(std::move(scene));
    CollectStepLcps(sim, "stack" + std::to_string(k), "stack", at, out);
  }
}

// A 2-D pyramid of boxes (rows r, r−1, …, 1 in the x–z plane), each box slightly rotated about
// a random axis and shifted, so that the upper boxes rest on two lower ones on a few corners.
void PyramidProblems(const std::vector<int>& rows, const std::vector<int>& at,
                     std::vector<Problem>* out) {
  const vinci::sim::Scene base =
      vinci::sim::LoadSceneFile(SourcePath("examples/scenes/box_stack.yaml"));
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (const int r : rows) {
    vinci::sim::Scene scene = base;
    const vinci::sim::Body like = scene.bodies[1];
    scene.bodies.resize(1);
    const double pitch = 0.205;  // 5 mm gap between neighbours of a row
    for (int row = 0; row < r; ++row) {
      for (int i = 0; i < r - row; ++i) {
        vinci::sim::Vector3d axis(unit(rng), unit(rng), unit(rng));
        axis.normalize();
        vinci::sim::Isometry3d pose = vinci::sim::Isometry3d::Identity();
        pose.linear() = Eigen::AngleAxisd(0.01 * unit(rng), axis).toRotationMatrix();
        pose.translation() = vinci::sim::Vector3d(pitch * (i + 0.5 * row) + 0.002 * unit(rng),
                                                  0.002 * unit(rng), 0.1 + 0.2005 * row + 0.001);
        scene.bodies.push_back(
            BoxBody("p" + std::to_string(row) + "_" + std::to_string(i), like, pose));
      }
    }
    const vinci::sim::Simulator sim(std::move(scene));
    CollectStepLcps(sim, "pyramid" + std::to_string(r), "pyramid", at, out);
  }
}

// examples/scenes/box_pile.yaml: a box pyramid onto which a box and spheres are dropped; the
// step LCP grows from n = 192 to 246 as they land.
void PileProblems(const std::vector<int>& at, std::vector<Problem>* out) {
  const vinci::sim::Simulator sim(
      vinci::sim::LoadSceneFile(SourcePath("examples/scenes/box_pile.yaml")));
  CollectStepLcps(sim, "pile", "pile", at, out);
}

void FileProblems(std::vector<Problem>* out) {
  const std::filesystem::path dir = SourcePath("tests/data/lcp");
  if (!std::filesystem::is_directory(dir)) return;
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    if (e.path().extension() == ".lcp") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (const auto& f : files) {
    out->push_back({f.stem().string(), "file", vinci::sim::ReadLcpFile(f.string())});
  }
}

// ------------------------------------------------------------------------------------------------
// Solvers

struct Outcome {
  bool ok = false;
  double residual = std::numeric_limits<double>::quiet_NaN();
  int iterations = 0;
  int code = 0;  // solver status (vinci: SolverStatus as int; Siconos: info)
  double wall = std::numeric_limits<double>::quiet_NaN();
  double cpu = std::numeric_limits<double>::quiet_NaN();
};

double ScaledTol(const LcpProblem& p) {
  return kSuccessTol * std::max(1.0, p.q.size() ? p.q.lpNorm<Eigen::Infinity>() : 0.0);
}

// Repeats `solve` (returns the iterate) and keeps median times; at least 3 runs, at most
// `max_reps`, stopping early once 0.5 s of wall time has been spent.
template <typename SolveFn>
Outcome Timed(int max_reps, const LcpProblem& p, SolveFn&& solve) {
  std::vector<double> walls, cpus;
  Outcome out;
  double spent = 0.0;
  for (int rep = 0; rep < max_reps; ++rep) {
    VectorXd z;
    double w0 = 0, c0 = 0, w1 = 0, c1 = 0;
    solve(&z, &out.iterations, &out.code, &w0, &c0, &w1, &c1);
    walls.push_back(w1 - w0);
    cpus.push_back(c1 - c0);
    spent += w1 - w0;
    if (rep == 0) {
      out.residual = z.size() == p.size() && z.allFinite()
                         ? vinci::sim::LcpResidual(p, z)
                         : std::numeric_limits<double>::infinity();
      out.ok = out.residual <= ScaledTol(p);
    }
    if (rep + 1 >= 3 && spent > 0.5) break;
  }
  out.wall = Median(walls);
  out.cpu = Median(cpus);
  return out;
}

Outcome SolveVinci(const vinci::sim::LcpSolver& solver, const LcpProblem& p, int reps) {
  return Timed(
      reps, p,
      [&](VectorXd* z, int* it, int* code, double* w0, double* c0, double* w1, double* c1) {
        *w0 = WallSeconds();
        *c0 = ThreadCpuSeconds();
        const vinci::sim::SolverReport r = solver.Solve(p, nullptr, z);
        *c1 = ThreadCpuSeconds();
        *w1 = WallSeconds();
        *it = r.iterations;
        *code = static_cast<int>(r.status);
      });
}

// A Siconos LCP owning copies of M (column-major, as Eigen stores it) and q.
struct SiconosLcp {
  LinearComplementarityProblem* p = nullptr;
  explicit SiconosLcp(const LcpProblem& lcp) {
    const int n = lcp.size();
    p = newLCP();
    p->size = n;
    p->M = NM_create(NM_DENSE, n, n);
    std::memcpy(p->M->matrix0, lcp.M.data(), sizeof(double) * n * n);
    p->q = static_cast<double*>(std::malloc(sizeof(double) * n));
    std::memcpy(p->q, lcp.q.data(), sizeof(double) * n);
  }
  ~SiconosLcp() { freeLinearComplementarityProblem(p); }
  SiconosLcp(const SiconosLcp&) = delete;
  SiconosLcp& operator=(const SiconosLcp&) = delete;
};

Outcome SolveSiconos(int solver_id, const LcpProblem& lcp, int reps) {
  return Timed(
      reps, lcp,
      [&](VectorXd* z, int* it, int* code, double* w0, double* c0, double* w1, double* c1) {
        const int n = lcp.size();
        SiconosLcp prob(lcp);  // fresh copy per run (outside the timed region)
        SolverOptions* opt = solver_options_create(solver_id);
        if (solver_id != SICONOS_LCP_LEMKE) {
          opt->dparam[SICONOS_DPARAM_TOL] = kSiconosIterativeTol;
        }
        *z = VectorXd::Zero(n);
        VectorXd w = VectorXd::Zero(n);
        *w0 = WallSeconds();
        *c0 = ThreadCpuSeconds();
        const int info = linearComplementarity_driver(prob.p, z->data(), w.data(), opt);
        *c1 = ThreadCpuSeconds();
        *w1 = WallSeconds();
        *it = opt->iparam[SICONOS_IPARAM_ITER_DONE];
        *code = info;
        // solver_options_delete clears the members but (Siconos 4.4) not the struct itself:
        // without free(opt) LeakSanitizer reports 120 bytes per solve.
        solver_options_delete(opt);
        std::free(opt);
      });
}

// ------------------------------------------------------------------------------------------------
// MCPs: Josephy and Kojima–Shindo (as in tests/sim/mcp_test.cc), NCPs of size 4.

// An NCP/box MCP of size 4 with F and its row-major Jacobian. Siconos' MCP has no bounds
// other than z ≥ 0 on its n2 block, so `upper` (finite only for the box MCP, never active at
// its solution) is given to vinci alone.
struct McpDef {
  std::string name;
  std::function<void(const double*, double*)> F;
  std::function<void(const double*, double*)> J;  // row-major 4×4
  VectorXd upper = VectorXd::Constant(4, std::numeric_limits<double>::infinity());
};

struct KojimaCoeffs {
  double a, b, c;
};

void KojimaF(const KojimaCoeffs& k, const double* x, double* F) {
  F[0] = 3 * x[0] * x[0] + 2 * x[0] * x[1] + 2 * x[1] * x[1] + x[2] + 3 * x[3] - 6;
  F[1] = 2 * x[0] * x[0] + x[0] + x[1] * x[1] + k.a * x[2] + 2 * x[3] - 2;
  F[2] = 3 * x[0] * x[0] + x[0] * x[1] + 2 * x[1] * x[1] + 2 * x[2] + k.b * x[3] - k.c;
  F[3] = x[0] * x[0] + 3 * x[1] * x[1] + 2 * x[2] + 3 * x[3] - 3;
}
// Row-major 4×4 Jacobian.
void KojimaJ(const KojimaCoeffs& k, const double* x, double* J) {
  const double rows[16] = {
      6 * x[0] + 2 * x[1], 2 * x[0] + 4 * x[1], 1, 3,   4 * x[0] + 1, 2 * x[1], k.a, 2,
      6 * x[0] + x[1],     x[0] + 4 * x[1],     2, k.b, 2 * x[0],     6 * x[1], 2,   3};
  std::copy(rows, rows + 16, J);
}

McpDef Kojima(const std::string& name, const KojimaCoeffs& k) {
  McpDef d;
  d.name = name;
  d.F = [k](const double* x, double* F) { KojimaF(k, x, F); };
  d.J = [k](const double* x, double* J) { KojimaJ(k, x, J); };
  return d;
}

// The 4×4 affine example of tests/sim/mcp_test.cc (Box4): F = Mz + q, 0 ≤ z ≤ 10, solution
// (2.8, 0, 0.8, 1.2).
McpDef Box4() {
  static const double kM[16] = {0, 0, -1, -1, 0, 0, 1, -2, 1, -1, 2, -2, 1, 2, -2, 4};
  static const double kQ[4] = {2, 2, -2, -6};
  McpDef d;
  d.name = "box4";
  d.F = [](const double* x, double* F) {
    for (int i = 0; i < 4; ++i) {
      F[i] = kQ[i];
      for (int j = 0; j < 4; ++j) F[i] += kM[4 * i + j] * x[j];
    }
  };
  d.J = [](const double*, double* J) { std::copy(kM, kM + 16, J); };
  d.upper = VectorXd::Constant(4, 10.0);
  return d;
}

vinci::sim::McpProblem VinciMcp(const McpDef& def) {
  vinci::sim::McpProblem p;
  p.lower = VectorXd::Zero(4);
  p.upper = def.upper;
  p.evaluate = [def](const VectorXd& x, VectorXd* F, MatrixXd* J) {
    F->resize(4);
    def.F(x.data(), F->data());
    if (J != nullptr) {
      double rows[16];
      def.J(x.data(), rows);
      J->resize(4, 4);
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) (*J)(i, j) = rows[4 * i + j];
    }
  };
  return p;
}

extern "C" void SiconosMcpF(void* env, int /*n*/, double* z, double* F) {
  static_cast<const McpDef*>(env)->F(z, F);
}
extern "C" void SiconosMcpJ(void* env, int /*n*/, double* z, NumericsMatrix* J) {
  double rows[16];
  static_cast<const McpDef*>(env)->J(z, rows);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) J->matrix0[i + 4 * j] = rows[4 * i + j];  // column-major
}

struct McpRow {
  std::string name;
  std::string solver;
  Outcome out;
  VectorXd z;
};

McpRow RunVinciMcp(const McpDef& def, const VectorXd& start, int reps) {
  const vinci::sim::McpProblem p = VinciMcp(def);
  const vinci::sim::McpSolver solver;
  McpRow row{def.name, "vinci semismooth-newton", {}, start};
  std::vector<double> walls, cpus;
  for (int rep = 0; rep < reps; ++rep) {
    VectorXd z = start;
    const double w0 = WallSeconds(), c0 = ThreadCpuSeconds();
    const vinci::sim::SolverReport r = solver.Solve(p, &z);
    const double c1 = ThreadCpuSeconds(), w1 = WallSeconds();
    walls.push_back(w1 - w0);
    cpus.push_back(c1 - c0);
    if (rep == 0) {
      row.out.iterations = r.iterations;
      row.out.code = static_cast<int>(r.status);
      row.out.residual = vinci::sim::McpResidual(p, z);
      row.out.ok = row.out.residual <= kSuccessTol;
      row.z = z;
    }
  }
  row.out.wall = Median(walls);
  row.out.cpu = Median(cpus);
  return row;
}

McpRow RunSiconosMcp(const McpDef& def, const VectorXd& start, int solver_id,
                     const std::string& label, int reps) {
  const vinci::sim::McpProblem vp = VinciMcp(def);
  McpRow row{def.name, label, {}, start};
  std::vector<double> walls, cpus;
  for (int rep = 0; rep < reps; ++rep) {
    MixedComplementarityProblem* p = mixedComplementarityProblem_new();
    p->n1 = 0;
    p->n2 = 4;
    p->compute_Fmcp = &SiconosMcpF;
    p->compute_nabla_Fmcp = &SiconosMcpJ;
    p->nabla_Fmcp = NM_create(NM_DENSE, 4, 4);
    p->env = const_cast<McpDef*>(&def);
    SolverOptions* opt = solver_options_create(solver_id);
    VectorXd z = start, w = VectorXd::Zero(4);
    const double w0 = WallSeconds(), c0 = ThreadCpuSeconds();
    const int info = mcp_driver(p, z.data(), w.data(), opt);
    const double c1 = ThreadCpuSeconds(), w1 = WallSeconds();
    walls.push_back(w1 - w0);
    cpus.push_back(c1 - c0);
    if (rep == 0) {
      row.out.iterations = opt->iparam[SICONOS_IPARAM_ITER_DONE];
      row.out.code = info;
      // Checked on vinci's problem (for box4 also z ≤ 10, which Siconos does not enforce).
      row.out.residual =
          z.allFinite() ? vinci::sim::McpResidual(vp, z) : std::numeric_limits<double>::infinity();
      row.out.ok = row.out.residual <= kSuccessTol;
      row.z = z;
    }
    solver_options_delete(opt);
    std::free(opt);  // see SolveSiconos
    mixedComplementarityProblem_free(p);
  }
  row.out.wall = Median(walls);
  row.out.cpu = Median(cpus);
  return row;
}

// ------------------------------------------------------------------------------------------------

struct Pair {
  std::string label;
  std::string vinci;  // vinci solver name (MakeLcpSolver)
  int siconos_id;
  std::string siconos;  // label
};

int Bucket(int n) {
  if (n <= 50) return 0;
  if (n <= 100) return 1;
  if (n <= 200) return 2;
  return 3;
}
const char* kBucketNames[] = {"n<=50", "51-100", "101-200", "201-500"};

int Usage() {
  std::cerr << "usage: vinci_vs_siconos [--quick] [--reps N] [--max-n N] [--csv FILE]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  int reps = 7;
  std::string csv_path;
  int max_n = 500;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quick") {
      quick = true;
    } else if (a == "--reps" && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
      if (reps < 1) return Usage();
    } else if (a == "--max-n" && i + 1 < argc) {
      max_n = std::atoi(argv[++i]);
      if (max_n < 1) return Usage();
    } else if (a == "--csv" && i + 1 < argc) {
      csv_path = argv[++i];
    } else {
      return Usage();
    }
  }
  if (quick) reps = 1;
  numerics_set_verbose(0);

  try {
    // Problems.
    std::vector<Problem> problems;
    if (quick) {
      StackProblems({1, 3}, {1}, &problems);
      PyramidProblems({2}, {1}, &problems);
      PileProblems({1}, &problems);
    } else {
      std::vector<int> heights;
      for (int k = 1; k <= 20; ++k) heights.push_back(k);
      StackProblems(heights, {1, 50, 300}, &problems);
      PyramidProblems({2, 3}, {1, 50, 300}, &problems);
      PileProblems({1, 160, 210, 310, 400}, &problems);
      FileProblems(&problems);
      // Keep to the sizes the comparison is about (10..500 unknowns).
      problems.erase(std::remove_if(problems.begin(), problems.end(),
                                    [max_n](const Problem& p) { return p.lcp.size() > max_n; }),
                     problems.end());
    }

    // Solver pairs; vinci solvers that are not (yet) registered are skipped.
    const std::vector<std::string> known = vinci::sim::LcpSolverNames();
    std::vector<Pair> pairs;
    for (const Pair& p :
         {Pair{"lemke", "lemke", SICONOS_LCP_LEMKE, "siconos lexicolemke"},
          Pair{"pgs", "pgs", SICONOS_LCP_PGS, "siconos pgs"},
          Pair{"pgs/rpgs", "pgs", SICONOS_LCP_RPGS, "siconos rpgs"},
          Pair{"fb-newton", "fb-newton", SICONOS_LCP_NEWTON_FB_FBLSA, "siconos newton-FB"}}) {
      if (std::find(known.begin(), known.end(), p.vinci) == known.end()) {
        std::cerr << "vinci solver '" << p.vinci << "' not registered: skipping its pair\n";
        continue;
      }
      pairs.push_back(p);
    }

    std::unique_ptr<std::ofstream> csv;
    if (!csv_path.empty()) {
      csv = std::make_unique<std::ofstream>(csv_path + ".tmp");
      *csv << "problem,source,n,pair,library,ok,residual,tol,iterations,code,wall_s,cpu_s\n";
    }

    // Per pair and bucket: counts and ratios.
    struct Acc {
      int problems = 0, vinci_ok = 0, siconos_ok = 0, both = 0;
      std::vector<double> wall_ratio, cpu_ratio;
      std::vector<double> vinci_cpu, siconos_cpu;
    };
    std::map<std::pair<int, int>, Acc> acc;  // (pair, bucket)

    std::printf("%-26s %-8s %4s  %-10s %5s %9s %5s %10s  %5s %9s %5s %10s\n", "problem", "source",
                "n", "pair", "v.ok", "v.resid", "v.it", "v.cpu[ms]", "s.ok", "s.resid", "s.it",
                "s.cpu[ms]");
    for (const Problem& prob : problems) {
      const int n = prob.lcp.size();
      for (size_t pi = 0; pi < pairs.size(); ++pi) {
        const Pair& pair = pairs[pi];
        const auto solver = vinci::sim::MakeLcpSolver(pair.vinci);
        const Outcome v = SolveVinci(*solver, prob.lcp, reps);
        const Outcome s = SolveSiconos(pair.siconos_id, prob.lcp, reps);
        std::printf("%-26s %-8s %4d  %-10s %5s %9.2e %5d %10.3f  %5s %9.2e %5d %10.3f\n",
                    prob.name.c_str(), prob.source.c_str(), n, pair.label.c_str(),
                    v.ok ? "yes" : "NO", v.residual, v.iterations, 1e3 * v.cpu, s.ok ? "yes" : "NO",
                    s.residual, s.iterations, 1e3 * s.cpu);
        std::fflush(stdout);
        Acc& a = acc[{static_cast<int>(pi), Bucket(n)}];
        ++a.problems;
        a.vinci_ok += v.ok;
        a.siconos_ok += s.ok;
        if (v.ok && s.ok) {
          ++a.both;
          a.wall_ratio.push_back(v.wall / s.wall);
          a.cpu_ratio.push_back(v.cpu / s.cpu);
          a.vinci_cpu.push_back(v.cpu);
          a.siconos_cpu.push_back(s.cpu);
        }
        if (csv) {
          const double tol = ScaledTol(prob.lcp);
          for (int lib = 0; lib < 2; ++lib) {
            const Outcome& o = lib == 0 ? v : s;
            *csv << prob.name << ',' << prob.source << ',' << n << ',' << pair.label << ','
                 << (lib == 0 ? "vinci " + pair.vinci : pair.siconos) << ',' << (o.ok ? 1 : 0)
                 << ',' << o.residual << ',' << tol << ',' << o.iterations << ',' << o.code << ','
                 << o.wall << ',' << o.cpu << '\n';
          }
        }
      }
    }

    std::printf(
        "\nSummary (success: LcpResidual <= 1e-8*max(1,|q|_inf) on the original problem; "
        "ratio = vinci time / Siconos time, median over problems both solved; < 1: vinci "
        "faster)\n");
    std::printf("%-40s %-8s %5s %6s %6s %5s %10s %10s %11s %11s\n", "pair (vinci vs siconos)",
                "bucket", "probs", "v.ok", "s.ok", "both", "cpu ratio", "wall ratio", "v.cpu[ms]",
                "s.cpu[ms]");
    for (size_t pi = 0; pi < pairs.size(); ++pi) {
      for (int b = 0; b < 4; ++b) {
        const auto it = acc.find({static_cast<int>(pi), b});
        if (it == acc.end()) continue;
        const Acc& a = it->second;
        const std::string label = "vinci " + pairs[pi].vinci + " vs " + pairs[pi].siconos;
        std::printf("%-40s %-8s %5d %6d %6d %5d %10.3f %10.3f %11.3f %11.3f\n", label.c_str(),
                    kBucketNames[b], a.problems, a.vinci_ok, a.siconos_ok, a.both,
                    Median(a.cpu_ratio), Median(a.wall_ratio), 1e3 * Median(a.vinci_cpu),
                    1e3 * Median(a.siconos_cpu));
      }
    }

    // MCPs.
    std::printf("\nMCPs (NCP, n = 4; success: McpResidual <= 1e-8)\n");
    std::printf("%-14s %-12s %-28s %4s %9s %4s %5s %10s  %s\n", "problem", "start", "solver", "ok",
                "resid", "it", "code", "cpu[us]", "z");
    const std::vector<McpDef> mcps = {Kojima("josephy", {3.0, 3.0, 1.0}),
                                      Kojima("kojima-shindo", {10.0, 9.0, 9.0}), Box4()};
    const std::vector<std::pair<std::string, VectorXd>> starts = {{"ones", VectorXd::Ones(4)},
                                                                  {"zeros", VectorXd::Zero(4)}};
    const int mcp_reps = quick ? 1 : 51;
    for (const McpDef& def : mcps) {
      const std::string& name = def.name;
      for (const auto& [start_name, start] : starts) {
        const McpRow rows[] = {RunVinciMcp(def, start, mcp_reps),
                               RunSiconosMcp(def, start, SICONOS_MCP_NEWTON_FB_FBLSA,
                                             "siconos newton-FB-FBLSA", mcp_reps),
                               RunSiconosMcp(def, start, SICONOS_MCP_NEWTON_MIN_FBLSA,
                                             "siconos newton-min-FBLSA", mcp_reps)};
        for (const McpRow& r : rows) {
          std::ostringstream z;
          z << r.z.transpose();
          std::printf("%-14s %-12s %-28s %4s %9.2e %4d %5d %10.2f  %s\n", name.c_str(),
                      start_name.c_str(), r.solver.c_str(), r.out.ok ? "yes" : "NO", r.out.residual,
                      r.out.iterations, r.out.code, 1e6 * r.out.cpu, z.str().c_str());
          if (csv) {
            *csv << name << "@" << start_name << ",mcp,4,mcp," << r.solver << ','
                 << (r.out.ok ? 1 : 0) << ',' << r.out.residual << ',' << kSuccessTol << ','
                 << r.out.iterations << ',' << r.out.code << ',' << r.out.wall << ',' << r.out.cpu
                 << '\n';
          }
        }
      }
    }

    if (csv) {
      csv->close();
      std::filesystem::rename(csv_path + ".tmp", csv_path);
    }
  } catch (const std::exception& e) {
    std::cerr << "vinci_vs_siconos: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
