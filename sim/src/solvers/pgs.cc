// Block projected Gauss–Seidel / SOR for the LCP (Cottle, Pang & Stone, The Linear
// Complementarity Problem, 1992, §5.2; the block form is the one used for friction cones in
// contact dynamics, e.g. Erleben, "Velocity-based shock propagation", 2007).
//
// One sweep visits the blocks B of LcpProblem::blocks in order. With the other variables fixed
// at their latest values, block B is the small LCP
//
//   M_BB x + r_B ⊥ x ≥ 0,   r_B = q_B + M_B,rest z_rest = w_B − M_BB z_B,   w = M z + q,
//
// solved exactly (closed form for a scalar block with M_ii > 0, Lemke otherwise), then relaxed:
// z_B ← max(0, (1 − ω) z_B + ω x). w is kept up to date by the columns of the variables that
// changed (O(n |B|) per block) and recomputed from scratch every few sweeps to bound roundoff.
#include "vinci/sim/solvers/pgs.h"

#include <Eigen/QR>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "solver_util.h"
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

// Sweeps between recomputations of w = Mz + q from scratch; in between, w accumulates the
// rank-|B| updates of each block and with them O(ε‖M‖‖z‖) roundoff per update.
constexpr int kRefreshInterval = 10;
// A block whose local residual ‖min(z_B, w_B)‖_∞ is below this fraction of the global
// tolerance is already solved to well within it and is not re-solved (saves the Lemke call
// near convergence; the global stopping test still checks every row).
constexpr double kSkipFraction = 1e-3;

constexpr double kInf = std::numeric_limits<double>::infinity();

using internal::FormatDouble;

void ValidateOptions(const PgsOptions& o) {
  auto fail = [](const std::string& field, double value, const char* expected) {
    throw std::invalid_argument("PgsOptions." + field + " = " + FormatDouble(value) +
                                "; expected " + expected);
  };
  if (o.max_sweeps < 1) fail("max_sweeps", o.max_sweeps, ">= 1");
  if (!(o.tolerance >= 0.0) || !std::isfinite(o.tolerance)) {
    fail("tolerance", o.tolerance, "a finite value >= 0");
  }
  if (!(o.relaxation > 0.0 && o.relaxation < 2.0)) {
    fail("relaxation", o.relaxation, "a value in (0, 2)");
  }
  if (o.polish_interval < 0) fail("polish_interval", o.polish_interval, ">= 0");
}

// Empty if `blocks` partitions {0..n−1}; otherwise what is wrong.
std::string CheckBlocks(const std::vector<std::vector<int>>& blocks, int n) {
  if (blocks.empty()) return {};
  std::vector<int> owner(n, -1);
  for (int b = 0; b < static_cast<int>(blocks.size()); ++b) {
    if (blocks[b].empty()) return "block " + std::to_string(b) + " is empty";
    for (int i : blocks[b]) {
      if (i < 0 || i >= n) {
        return "block " + std::to_string(b) + " holds index " + std::to_string(i) +
               ", outside [0, " + std::to_string(n) + ")";
      }
      if (owner[i] >= 0) {
        return "index " + std::to_string(i) + " is in blocks " + std::to_string(owner[i]) +
               " and " + std::to_string(b);
      }
      owner[i] = b;
    }
  }
  for (int i = 0; i < n; ++i) {
    if (owner[i] < 0) return "index " + std::to_string(i) + " is in no block";
  }
  return {};
}

// Empty if `parts` is empty or fits `blocks` (LcpProblem::block_parts); otherwise what is wrong.
std::string CheckBlockParts(const std::vector<std::vector<int>>& parts,
                            const std::vector<std::vector<int>>& blocks) {
  if (parts.empty()) return {};
  if (parts.size() != blocks.size()) {
    return "block_parts has " + std::to_string(parts.size()) + " entries for " +
           std::to_string(blocks.size()) + " blocks";
  }
  for (std::size_t b = 0; b < parts.size(); ++b) {
    const int m = static_cast<int>(blocks[b].size());
    for (std::size_t p = 0; p < parts[b].size(); ++p) {
      const int s = parts[b][p];
      if ((p == 0 && s != 0) || (p > 0 && s <= parts[b][p - 1]) || s >= m) {
        return "block_parts[" + std::to_string(b) + "] = offset " + std::to_string(s) +
               " at position " + std::to_string(p) +
               "; expected 0 first, then increasing offsets below the block size " +
               std::to_string(m);
      }
    }
  }
  return {};
}

// ‖min(z, w)‖_∞, +∞ if anything is NaN.
double Residual(const VectorXd& z, const VectorXd& w) {
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(z(i)) || std::isnan(w(i))) return kInf;
    r = std::max(r, std::abs(std::min(z(i), w(i))));
  }
  return r;
}

std::string DescribeBlock(int b, const int* index, int size) {
  std::string s = "block " + std::to_string(b) + " {";
  for (int k = 0; k < size; ++k) s += (k ? ", " : "") + std::to_string(index[k]);
  return s + "}";
}

// Per-solve data of one block of size ≥ 2: its fixed M_BB and scratch for the local LCP.
struct LocalLcp {
  LcpProblem lcp;  // M_BB and r_B
  VectorXd z_b;    // current z_B (Lemke's warm start)
  VectorXd x;      // local solution
};

// ‖min(x, M x + r)‖_∞ of a block LCP, +∞ if anything is NaN.
double BlockResidual(const MatrixXd& M, const VectorXd& r, const VectorXd& x) {
  return Residual(x, M * x + r);
}

// Active-set refinement of a block solution x of M x + r ⊥ x ≥ 0 (block Lemke's result, when it
// misses its tight tolerance). A contact patch's M_BB is singular — its impulse columns act
// through the 12 velocities of two bodies, and the patch's normal forces are statically
// indeterminate — so Lemke's degenerate bases leave residuals of 1e-10…1e-9 on impulses of
// ~1e-2 (box stack), a floor right at PGS's global tolerance. Each refinement step takes the
// active set A = {i : x_i > w_i}, sets x_i = 0 off A and the minimum-norm correction δ of
// M_AA δ = −w_A on A (complete orthogonal decomposition, rank-revealing, so the singular M_AA
// is fine), projects onto x ≥ 0 and keeps the result only if the block residual drops.
// Returns the block residual of the (possibly unchanged) x.
double RefineOnActiveSet(const MatrixXd& M, const VectorXd& r, VectorXd* x) {
  constexpr int kMaxRefinements = 3;
  const int m = static_cast<int>(r.size());
  double residual = BlockResidual(M, r, *x);
  std::vector<int> active;
  for (int it = 0; it < kMaxRefinements && residual > 0.0 && std::isfinite(residual); ++it) {
    const VectorXd w = M * *x + r;
    active.clear();
    for (int i = 0; i < m; ++i)
      if ((*x)(i) > w(i)) active.push_back(i);
    const int k = static_cast<int>(active.size());
    VectorXd trial = VectorXd::Zero(m);
    if (k > 0) {
      MatrixXd M_aa(k, k);
      VectorXd w_a(k);
      for (int c = 0; c < k; ++c) {
        for (int rr = 0; rr < k; ++rr) M_aa(rr, c) = M(active[rr], active[c]);
      }
      // w_A after zeroing x off A.
      for (int rr = 0; rr < k; ++rr) {
        double v = w(active[rr]);
        for (int i = 0; i < m; ++i) {
          if ((*x)(i) <= w(i)) v -= M(active[rr], i) * (*x)(i);
        }
        w_a(rr) = v;
      }
      const VectorXd delta = M_aa.completeOrthogonalDecomposition().solve(-w_a);
      for (int c = 0; c < k; ++c) trial(active[c]) = std::max(0.0, (*x)(active[c]) + delta(c));
    }
    const double trial_residual = BlockResidual(M, r, trial);
    if (!(trial_residual < residual)) break;
    *x = trial;
    residual = trial_residual;
  }
  return residual;
}

}  // namespace

SolverReport PgsSolver::Solve(const LcpProblem& problem, const VectorXd* warm_start,
                              VectorXd* z) const {
  if (z == nullptr) {
    throw std::invalid_argument("PgsSolver::Solve: z is null; expected an output vector");
  }
  ValidateOptions(options_);
  const auto start = std::chrono::steady_clock::now();
  SolverReport report;
  auto finish = [&]() {
    report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
  };
  auto invalid = [&](std::string message) {
    z->setZero(problem.q.size());
    report.status = SolverStatus::kInvalidInput;
    report.residual = std::numeric_limits<double>::quiet_NaN();
    report.message = std::move(message);
    return finish();
  };

  const int n = static_cast<int>(problem.q.size());
  if (std::string bad = CheckLcpData(problem); !bad.empty()) return invalid(std::move(bad));
  if (const std::string bad = CheckBlocks(problem.blocks, n); !bad.empty()) {
    return invalid("LcpProblem::blocks is not a partition of the " + std::to_string(n) +
                   " variables: " + bad);
  }
  if (const std::string bad = CheckBlockParts(problem.block_parts, problem.blocks); !bad.empty()) {
    return invalid("LcpProblem::block_parts does not fit the blocks: " + bad);
  }
  if (n == 0) {
    z->resize(0);
    report.status = SolverStatus::kSolved;
    return finish();
  }
  const double tolerance = options_.tolerance * std::max(1.0, problem.q.lpNorm<Eigen::Infinity>());
  report.tolerance = tolerance;

  // Initial iterate: the warm start projected onto z ≥ 0 (it may alias *z), else zero.
  if (warm_start != nullptr && warm_start->size() == n && warm_start->allFinite()) {
    *z = warm_start->cwiseMax(0.0);
  } else {
    z->setZero(n);
  }
  double residual = LcpResidual(problem, *z);
  if (residual <= tolerance && CheckLcpSolution(problem, *z).empty()) {
    report.status = SolverStatus::kSolved;
    report.residual = residual;
    return finish();
  }
  VectorXd w = problem.M * *z + problem.q;

  // Block layout, flattened: block b holds index[begin[b] .. begin[b + 1]).
  std::vector<int> index, begin, local_of;
  if (problem.blocks.empty()) {
    index.resize(n);
    begin.resize(n + 1);
    for (int i = 0; i <= n; ++i) begin[i] = i;
    for (int i = 0; i < n; ++i) index[i] = i;
  } else {
    index.reserve(n);
    begin.reserve(problem.blocks.size() + 1);
    for (const std::vector<int>& b : problem.blocks) {
      begin.push_back(static_cast<int>(index.size()));
      index.insert(index.end(), b.begin(), b.end());
    }
    begin.push_back(n);
  }
  const int num_blocks = static_cast<int>(begin.size()) - 1;
  // Blocks of size ≥ 2 get their M_BB extracted once per solve.
  std::vector<LocalLcp> locals;
  local_of.assign(num_blocks, -1);
  for (int b = 0; b < num_blocks; ++b) {
    const int m = begin[b + 1] - begin[b];
    if (m < 2) continue;
    local_of[b] = static_cast<int>(locals.size());
    LocalLcp& l = locals.emplace_back();
    const int* idx = index.data() + begin[b];
    l.lcp.M.resize(m, m);
    for (int c = 0; c < m; ++c) {
      for (int r = 0; r < m; ++r) l.lcp.M(r, c) = problem.M(idx[r], idx[c]);
    }
    l.lcp.q.resize(m);
    l.z_b.resize(m);
    l.x.resize(m);
  }
  // The block solves need to be at least as accurate as the global tolerance asks. Lemke scales
  // its residual_tolerance by up to 1000·max(1, ‖q_B‖∞) (lemke.h), and it accepts a warm start
  // that passes that test, so the factor 1e-3 keeps an accepted block within the tolerance.
  LemkeOptions lemke_options;
  lemke_options.residual_tolerance =
      std::max(1e-14, 1e-3 * std::min(lemke_options.residual_tolerance, options_.tolerance));
  const LemkeSolver lemke(lemke_options);
  const double block_tolerance = std::min(1e-9, options_.tolerance);
  const double omega = options_.relaxation;
  // Blocks within kSkipFraction of the tolerance are skipped, unless the iterate already meets
  // the tolerance but not the scale-aware check (a problem in small units, where the absolute
  // floor of `tolerance` hides every block's error): then no block is skipped.
  double skip_tolerance = residual <= tolerance ? 0.0 : kSkipFraction * tolerance;

  VectorXd best = *z;
  double best_residual = residual;
  bool solved = false;
  std::string failure;

  // Moves z_i to x (after relaxation and projection) and updates w.
  auto update = [&](int i, double x) {
    x = std::max(0.0, (1.0 - omega) * (*z)(i) + omega * x);
    const double delta = x - (*z)(i);
    if (delta == 0.0) return;
    w.noalias() += problem.M.col(i) * delta;
    (*z)(i) = x;
  };

  // The 1×1 block {i}; returns why it has no solution, else "".
  auto solve_scalar = [&](int i) -> std::string {
    const double d = problem.M(i, i);
    if (d > 0.0) {
      const double z_i = (*z)(i);
      update(i, std::max(0.0, z_i - w(i) / d));
      return {};
    }
    // 1×1 LCP d x + r ⊥ x ≥ 0 with d ≤ 0: x = 0 if r ≥ 0; no solution if r < 0.
    const double r = w(i) - d * (*z)(i);
    if (r >= 0.0) {
      update(i, 0.0);
      return {};
    }
    return "variable " + std::to_string(i) + " has M_ii = " + FormatDouble(d) +
           " <= 0 and r_i = " + FormatDouble(r) +
           " < 0, so its 1x1 LCP given the other variables has no solution (scalar "
           "PGS cannot handle rows with a non-positive diagonal; group them with the "
           "variables they couple to in LcpProblem::blocks)";
  };
  // The block LCP of the rows idx[0..m) (m = l->x.size(), l->lcp.M = M_BB filled in): sets
  // l->x to its solution given the other variables (not applied yet); returns why it failed,
  // else "".
  auto solve_block = [&](const int* idx, LocalLcp* l) -> std::string {
    const int m = static_cast<int>(l->x.size());
    for (int k = 0; k < m; ++k) l->z_b(k) = (*z)(idx[k]);
    l->lcp.q.noalias() = -l->lcp.M * l->z_b;
    for (int k = 0; k < m; ++k) l->lcp.q(k) += w(idx[k]);
    if (l->lcp.q.minCoeff() >= 0.0) {
      l->x.setZero();  // Lemke's trivial case, without the call
      return {};
    }
    const SolverReport local = lemke.Solve(l->lcp, &l->z_b, &l->x);
    if (local.ok()) return {};
    // A block Lemke cannot bring below its tight tolerance is refined on its active set
    // (RefineOnActiveSet) and then accepted at the global tolerance.
    double refined = local.residual;
    if (l->x.size() == m && l->x.allFinite())
      refined = RefineOnActiveSet(l->lcp.M, l->lcp.q, &l->x);
    if (std::isfinite(refined) && l->x.allFinite() &&
        refined <= block_tolerance * std::max(1.0, l->lcp.q.lpNorm<Eigen::Infinity>())) {
      return {};
    }
    return "Lemke failed on the block LCP (" + std::string(ToString(local.status)) +
           (local.message.empty() ? "" : ": " + local.message) + "; residual after refinement " +
           FormatDouble(refined) + ")";
  };

  int sweep = 0, part_fallbacks = 0;
  std::vector<char> use_parts(num_blocks, 0);  // blocks solved by their parts (fallback)
  const int polish_interval = options_.polish_interval;
  while (sweep < options_.max_sweeps && !solved && failure.empty()) {
    for (int b = 0; b < num_blocks && failure.empty(); ++b) {
      const int* idx = index.data() + begin[b];
      const int m = begin[b + 1] - begin[b];
      double local_residual = 0.0;
      for (int k = 0; k < m; ++k) {
        local_residual = std::max(local_residual, std::abs(std::min((*z)(idx[k]), w(idx[k]))));
      }
      if (local_residual <= skip_tolerance) continue;

      if (m == 1) {
        failure = solve_scalar(idx[0]);
        continue;
      }
      std::string error;
      if (!use_parts[b]) {
        LocalLcp& l = locals[local_of[b]];
        error = solve_block(idx, &l);
        if (error.empty()) {
          for (int k = 0; k < m; ++k) update(idx[k], l.x(k));
          continue;
        }
      }
      // Fallback: the block's parts (LcpProblem::block_parts, e.g. the contacts of a patch),
      // one Gauss–Seidel pass over them in order.
      const std::vector<int>* parts = problem.block_parts.empty() || problem.block_parts[b].empty()
                                          ? nullptr
                                          : &problem.block_parts[b];
      if (parts == nullptr) {
        failure = DescribeBlock(b, idx, m) + ": " + error;
        continue;
      }
      if (!use_parts[b]) ++part_fallbacks;
      use_parts[b] = 1;  // for the rest of this solve
      for (std::size_t p = 0; p < parts->size() && failure.empty(); ++p) {
        const int s = (*parts)[p];
        const int e = p + 1 < parts->size() ? (*parts)[p + 1] : m;
        if (e - s == 1) {
          failure = solve_scalar(idx[s]);
          continue;
        }
        LocalLcp part;
        part.lcp.M.resize(e - s, e - s);
        for (int c = s; c < e; ++c) {
          for (int r = s; r < e; ++r) part.lcp.M(r - s, c - s) = problem.M(idx[r], idx[c]);
        }
        part.lcp.q.resize(e - s);
        part.z_b.resize(e - s);
        part.x.resize(e - s);
        const std::string part_error = solve_block(idx + s, &part);
        if (!part_error.empty()) {
          failure = DescribeBlock(b, idx, m) + ": " + error + "; part " + std::to_string(p) +
                    " of the block (the fallback) failed: " + part_error;
          continue;
        }
        for (int k = s; k < e; ++k) update(idx[k], part.x(k - s));
      }
    }
    ++sweep;
    if (!failure.empty()) break;

    bool exact = false;
    if (sweep % kRefreshInterval == 0) {
      w.noalias() = problem.M * *z;
      w += problem.q;
      exact = true;
    }
    residual = Residual(*z, w);
    if (polish_interval > 0 && residual > tolerance && sweep % polish_interval == 0 &&
        std::isfinite(residual)) {
      // Subspace minimization on the active set PGS has identified (RefineOnActiveSet).
      const double before = residual;
      residual = RefineOnActiveSet(problem.M, problem.q, z);
      if (residual < before) {
        w.noalias() = problem.M * *z;
        w += problem.q;
        exact = true;
      }
    }
    if (residual <= tolerance) {
      // Stop only on the independent residual (the updated w carries roundoff).
      residual = LcpResidual(problem, *z);
      if (!exact) {
        w.noalias() = problem.M * *z;
        w += problem.q;
      }
    }
    if (std::isnan(residual) || residual == kInf || !z->allFinite()) {
      failure = "the iterate became non-finite at sweep " + std::to_string(sweep) +
                " (divergence; try a smaller relaxation)";
      break;
    }
    if (residual < best_residual) {
      best_residual = residual;
      best = *z;
    }
    // The absolute floor of `tolerance` (max(1, ‖q‖∞)) would accept z = 0 on a problem in
    // small units: sweep on until the scale-aware check passes too (lcp_acceptance.h).
    solved = residual <= tolerance && CheckLcpSolution(problem, *z).empty();
    if (residual <= tolerance && !solved) skip_tolerance = 0.0;
  }

  report.iterations = sweep;
  report.restarts = part_fallbacks;
  if (solved) {
    report.status = SolverStatus::kSolved;
  } else {
    *z = best;
    if (failure.empty()) {
      report.status = SolverStatus::kMaxIterations;
      report.message = "PGS reached the sweep limit " + std::to_string(options_.max_sweeps) +
                       " with residual " + FormatDouble(best_residual) + " > tolerance " +
                       FormatDouble(tolerance) + "; returning the best iterate";
    } else {
      report.status = SolverStatus::kNumericalFailure;
      report.message = "PGS stopped at sweep " + std::to_string(sweep) + ": " + failure +
                       "; returning the best iterate (residual " + FormatDouble(best_residual) +
                       ")";
    }
  }
  report.residual = LcpResidual(problem, *z);
  if (report.status == SolverStatus::kSolved && !(report.residual <= tolerance)) {
    throw std::logic_error("PgsSolver: solved iterate fails the residual check");
  }
  ConfirmSolved(problem, *z, &report);
  return finish();
}

}  // namespace vinci::sim
