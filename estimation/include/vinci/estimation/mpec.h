// Mathematical programs with equilibrium (complementarity) constraints, solved by Ipopt through
// a relaxation or a penalty (docs/estimation.md, method mpec).
//
// An MpecProblem is a smooth NLP plus complementarity pairs between its variables:
//
//   min_x f(x)  s.t.  g_l ≤ g(x) ≤ g_u,  x_l ≤ x ≤ x_u,  0 ≤ x_a ⊥ x_b ≥ 0  for every pair (a, b)
//
// (a complementarity between functions is written with slack variables s = c(x), s ≥ 0).
// SolveMpec replaces the pairs by a sequence of smooth NLPs, each warm-started from the last:
//
//   Scholtes relaxation:  x_a ≥ 0, x_b ≥ 0, x_a x_b ≤ ε,  ε = ε_0, ε_0 κ, ε_0 κ², … ≥ ε_end;
//   ℓ1 penalty:           min f(x) + ρ Σ x_a x_b,  x_a, x_b ≥ 0,  ρ = ρ_0, ρ_0 β, … ≤ ρ_max
//                         (Σ x_a x_b = Σ |x_a x_b| on the feasible set, an exact penalty);
//                         entry: every ρ is solved from the starting point until a solution
//                         satisfies the first Scholtes relaxation (max x_a x_b ≤ ε_0), and only
//                         from there are the larger ρ warm-started,
//
// and, optionally, a final "polish" NLP with the active set of the last iterate fixed (for each
// pair the smaller of x_a, x_b is fixed at 0, the other kept ≥ 0), which restores exact
// complementarity when the relaxed solution identified the active set. Every NLP is solved by
// Ipopt (sparse Jacobian; the problem's exact Lagrangian Hessian plus the relaxation's terms, or
// Ipopt's limited-memory quasi-Newton approximation).
#pragma once

#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/types.h"

namespace vinci::estimation {

/// A sparse matrix entry position (row, column), 0-based.
struct Entry {
  int row = 0, col = 0;
};

/// The smooth part of an MPEC and its complementarity pairs. Evaluation functions return false
/// when they cannot evaluate at x (the solver then shortens its step); they must not throw.
class MpecProblem {
 public:
  virtual ~MpecProblem() = default;
  virtual int num_variables() const = 0;
  virtual int num_constraints() const = 0;
  /// Bounds (±1e19 or beyond = none). The solver raises the lower bound of every variable in a
  /// complementarity pair to ≥ 0.
  virtual void Bounds(sim::VectorXd* x_l, sim::VectorXd* x_u, sim::VectorXd* g_l,
                      sim::VectorXd* g_u) const = 0;
  virtual sim::VectorXd StartingPoint() const = 0;
  /// 0 ≤ x[first] ⊥ x[second] ≥ 0; first ≠ second.
  virtual std::vector<std::pair<int, int>> ComplementarityPairs() const = 0;
  virtual bool Objective(const sim::VectorXd& x, double* f) const = 0;
  virtual bool Gradient(const sim::VectorXd& x, sim::VectorXd* grad) const = 0;
  virtual bool Constraints(const sim::VectorXd& x, sim::VectorXd* g) const = 0;
  /// The positions of the constraint Jacobian's structural non-zeros (fixed).
  virtual std::vector<Entry> JacobianStructure() const = 0;
  /// Values in the order of JacobianStructure().
  virtual bool JacobianValues(const sim::VectorXd& x, sim::VectorXd* values) const = 0;
  /// Whether HessianStructure/HessianValues are provided (else only limited memory can be used).
  virtual bool has_hessian() const { return false; }
  /// Lower triangle (row ≥ col) of ∇²(σ f + Σ λ_i g_i).
  virtual std::vector<Entry> HessianStructure() const { return {}; }
  /// Values of ∇²(obj_factor f + Σ lambda_i g_i) in the order of HessianStructure(); may be an
  /// approximation (then say so in the problem's documentation).
  virtual bool HessianValues(const sim::VectorXd& /*x*/, double /*obj_factor*/,
                             const sim::VectorXd& /*lambda*/, sim::VectorXd* /*values*/) const {
    return false;
  }
};

enum class ComplementarityMethod {
  kScholtes,  ///< x_a x_b ≤ ε, ε driven to ε_end
  kPenalty,   ///< ρ Σ x_a x_b added to the objective, ρ increased until complementary
};

/// "scholtes" or "penalty".
const char* ToString(ComplementarityMethod method);
/// Parses "scholtes" / "penalty"; throws std::invalid_argument naming the value otherwise.
ComplementarityMethod ParseComplementarityMethod(const std::string& name);

struct MpecSolverOptions {
  ComplementarityMethod method = ComplementarityMethod::kScholtes;
  double epsilon_start = 1e-1;  ///< Scholtes: first ε
  double epsilon_end = 1e-8;    ///< Scholtes: last ε
  double epsilon_factor = 0.1;  ///< Scholtes: κ, ε ← κ ε; in (0, 1)
  /// Penalty: first ρ. The entry NLPs (ρ_0, ρ_0 β, …, each from the starting point; a rejected
  /// one's iterate is discarded) end at the first whose solution has max x_a x_b ≤
  /// penalty_entry_epsilon (default epsilon_start) — a point of the first Scholtes relaxation
  /// — or at ρ_max; the later ρ are
  /// warm-started from it. Warm-starting from a solution far from complementary (products
  /// ~0.1–0.5 at ρ = 1, 10 on a noisy block log) led the larger ρ to a distant local solution,
  /// complementary by the process noise instead of the impulses (objective 190× the Scholtes
  /// optimum; docs/estimation.md).
  double penalty_start = 1.0;
  double penalty_factor = 10.0;  ///< penalty: β, ρ ← β ρ; > 1
  /// penalty: the entry's bound on max x_a x_b (each ρ solved cold and rejected until its
  /// solution meets it, see SolveMpec); ≤ 0: epsilon_start.
  double penalty_entry_epsilon = 0.0;
  double penalty_max = 1e10;  ///< penalty: last ρ at most
  /// Converged when the final iterate's complementarity violation max_pairs |min(x_a, x_b)| is
  /// at most this (and the last NLP solved). A relaxed iterate has min(x_a, x_b) ≤ ε / max(x_a,
  /// x_b) (plus Ipopt's bound relaxation, ~1e-8); a polished one is exactly complementary.
  double complementarity_tolerance = 1e-6;
  bool polish = true;  ///< the final NLP with the active set fixed
  /// Early polish (Scholtes only): after a relaxation stage (not the last), the polish NLP is
  /// tried from its iterate and accepted, ending the homotopy, if its objective is at most the
  /// stage's optimal value plus this (the stage's value is a lower bound of the MPEC's near
  /// the iterate: its feasible set contains the MPEC's; so the polished point is within this
  /// of what the remaining stages could reach). After one rejected attempt the homotopy
  /// continues without further ones. < 0: off (every stage run).
  double early_polish_tolerance = -1.0;
  /// The early polish is tried only after stages with ε ≤ this (a polish from a loose stage,
  /// whose active set is not identified yet, was measured to stall: 100 iterations after ε =
  /// 1e-2 on a noisy block).
  double early_polish_epsilon = std::numeric_limits<double>::infinity();
  /// Ipopt iterations of the early-polish attempt at most (0: max_iterations). From a stage
  /// whose active set is not yet identified the polish NLP can creep for thousands of
  /// iterations before failing (measured on a tossed cube: > 2 100 iterations, > 500 s of CPU);
  /// a capped attempt that fails keeps the relaxed iterate and the homotopy goes on.
  int early_polish_max_iterations = 0;
  /// The early polish's acceptance widened by the relaxation's first-order rise: accepted if
  /// its objective is at most the stage's value + early_polish_tolerance + this × ε Σ_k λ_k
  /// (λ_k ≥ 0 the multipliers of the stage's rows x_a x_b ≤ ε: −∂(optimal value)/∂ε of each,
  /// so ε Σ λ_k is the linear estimate of the value's rise as ε → 0). 0: the plain tolerance.
  double early_polish_rise_factor = 0.0;
  /// Stall exit of the relaxation / penalty stages (not the polish): a stage also ends, as
  /// solved to an acceptable level, after this many consecutive iterations in which the
  /// objective changed by at most stall_objective_change relative (max(1, |f|)) and the
  /// constraint violation was at most stall_constraint_violation (Ipopt's acceptable-level
  /// termination). Near a degenerate MPEC solution a relaxed NLP can creep for hundreds of
  /// iterations at its optimal value without meeting `tolerance` (measured on a noisy block
  /// log: the value was reached after ~190 iterations, the stage ended "infeasible" after 567);
  /// the polish that follows restores the tight tolerance. A problem without pairs (its one
  /// NLP, e.g. the active-set NLP of MpecOptions::least_squares_start) gets the same exit after
  /// max(15, stall_iterations) such iterations (its solution is the result; measured on a
  /// tossed cube: its dual infeasibility alternated between 3e-8 and 5e-4 from iteration ~59 to
  /// the cap of 300, at the central-difference state columns' rounding). 0: off (Ipopt's
  /// default, 15 iterations at 1e3 × tolerance).
  int stall_iterations = 0;
  /// Stall exit of the polish NLPs (early and final): a polish stops, as failed, once the best
  /// error max(primal, dual infeasibility) of Ipopt's last polish_stall_iterations iterations is
  /// not below polish_stall_reduction times the best before them. A polish whose fixed active
  /// set is wrong (its NLP infeasible or degenerate near the iterate) creeps with tiny steps
  /// instead of failing (measured on a tossed cube: thousands of iterations at dual
  /// infeasibility ~1–10); a polish from an identified active set converges in a few
  /// iterations. A stalled early polish keeps the relaxed iterate and the homotopy goes on; a
  /// stalled final polish leaves the relaxed iterate, converged only if its complementarity
  /// violation is within complementarity_tolerance, and the reason says so. 0: off.
  int polish_stall_iterations = 100;
  double polish_stall_reduction = 0.1;  ///< in (0, 1)
  /// The final polish's branch at a biactive pair (Scholtes only; an early polish fixes every
  /// pair's smaller side). A pair whose two sides are both at most biactive_factor √ε (ε: the
  /// last relaxation stage's) is biactive; the others fix their smaller side. At a biactive pair
  /// the relaxation's stationarity gives the MPEC multipliers of the sides' bounds x_a, x_b ≥ 0:
  /// ν_a = z_a − λ x_b, ν_b = z_b − λ x_a (z: the bound multipliers, λ ≥ 0 the multiplier of x_a
  /// x_b ≤ ε); ν < 0 means the objective decreases as that side leaves 0. The side with the larger
  /// ν is fixed at 0 and the other released (the branch with the steeper descent; either is exact
  /// when both ν ≥ 0, strong stationarity); equal ν: the smaller side is fixed. 0 (default):
  /// every pair fixes its smaller side. Off by default: measured only on the tossed cube (3: no
  /// change to its hard toss), not on the noisy-log studies.
  double biactive_factor = 0.0;
  /// Scholtes: the warm-started stages' distance of the starting point from its bounds, per ε:
  /// Ipopt's warm_start_bound_push, _bound_frac, _slack_bound_push and _slack_bound_frac are
  /// max(1e-9, this × ε) for the stage at ε. 0: 1e-9 at every stage (the polish NLPs: always
  /// 1e-9). A starting point with its sides ~1e-9 from their bounds made the first
  /// warm-started stage of a noisy log creep with steps cut by the fraction-to-the-boundary
  /// rule (measured, docs/estimation.md).
  double warm_start_push_per_epsilon = 0.0;
  /// Scholtes: the first (cold-started) stage's Ipopt bound_push, the least distance of its
  /// starting point from a lower bound of 0 (relative to max(1, |bound|)). 0: Ipopt's default
  /// (1e-2). The estimator leaves it at 0: 0.1 took fewer iterations on noisy planar logs and
  /// more, or failed, on noisy spatial ones (docs/estimation.md, "Warm push ε, and the cold push
  /// measured").
  double cold_bound_push = 0.0;
  /// Scholtes: before each warm-started stage ε, every pair with x_a x_b > ε has its smaller
  /// side moved onto the new hyperbola, x_min ← ε / x_max (a predictor along the relaxation
  /// path of a pair whose smaller side tends to 0; the step equations, not the relaxation rows,
  /// are then violated by the change). false: the last stage's iterate as it is.
  bool epsilon_predictor = false;
  /// Scholtes: when the final polish fails and the relaxed iterate's complementarity violation
  /// is above complementarity_tolerance, the homotopy goes on past epsilon_end (ε ← κ ε,
  /// warm-started) until the violation is within the tolerance or ε would fall below this. A
  /// relaxed iterate's violation is ~√ε, so a failed polish at ε = 1e-8 leaves ~1e-4 (measured
  /// on a tossed cube: 7.6e-5; 7.1e-7 at 1e-12). 0: off (also when ≥ epsilon_end).
  double epsilon_floor = 0.0;
  /// Ipopt iterations of each stage of that continuation at most (0: max_iterations). A stage
  /// that does not end within the cap leaves the last accepted iterate (MpecSolution::
  /// iterate_solved) and ends the continuation. Measured on 50 tossed cubes (warm-started
  /// tails, ε = 1e-9 … 1e-12): of 464 continued stages the median took 55 iterations, 95 %
  /// ≤ 490, and the 20 that failed ran the full 3 000 (60 000 of the run's 188 848 Ipopt
  /// iterations).
  int continued_max_iterations = 0;
  double stall_objective_change = 1e-7;
  double stall_constraint_violation = 1e-6;
  bool limited_memory = false;  ///< Ipopt's L-BFGS Hessian instead of the problem's
  /// Scholtes stages: the Hessian includes the relaxation rows' curvature λ_k (∂²(x_a x_b) =
  /// [0 1; 1 0], indefinite). false: it is left out, so the relaxation adds nothing to the
  /// problem's Hessian (a Gauss–Newton-like approximation; the linearized row x_b dx_a + x_a
  /// dx_b ≤ ε − x_a x_b is an inner approximation of the nonconvex set x_a x_b ≤ ε).
  bool relaxation_curvature = true;
  double tolerance = 1e-8;    ///< Ipopt tol of each NLP
  int max_iterations = 3000;  ///< Ipopt iterations per NLP
  int print_level = 0;        ///< Ipopt print_level (0 silent … 12)
  /// A deterministic MUMPS ordering: the same problem gives bitwise the same result run after
  /// run in one process and for any thread count of the problem's evaluation. SCOTCH on one
  /// thread (sets the environment variable SCOTCH_PTHREAD_NUMBER=1) with its random generator
  /// seeded (SCOTCH_randomSeed) before every NLP where MUMPS' SCOTCH is found in the process,
  /// else QAMD (approximate minimum degree; about twice the factorization cost
  /// here). Off: MUMPS' automatic choice (SCOTCH on large systems, whose random state persists
  /// between solves: last-digit differences).
  bool deterministic_ordering = false;
  /// With deterministic_ordering, MUMPS' fill-reducing ordering: SCOTCH (seeded, where found;
  /// else QAMD), QAMD, or kAuto: SCOTCH unless the KKT pattern has a dense vertex (degree above
  /// AMD's max(16, 10 √N)) joining parts that are otherwise disconnected and MUMPS' analysis of
  /// the pattern estimates > 100× QAMD's factorization flops with SCOTCH; then QAMD. One
  /// decision per SolveMpec, from the pattern of its NLPs (two MUMPS analyses, ~0.1 s on 27 000
  /// rows, only where that structure is found). Measured (bench/README.md, sessions 33–34): SCOTCH
  /// halves QAMD's factorization cost on one body's log (fewer delayed pivots); with k particles
  /// sharing μ (θ's column meets every step's rows, the particles only through θ) SCOTCH's
  /// largest front grows 65, 63, 156, 395, 753, 5 217, 5 628 for k = 1 … 8 (estimated flops
  /// 12× … 54 000× QAMD's; a factorization took 10 s at k = 7) while QAMD's stays at 17; with
  /// θ's edges removed SCOTCH's stays at ≤ 51. The joint NLP of several episodes (log files
  /// sharing only θ) has the same structure: on four block logs SCOTCH's factorizations took
  /// 0.9–2.2 s against QAMD's 0.08 s.
  enum class Ordering { kAuto, kScotch, kQamd };
  Ordering ordering = Ordering::kAuto;
  /// MUMPS' working storage beyond its analysis estimate, in percent (Ipopt's
  /// mumps_mem_percent; Ipopt's own default is 1000). MUMPS allocates and clears that storage
  /// at every factorization, so on these KKT systems (fronts of ≤ ~50 rows) a large reserve
  /// costs more than the factorization; when the storage runs out (delayed pivots) Ipopt
  /// doubles it and factorizes again. ≥ 1 (Ipopt doubles a 0 to 0).
  int mumps_mem_percent = 5;
  /// Called after each NLP with a one-line summary. May be empty. Must not throw.
  std::function<void(const std::string&)> progress;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// Parses "auto" / "scotch" / "qamd"; throws std::invalid_argument naming the value otherwise.
MpecSolverOptions::Ordering ParseMpecOrdering(const std::string& name);
/// "auto", "scotch" or "qamd".
const char* ToString(MpecSolverOptions::Ordering ordering);
/// The ordering SolveMpec(problem, o) uses (MpecSolution::ordering): o.ordering with
/// o.deterministic_ordering, kAuto resolved (o.progress told why when MUMPS' analyses decide),
/// QAMD where SCOTCH is not found; kAuto (MUMPS' own choice) without deterministic_ordering.
MpecSolverOptions::Ordering ResolveOrdering(const MpecProblem& problem, const MpecSolverOptions& o);

/// Multipliers to warm-start a Scholtes stage from a relaxed solution (MpecSolution::relaxed).
struct MpecMultipliers {
  /// Of the problem's constraints g, then of the relaxation rows x_a x_b ≤ ε (one per pair).
  sim::VectorXd lambda;
  sim::VectorXd z_l, z_u;  ///< of the variables' lower and upper bounds
};

struct MpecSolution {
  sim::VectorXd x;       ///< the final iterate
  sim::VectorXd lambda;  ///< multipliers of the problem's constraints g
  /// Scholtes: the last solved relaxation stage's ε (0: none), and, when the result is that
  /// stage's iterate (not polished), its multipliers (else empty).
  double final_epsilon = 0.0;
  MpecMultipliers relaxed;
  double objective = 0.0;
  /// max over pairs of |min(x_a, x_b)| (0 without pairs).
  double complementarity_violation = 0.0;
  /// Per pair: true if x_a is the side at zero (the polish stage fixes it), else x_b.
  std::vector<bool> first_at_zero;
  int iterations = 0;  ///< Ipopt iterations over all NLPs
  int stages = 0;      ///< NLPs solved (relaxation / penalty stages + polish)
  bool converged = false;
  /// The NLPs that gave the result solved (relaxation stages without a failure, or the polish);
  /// converged also needs the complementarity tolerance.
  bool solved = false;
  /// x is the solution of an NLP that solved (a relaxation or penalty stage, or the polish),
  /// also when a later stage failed; false when x is the starting point or a failed NLP's
  /// iterate.
  bool iterate_solved = false;
  bool polished = false;  ///< the polish stage succeeded and gave the final iterate
  /// Scholtes: the first relaxation stage did not solve, so no stage of the homotopy did; the
  /// result (polished or not) comes from that stage's failed iterate.
  bool first_stage_failed = false;
  /// The last polish attempt's biactive pairs (MpecSolverOptions::biactive_factor) and how
  /// many of them the multipliers fixed at the larger side instead of the smaller.
  int biactive_pairs = 0;
  int biactive_switched = 0;
  /// The ordering the NLPs used: kScotch or kQamd with deterministic_ordering (kAuto resolved),
  /// else kAuto (MUMPS' own choice).
  MpecSolverOptions::Ordering ordering = MpecSolverOptions::Ordering::kAuto;
  std::string reason;  ///< how the last NLP ended, and why not converged
  double time_s = 0.0;
};

/// Solves the MPEC from problem.StartingPoint(). With `warm_start` (Scholtes only), the first stage
/// is warm-started from those multipliers (a relaxed solution of a nearby problem with the same
/// variables, constraints and pairs). Throws std::invalid_argument for invalid options,
/// inconsistent sizes or a pair with equal or out-of-range indices, or an exact-Hessian run on
/// a problem without one; numerical failure is reported in the result. Sets the process' OpenBLAS
/// (if that is the BLAS loaded) to one thread, unless OPENBLAS_NUM_THREADS is set.
MpecSolution SolveMpec(const MpecProblem& problem, const MpecSolverOptions& options,
                       const MpecMultipliers* warm_start = nullptr);

}  // namespace vinci::estimation
