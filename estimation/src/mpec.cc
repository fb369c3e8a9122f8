#include "vinci/estimation/mpec.h"

#include <dlfcn.h>

#include <IpIpoptApplication.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "mpec_relaxed_nlp.h"
#include "mumps_ldlt.h"

namespace vinci::estimation {
namespace {

using mpec_internal::kInf;
using mpec_internal::RelaxedNlp;
using mpec_internal::Stage;
using sim::VectorXd;

// Scholtes stages with ε below this write their relaxation rows relative to ε
// (RelaxedNlp::relaxation_scale_): measured on a tossed cube, with the rows x_a x_b ≤ ε the
// violation stayed at 9.7e-5 (products ~1e-8, feasible to Ipopt's tolerance) from ε = 1e-8 to
// 1e-12. Every stage of the default homotopy (ε ≥ 1e-8) is unchanged.
constexpr double kRelativeRelaxationBelow = 1e-8 * (1 - 1e-9);

// SCOTCH_randomSeed of the SCOTCH library MUMPS was built with, if the process has it (it is a
// dependency of MUMPS, not of vinci: looked up at run time; null without it). Its argument is a
// SCOTCH_Num (32 or 64 bits by build): passed as a 64-bit register value, small seeds read the
// same either way.
using ScotchRandomSeed = void (*)(std::int64_t);
ScotchRandomSeed FindScotchRandomSeed() {
  static const ScotchRandomSeed f =
      reinterpret_cast<ScotchRandomSeed>(dlsym(RTLD_DEFAULT, "SCOTCH_randomSeed"));
  return f;
}

// MUMPS' dense fronts are small here: OpenBLAS (when it is the system BLAS) on its default
// thread count spun its workers in sched_yield (21 % of the samples, bench/README.md). One BLAS
// thread for the process, once, unless the user set OPENBLAS_NUM_THREADS.
void UseOneBlasThreadUnlessSet() {
  static const bool done = [] {
    using SetThreads = void (*)(int);
    if (std::getenv("OPENBLAS_NUM_THREADS") != nullptr) return false;
    const auto set = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"));
    if (set) set(1);
    return set != nullptr;
  }();
  (void)done;
}

// SCOTCH on one thread with its generator reset: the same pattern gets the same ordering every
// time (MpecSolverOptions::deterministic_ordering).
void ResetScotch(ScotchRandomSeed seed) {
  const char* threads = std::getenv("SCOTCH_PTHREAD_NUMBER");
  if (threads == nullptr || std::strcmp(threads, "1") != 0) setenv("SCOTCH_PTHREAD_NUMBER", "1", 1);
  seed(1);
}

// MpecSolverOptions::Ordering::kAuto resolved for `problem` (SCOTCH found: `seed`) from the
// pattern of Ipopt's KKT matrix [W 0 J_cᵀ J_dᵀ; 0 Σ_s 0 −I; J_c 0 0 0; J_d −I 0 0] over the
// variables Ipopt keeps (fixed ones are parameters to it), the slacks s of the inequality rows
// d (the problem's and, with `relaxation_rows`, the Scholtes rows x_a x_b ≤ ε) and the
// equality rows c; W with the pairs' relaxation curvature.
MpecSolverOptions::Ordering ResolveAutoOrdering(
    const MpecProblem& problem, const std::vector<std::pair<int, int>>& pairs, bool relaxation_rows,
    ScotchRandomSeed seed, const std::function<void(const std::string&)>& progress) {
  const int n = problem.num_variables(), m = problem.num_constraints();
  VectorXd xl, xu, gl, gu;
  problem.Bounds(&xl, &xu, &gl, &gu);
  std::vector<int> index(n, -1);
  int dim = 0;
  for (int i = 0; i < n; ++i)
    if (!(xl[i] == xu[i])) index[i] = dim++;
  const int rows = dim;
  dim += m;
  std::vector<std::pair<int, int>> lower;
  auto add = [&](int r, int c) {
    if (r < 0 || c < 0) return;
    lower.emplace_back(std::max(r, c), std::min(r, c));
  };
  for (const Entry& e : problem.HessianStructure()) add(index[e.row], index[e.col]);
  for (const auto& [a, b] : pairs) add(index[a], index[b]);
  for (const Entry& e : problem.JacobianStructure())
    if (index[e.col] >= 0) add(rows + e.row, index[e.col]);
  for (int j = 0; j < m; ++j)
    if (!(gl[j] == gu[j])) add(rows + j, dim++);  // the row's slack
  if (relaxation_rows) {
    for (const auto& [a, b] : pairs) {
      add(dim, index[a]);
      add(dim, index[b]);
      add(dim, dim + 1);  // its slack
      dim += 2;
    }
  }
  for (int i = 0; i < dim; ++i) add(i, i);
  std::sort(lower.begin(), lower.end());
  lower.erase(std::unique(lower.begin(), lower.end()), lower.end());

  // Dense vertices by AMD's rule; the decision needs one that joins otherwise disconnected parts.
  std::vector<int> degree(dim, 0);
  for (const auto& [r, c] : lower)
    if (r != c) ++degree[r], ++degree[c];
  const double dense = std::max(16.0, 10.0 * std::sqrt(static_cast<double>(dim)));
  if (std::none_of(degree.begin(), degree.end(), [&](int d) { return d > dense; }))
    return MpecSolverOptions::Ordering::kScotch;
  std::vector<int> parent(dim);
  for (int i = 0; i < dim; ++i) parent[i] = i;
  auto root = [&](int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const auto& [r, c] : lower)
    if (degree[r] <= dense && degree[c] <= dense) parent[root(r)] = root(c);
  int parts = 0;
  for (int i = 0; i < dim; ++i) parts += degree[i] <= dense && root(i) == i;
  if (parts < 2) return MpecSolverOptions::Ordering::kScotch;

  ResetScotch(seed);
  const double scotch = mpec_internal::EstimatedFactorizationFlops(dim, lower, 3);
  const double qamd = mpec_internal::EstimatedFactorizationFlops(dim, lower, 6);
  const bool use_qamd = !(scotch <= 100.0 * qamd);
  if (progress) {
    std::ostringstream line;
    line << "ordering " << (use_qamd ? "qamd" : "scotch") << ": a dense column joins " << parts
         << " parts; MUMPS estimates " << scotch << " flops with SCOTCH, " << qamd << " with QAMD";
    progress(line.str());
  }
  return use_qamd ? MpecSolverOptions::Ordering::kQamd : MpecSolverOptions::Ordering::kScotch;
}

const char* StatusText(Ipopt::ApplicationReturnStatus s) {
  switch (s) {
    case Ipopt::Solve_Succeeded:
      return "solved";
    case Ipopt::Solved_To_Acceptable_Level:
      return "solved to acceptable level";
    case Ipopt::Infeasible_Problem_Detected:
      return "infeasible problem detected";
    case Ipopt::Search_Direction_Becomes_Too_Small:
      return "search direction too small";
    case Ipopt::Diverging_Iterates:
      return "diverging iterates";
    case Ipopt::User_Requested_Stop:
      return "user requested stop";
    case Ipopt::Feasible_Point_Found:
      return "feasible point found";
    case Ipopt::Maximum_Iterations_Exceeded:
      return "maximum iterations exceeded";
    case Ipopt::Restoration_Failed:
      return "restoration failed";
    case Ipopt::Error_In_Step_Computation:
      return "error in step computation";
    case Ipopt::Maximum_CpuTime_Exceeded:
      return "maximum CPU time exceeded";
    case Ipopt::Not_Enough_Degrees_Of_Freedom:
      return "not enough degrees of freedom";
    case Ipopt::Invalid_Problem_Definition:
      return "invalid problem definition";
    case Ipopt::Invalid_Option:
      return "invalid option";
    case Ipopt::Invalid_Number_Detected:
      return "invalid number detected";
    default:
      return "internal error";
  }
}

bool Solved(Ipopt::ApplicationReturnStatus s) {
  return s == Ipopt::Solve_Succeeded || s == Ipopt::Solved_To_Acceptable_Level;
}

double Violation(const std::vector<std::pair<int, int>>& pairs, const VectorXd& x) {
  double v = 0.0;
  for (const auto& [a, b] : pairs) v = std::max(v, std::abs(std::min(x[a], x[b])));
  return v;
}

// max over pairs of x_a x_b (0 without pairs).
double MaxProduct(const std::vector<std::pair<int, int>>& pairs, const VectorXd& x) {
  double v = 0.0;
  for (const auto& [a, b] : pairs) v = std::max(v, x[a] * x[b]);
  return v;
}

// The polish's active set: per pair, true if x_a is fixed at 0 (else x_b). The smaller side,
// except at a biactive pair of a Scholtes iterate (MpecSolverOptions::biactive_factor): there
// the side with the larger MPEC multiplier estimate ν = z − λ_k × partner. `lambda` holds the
// problem's m multipliers followed, after a Scholtes stage, by one per pair; `epsilon` is that
// stage's ε (0: no Scholtes iterate, the smaller side everywhere).
std::vector<bool> PolishBranches(int m, const std::vector<std::pair<int, int>>& pairs,
                                 const VectorXd& x, const VectorXd& lambda, const VectorXd& zl,
                                 double epsilon, const MpecSolverOptions& o, int* biactive,
                                 int* switched) {
  std::vector<bool> fixed(pairs.size());
  const bool multipliers = epsilon > 0 && o.biactive_factor > 0 &&
                           lambda.size() == m + static_cast<Eigen::Index>(pairs.size()) &&
                           zl.size() == x.size();
  const double tau = o.biactive_factor * std::sqrt(epsilon);
  *biactive = *switched = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto [a, b] = pairs[k];
    fixed[k] = x[a] <= x[b];
    if (!multipliers || std::max(x[a], x[b]) > tau) continue;
    ++*biactive;
    const double lam = lambda[m + static_cast<Eigen::Index>(k)];
    const double nu_a = zl[a] - lam * x[b];
    const double nu_b = zl[b] - lam * x[a];
    if (nu_a == nu_b) continue;
    const bool fix_a = nu_a > nu_b;
    if (fix_a != fixed[k]) ++*switched;
    fixed[k] = fix_a;
  }
  return fixed;
}

}  // namespace

const char* ToString(ComplementarityMethod method) {
  return method == ComplementarityMethod::kScholtes ? "scholtes" : "penalty";
}

const char* ToString(MpecSolverOptions::Ordering ordering) {
  switch (ordering) {
    case MpecSolverOptions::Ordering::kScotch:
      return "scotch";
    case MpecSolverOptions::Ordering::kQamd:
      return "qamd";
    case MpecSolverOptions::Ordering::kAuto:
      break;
  }
  return "auto";
}

MpecSolverOptions::Ordering ParseMpecOrdering(const std::string& name) {
  if (name == "auto") return MpecSolverOptions::Ordering::kAuto;
  if (name == "scotch") return MpecSolverOptions::Ordering::kScotch;
  if (name == "qamd") return MpecSolverOptions::Ordering::kQamd;
  throw std::invalid_argument("mpec ordering '" + name + "': expected auto, scotch or qamd");
}

ComplementarityMethod ParseComplementarityMethod(const std::string& name) {
  if (name == "scholtes") return ComplementarityMethod::kScholtes;
  if (name == "penalty") return ComplementarityMethod::kPenalty;
  throw std::invalid_argument("complementarity method '" + name +
                              "': expected scholtes or penalty");
}

void MpecSolverOptions::Validate() const {
  auto fail = [](const std::string& field, double v, const std::string& expected) {
    std::ostringstream m;
    m << "mpec solver: " << field << " = " << v << ", expected " << expected;
    throw std::invalid_argument(m.str());
  };
  if (!(epsilon_start > 0) || !std::isfinite(epsilon_start))
    fail("epsilon_start", epsilon_start, "finite > 0");
  if (!(epsilon_end > 0) || !(epsilon_end <= epsilon_start))
    fail("epsilon_end", epsilon_end, "in (0, epsilon_start]");
  if (!(epsilon_factor > 0) || !(epsilon_factor < 1))
    fail("epsilon_factor", epsilon_factor, "in (0, 1)");
  if (!(penalty_start > 0) || !std::isfinite(penalty_start))
    fail("penalty_start", penalty_start, "finite > 0");
  if (!(penalty_factor > 1) || !std::isfinite(penalty_factor))
    fail("penalty_factor", penalty_factor, "finite > 1");
  if (!(penalty_max >= penalty_start) || !std::isfinite(penalty_max))
    fail("penalty_max", penalty_max, "finite ≥ penalty_start");
  if (!std::isfinite(penalty_entry_epsilon))
    fail("penalty_entry_epsilon", penalty_entry_epsilon, "finite (≤ 0: epsilon_start)");
  if (!(complementarity_tolerance > 0))
    fail("complementarity_tolerance", complementarity_tolerance, "> 0");
  if (!(tolerance > 0)) fail("tolerance", tolerance, "> 0");
  if (max_iterations < 1) fail("max_iterations", max_iterations, "≥ 1");
  if (early_polish_max_iterations < 0)
    fail("early_polish_max_iterations", early_polish_max_iterations, "≥ 0");
  if (continued_max_iterations < 0)
    fail("continued_max_iterations", continued_max_iterations, "≥ 0");
  if (stall_iterations < 0) fail("stall_iterations", stall_iterations, "≥ 0");
  if (mumps_mem_percent < 1) fail("mumps_mem_percent", mumps_mem_percent, "≥ 1");
  if (polish_stall_iterations < 0) fail("polish_stall_iterations", polish_stall_iterations, "≥ 0");
  if (!(polish_stall_reduction > 0) || !(polish_stall_reduction < 1))
    fail("polish_stall_reduction", polish_stall_reduction, "in (0, 1)");
  if (!(early_polish_epsilon > 0)) fail("early_polish_epsilon", early_polish_epsilon, "> 0");
  if (!(biactive_factor >= 0) || !std::isfinite(biactive_factor))
    fail("biactive_factor", biactive_factor, "finite ≥ 0");
  if (!(warm_start_push_per_epsilon >= 0) || !std::isfinite(warm_start_push_per_epsilon))
    fail("warm_start_push_per_epsilon", warm_start_push_per_epsilon, "finite ≥ 0");
  if (!(cold_bound_push >= 0) || !std::isfinite(cold_bound_push))
    fail("cold_bound_push", cold_bound_push, "finite ≥ 0");
  if (!(stall_objective_change > 0)) fail("stall_objective_change", stall_objective_change, "> 0");
  if (!(early_polish_rise_factor >= 0) || !std::isfinite(early_polish_rise_factor))
    fail("early_polish_rise_factor", early_polish_rise_factor, "finite ≥ 0");
  if (!(stall_constraint_violation > 0))
    fail("stall_constraint_violation", stall_constraint_violation, "> 0");
  if (print_level < 0 || print_level > 12) fail("print_level", print_level, "in [0, 12]");
  if (!(epsilon_floor >= 0) || !std::isfinite(epsilon_floor))
    fail("epsilon_floor", epsilon_floor, "finite ≥ 0");
}

MpecSolverOptions::Ordering ResolveOrdering(const MpecProblem& problem,
                                            const MpecSolverOptions& o) {
  if (!o.deterministic_ordering) return MpecSolverOptions::Ordering::kAuto;
  const ScotchRandomSeed seed = FindScotchRandomSeed();
  if (seed == nullptr || o.ordering == MpecSolverOptions::Ordering::kQamd)
    return MpecSolverOptions::Ordering::kQamd;
  if (o.ordering == MpecSolverOptions::Ordering::kScotch)
    return MpecSolverOptions::Ordering::kScotch;
  return ResolveAutoOrdering(problem, problem.ComplementarityPairs(),
                             o.method == ComplementarityMethod::kScholtes, seed, o.progress);
}

MpecSolution SolveMpec(const MpecProblem& problem, const MpecSolverOptions& o,
                       const MpecMultipliers* warm_start) {
  o.Validate();
  UseOneBlasThreadUnlessSet();
  const auto start = std::chrono::steady_clock::now();
  const int n = problem.num_variables();
  const std::vector<std::pair<int, int>> pairs = problem.ComplementarityPairs();
  for (const auto& [a, b] : pairs) {
    if (a < 0 || b < 0 || a >= n || b >= n || a == b) {
      throw std::invalid_argument(
          "mpec: complementarity pair (" + std::to_string(a) + ", " + std::to_string(b) +
          "): expected two different variables in [0, " + std::to_string(n) + ")");
    }
  }
  if (!o.limited_memory && !problem.has_hessian())
    throw std::invalid_argument("mpec: the problem has no Hessian; use limited_memory");
  VectorXd x = problem.StartingPoint();
  if (x.size() != n) throw std::invalid_argument("mpec: starting point of the wrong size");

  MpecSolution sol;
  sol.first_at_zero.assign(pairs.size(), true);
  sol.ordering = ResolveOrdering(problem, o);
  VectorXd lambda, zl, zu;
  bool have_multipliers = false;
  Ipopt::ApplicationReturnStatus last = Ipopt::Internal_Error;
  int max_iter_override = 0;  // > 0: the early-polish attempt's or a continued stage's cap
  double last_epsilon = 0.0;  // the last accepted Scholtes stage's ε (0: none)
  if (warm_start) {
    const int m = problem.num_constraints();
    if (o.method != ComplementarityMethod::kScholtes || pairs.empty() ||
        warm_start->lambda.size() != m + static_cast<Eigen::Index>(pairs.size()) ||
        warm_start->z_l.size() != n || warm_start->z_u.size() != n)
      throw std::invalid_argument("mpec: warm-start multipliers of the wrong size or method");
    lambda = warm_start->lambda;
    zl = warm_start->z_l;
    zu = warm_start->z_u;
    have_multipliers = true;
  }

  auto run = [&](Stage stage, double param, const std::vector<bool>& fixed,
                 bool warm) -> Ipopt::SmartPtr<RelaxedNlp> {
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = IpoptApplicationFactory();
    auto& opt = *app->Options();
    opt.SetIntegerValue("print_level", o.print_level);
    opt.SetStringValue("sb", "yes");  // no banner
    opt.SetNumericValue("tol", o.tolerance);
    opt.SetNumericValue("acceptable_tol", std::max(o.tolerance * 1e3, 1e-8));
    opt.SetIntegerValue("max_iter", max_iter_override > 0 ? max_iter_override : o.max_iterations);
    opt.SetStringValue("mu_strategy", "adaptive");
    if (o.limited_memory) opt.SetStringValue("hessian_approximation", "limited-memory");
    // MUMPS' automatic ordering picks SCOTCH on large KKT systems, whose random generator
    // continues from call to call within a process: the same problem solved twice in one
    // process can differ in the last digits. QAMD (approximate minimum degree with quasi-dense
    // row detection) is deterministic; it took as many iterations as the automatic choice on the
    // block (plain AMD: more; bench/README.md).
    // SCOTCH with its generator reset before every NLP orders the same structure the same way
    // every time, and its orderings cost half the CPU of QAMD's factorizations here
    // (bench/README.md); QAMD where SCOTCH is not found.
    if (o.deterministic_ordering)
      opt.SetIntegerValue("mumps_pivot_order",
                          sol.ordering == MpecSolverOptions::Ordering::kScotch ? 3 : 6);
    opt.SetIntegerValue("mumps_mem_percent", o.mumps_mem_percent);
    // The penalty ρ Σ x_a x_b is bounded below by 0 only on x_a, x_b ≥ 0. Ipopt relaxes every
    // bound by 1e-8 (bound_relax_factor), so a side at its bound sits at ≈ −1e-8 and the
    // penalty decreases without bound along any ray where its partner grows freely (an
    // impulse or slack with no upper bound): on the noise-free block the first penalty NLP
    // followed such a ray (objective −338 after 60 iterations, |x| ~ 1e8) to its iteration
    // limit. Exact bounds keep the penalty ≥ 0.
    if (stage == Stage::kPenalty) opt.SetNumericValue("bound_relax_factor", 0.0);
    if ((stage != Stage::kPolish || pairs.empty()) && o.stall_iterations > 0) {
      // Ipopt's acceptable level, made a stall test: the overall error bound is loose (the
      // dual infeasibility oscillates at a degenerate solution), the objective change and the
      // constraint violation decide. Also for an NLP without pairs (e.g. the least-squares
      // start's active set), whose dual infeasibility can stall above `tolerance` at the
      // rounding of the central-difference state columns, or whose free rays (unbounded
      // unknowns absent from the objective) the barrier keeps following; as its solution is
      // the estimate, over Ipopt's own count of iterations (15) at least.
      opt.SetIntegerValue("acceptable_iter",
                          pairs.empty() ? std::max(15, o.stall_iterations) : o.stall_iterations);
      opt.SetNumericValue("acceptable_tol", 1e-2);
      opt.SetNumericValue("acceptable_obj_change_tol", o.stall_objective_change);
      opt.SetNumericValue("acceptable_constr_viol_tol", o.stall_constraint_violation);
    }
    if (!warm && stage == Stage::kScholtes && o.cold_bound_push > 0)
      opt.SetNumericValue("bound_push", o.cold_bound_push);
    if (warm) {
      const double push =
          stage == Stage::kScholtes ? std::max(1e-9, o.warm_start_push_per_epsilon * param) : 1e-9;
      opt.SetStringValue("warm_start_init_point", "yes");
      opt.SetNumericValue("warm_start_bound_push", push);
      opt.SetNumericValue("warm_start_bound_frac", push);
      opt.SetNumericValue("warm_start_slack_bound_push", push);
      opt.SetNumericValue("warm_start_slack_bound_frac", push);
      opt.SetNumericValue("warm_start_mult_bound_push", 1e-9);
      opt.SetNumericValue("mu_init", 1e-6);
    }
    Ipopt::SmartPtr<RelaxedNlp> nlp = new RelaxedNlp(
        problem, pairs, stage, param, fixed, !o.limited_memory, o.relaxation_curvature, x,
        warm ? &lambda : nullptr, warm ? &zl : nullptr, warm ? &zu : nullptr);
    last = app->Initialize();
    // SCOTCH 7 orders with several threads unless told otherwise (read at every ordering): one
    // thread and a fixed seed give the same ordering every time (measured: two runs in one
    // process, or two processes, differed in the last digits of μ̂ without either).
    if (sol.ordering == MpecSolverOptions::Ordering::kScotch && o.deterministic_ordering)
      ResetScotch(FindScotchRandomSeed());
    if (stage == Stage::kScholtes && param < kRelativeRelaxationBelow)
      nlp->relaxation_scale_ = 1.0 / param;
    if (stage == Stage::kPolish && !pairs.empty()) {
      nlp->stall_window_ = o.polish_stall_iterations;
      nlp->stall_reduction_ = o.polish_stall_reduction;
    }
    if (last == Ipopt::Solve_Succeeded) last = app->OptimizeTNLP(nlp);
    sol.iterations += nlp->iterations_;
    ++sol.stages;
    return nlp;
  };
  // How an NLP ended: Ipopt's status, or the polish's stall exit.
  auto ended = [&](const Ipopt::SmartPtr<RelaxedNlp>& nlp) -> std::string {
    if (!nlp->stalled_) return StatusText(last);
    std::ostringstream s;
    s << "stalled (error max(inf_pr, inf_du) " << nlp->stall_error_ << " not reduced "
      << 1.0 / o.polish_stall_reduction << "x in " << o.polish_stall_iterations << " iterations)";
    return s.str();
  };
  auto accept = [&](const Ipopt::SmartPtr<RelaxedNlp>& nlp, const std::string& what,
                    const std::string& suffix = "") {
    const bool ok = nlp->x_.size() == n && nlp->x_.allFinite();
    if (ok) {
      sol.iterate_solved = Solved(last);
      x = nlp->x_;
      zl = nlp->z_l_;
      zu = nlp->z_u_;
      lambda = nlp->lambda_;
      have_multipliers = true;
      sol.objective = nlp->objective_;
    }
    std::ostringstream line;
    line << what << ": " << ended(nlp) << ", " << nlp->iterations_
         << " iterations, complementarity " << Violation(pairs, x) << ", objective "
         << nlp->objective_ << suffix;
    if (o.progress) o.progress(line.str());
    return ok;
  };

  // The polish NLP from the current iterate (active set: the smaller side of every pair).
  // Accepted (x, multipliers and sol.first_at_zero replaced) if it solves and, when
  // `lower_bound` is finite, its objective is at most lower_bound + early_polish_tolerance;
  // otherwise the iterate is restored.
  std::string polish_failure;  // how the last rejected polish ended
  auto try_polish = [&](double lower_bound, const std::string& what, double rise = 0.0) {
    // The multipliers choose biactive branches in the final polish only: after an early stage
    // most pairs are within biactive_factor √ε of zero (a tossed cube at ε = 1e-4: 1 459 of
    // 2 550), where the first-order rule says nothing about the far branch.
    const bool final = !std::isfinite(lower_bound);
    const std::vector<bool> fixed =
        PolishBranches(problem.num_constraints(), pairs, x, lambda, zl, final ? last_epsilon : 0.0,
                       o, &sol.biactive_pairs, &sol.biactive_switched);
    const VectorXd x_keep = x, l_keep = lambda, zl_keep = zl, zu_keep = zu;
    const double f_keep = sol.objective;
    const bool solved_keep = sol.iterate_solved;
    // The Scholtes rows' multipliers are dropped: lambda keeps the problem's rows.
    lambda.conservativeResize(problem.num_constraints());
    if (std::isfinite(lower_bound)) max_iter_override = o.early_polish_max_iterations;
    std::string branches;
    if (sol.biactive_pairs > 0) {
      branches = ", " + std::to_string(sol.biactive_pairs) + " biactive pairs (" +
                 std::to_string(sol.biactive_switched) + " fixed at the larger side)";
    }
    Ipopt::SmartPtr<RelaxedNlp> nlp = run(Stage::kPolish, 0.0, fixed, true);
    max_iter_override = 0;
    const bool solved = Solved(last) && nlp->x_.size() == n && nlp->x_.allFinite();
    const double allowed = o.early_polish_tolerance + o.early_polish_rise_factor * rise;
    const bool close = !std::isfinite(lower_bound) || nlp->objective_ <= lower_bound + allowed;
    if (solved && close) {
      accept(nlp, what, branches);
      sol.first_at_zero = fixed;
      return true;
    }
    if (o.progress) {
      std::ostringstream line;
      line << what << ": " << ended(nlp) << ", " << nlp->iterations_ << " iterations" << branches;
      if (solved) {
        line << ", objective " << nlp->objective_ << " above the relaxed " << lower_bound << " + "
             << allowed << " (first-order rise " << rise << ")";
      }
      o.progress(line.str() + ", kept the relaxed iterate");
    }
    polish_failure = what + ": " + ended(nlp) + " after " + std::to_string(nlp->iterations_) +
                     " iterations, kept the relaxed iterate";
    x = x_keep;
    lambda = l_keep;
    zl = zl_keep;
    zu = zu_keep;
    sol.objective = f_keep;
    sol.iterate_solved = solved_keep;
    return false;
  };

  std::string stage_failure;
  // Early polish still allowed (Scholtes only: the penalty usually ends after its first stage
  // anyway, and an early polish from a penalty iterate far from complementary was measured to
  // run long).
  bool early = o.polish && o.early_polish_tolerance >= 0;
  if (pairs.empty()) {
    accept(run(Stage::kPolish, 0.0, {}, false), "nlp");
    if (!Solved(last)) stage_failure = std::string("nlp: ") + StatusText(last);
  } else if (o.method == ComplementarityMethod::kScholtes) {
    // A failed stage ends the homotopy at the last solved stage's iterate (the polish then
    // starts from there).
    for (double eps = o.epsilon_start; eps >= o.epsilon_end * (1 - 1e-9); eps *= o.epsilon_factor) {
      std::ostringstream what;
      what << "scholtes eps " << eps;
      const bool first = !have_multipliers;
      VectorXd x_keep;  // the last solved stage's iterate, kept if the predictor moves x
      if (o.epsilon_predictor && !first) {
        x_keep = x;
        int moved = 0;
        for (const auto& [a, b] : pairs) {
          const int lo = x[a] <= x[b] ? a : b, hi = lo == a ? b : a;
          if (x[a] * x[b] > eps && x[hi] > 0) {
            x[lo] = eps / x[hi];
            ++moved;
          }
        }
        what << " (predictor: " << moved << " pairs moved)";
      }
      auto nlp = run(Stage::kScholtes, eps, {}, have_multipliers);
      if (!Solved(last) && x_keep.size() > 0) x = x_keep;
      if (Solved(last) || first) {
        accept(nlp, what.str());
        last_epsilon = eps;
      }
      if (!Solved(last)) {
        stage_failure = what.str() + ": " + StatusText(last);
        sol.first_stage_failed = first;
        if (o.progress && !first) o.progress(stage_failure + ", stopped the homotopy");
        break;
      }
      if (early && eps <= o.early_polish_epsilon * (1 + 1e-9) &&
          eps * o.epsilon_factor >= o.epsilon_end * (1 - 1e-9)) {
        // ε Σ λ_k: the relaxation rows' multipliers follow the problem's m in lambda.
        double rise = 0.0;
        const int m = problem.num_constraints();
        if (lambda.size() == m + static_cast<Eigen::Index>(pairs.size())) {
          for (std::size_t k = 0; k < pairs.size(); ++k)
            rise += std::max(0.0, lambda[m + static_cast<Eigen::Index>(k)]);
          rise *= eps;
        }
        if (try_polish(nlp->objective_, "early polish", rise)) {
          sol.polished = true;
          break;
        }
        early = false;
      }
    }
  } else {
    // Entry: each ρ solved from the starting point (cold) until a solution satisfies the first
    // Scholtes relaxation, max x_a x_b ≤ ε_0; a rejected NLP's iterate is discarded. Then ρ
    // rises warm-started from the entry NLP's solution until complementary.
    const double entry_bound =
        o.penalty_entry_epsilon > 0 ? o.penalty_entry_epsilon : o.epsilon_start;
    const VectorXd x_start = x;
    bool entered = false;
    for (double rho = o.penalty_start; rho <= o.penalty_max * (1 + 1e-9); rho *= o.penalty_factor) {
      std::ostringstream what;
      what << "penalty rho " << rho;
      const bool last_rho = rho * o.penalty_factor > o.penalty_max * (1 + 1e-9);
      auto nlp = run(Stage::kPenalty, rho, {}, entered);
      if (!entered) {
        const bool finite = nlp->x_.size() == n && nlp->x_.allFinite();
        const double product = finite ? MaxProduct(pairs, nlp->x_) : kInf;
        if (!(Solved(last) && product <= entry_bound) && !last_rho) {
          if (o.progress) {
            std::ostringstream line;
            line << what.str() << ": " << StatusText(last) << ", " << nlp->iterations_
                 << " iterations, max product " << product << " > " << entry_bound
                 << ", rejected (next rho from the start)";
            o.progress(line.str());
          }
          x = x_start;
          continue;
        }
        entered = true;
        accept(nlp, what.str() + " (entry)");
      } else if (Solved(last)) {
        accept(nlp, what.str());
      }
      if (!Solved(last)) {
        stage_failure = what.str() + ": " + StatusText(last);
        if (o.progress) o.progress(stage_failure + ", stopped the homotopy");
        break;
      }
      if (Violation(pairs, x) <= o.complementarity_tolerance) break;
    }
  }
  if (!sol.polished) {
    for (std::size_t k = 0; k < pairs.size(); ++k)
      sol.first_at_zero[k] = x[pairs[k].first] <= x[pairs[k].second];
  }
  bool relaxed_ok = stage_failure.empty() || sol.polished;
  bool final_polish_failed = false;
  if (o.polish && !pairs.empty() && !sol.polished) {
    if (try_polish(std::numeric_limits<double>::infinity(), "polish")) {
      sol.polished = true;
      relaxed_ok = true;
      stage_failure.clear();
    } else {
      final_polish_failed = true;
    }
  }
  if ((final_polish_failed || !o.polish) && o.method == ComplementarityMethod::kScholtes &&
      stage_failure.empty() && last_epsilon > 0 && o.epsilon_floor > 0) {
    // The homotopy continued past epsilon_end until the relaxed iterate is complementary
    // within the tolerance (MpecSolverOptions::epsilon_floor).
    for (double eps = last_epsilon * o.epsilon_factor;
         Violation(pairs, x) > o.complementarity_tolerance && eps >= o.epsilon_floor * (1 - 1e-9);
         eps *= o.epsilon_factor) {
      std::ostringstream what;
      what << "scholtes eps " << eps << " (continued: not polished)";
      max_iter_override = o.continued_max_iterations;
      auto nlp = run(Stage::kScholtes, eps, {}, true);
      max_iter_override = 0;
      if (!Solved(last)) {
        if (o.progress) {
          o.progress(what.str() + ": " + StatusText(last) + " after " +
                     std::to_string(nlp->iterations_) + " iterations, stopped");
        }
        break;
      }
      accept(nlp, what.str());
      last_epsilon = eps;
    }
  }
  sol.final_epsilon = last_epsilon;
  if (!sol.polished && !pairs.empty() && o.method == ComplementarityMethod::kScholtes &&
      have_multipliers &&
      lambda.size() == problem.num_constraints() + static_cast<Eigen::Index>(pairs.size())) {
    sol.relaxed.lambda = lambda;
    sol.relaxed.z_l = zl;
    sol.relaxed.z_u = zu;
  }
  sol.x = x;
  sol.lambda = lambda.size() >= problem.num_constraints()
                   ? VectorXd(lambda.head(problem.num_constraints()))
                   : VectorXd::Zero(problem.num_constraints());
  sol.complementarity_violation = Violation(pairs, x);
  double f = 0.0;
  if (problem.Objective(x, &f)) sol.objective = f;  // without penalty terms
  sol.solved = relaxed_ok;
  sol.converged = relaxed_ok && sol.complementarity_violation <= o.complementarity_tolerance;
  std::ostringstream reason;
  reason << (sol.polished ? "polished: " : "") << StatusText(last) << ", complementarity violation "
         << sol.complementarity_violation;
  if (!sol.polished && last_epsilon > 0)
    reason << " (the relaxed iterate at eps " << last_epsilon << ")";
  if (!stage_failure.empty()) reason << "; " << stage_failure;
  if (final_polish_failed) reason << "; " << polish_failure;
  if (!sol.converged && relaxed_ok)
    reason << "; above the tolerance " << o.complementarity_tolerance;
  sol.reason = reason.str();
  sol.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

}  // namespace vinci::estimation
