// Semismooth Newton on the penalized Fischer–Burmeister reformulation of the LCP (Chen, Chen &
// Kanzow, "A penalized Fischer–Burmeister NCP-function", Math. Program. 88, 2000; the
// generalized Jacobian and the descent safeguard follow De Luca, Facchinei & Kanzow, Math.
// Program. 75, 1996). With a = z, b = w = Mz + q, componentwise
//
//   Φ_i(z) = λ (√(a_i² + b_i²) − a_i − b_i) − (1 − λ) max(0, a_i) max(0, b_i),
//
// Φ(z) = 0 ⇔ z solves the LCP. Each iteration solves H d = −Φ with H = D_a + D_b M an element
// of the generalized Jacobian, and backtracks on Ψ = ½‖Φ‖² against the largest Ψ of the last
// few iterates (non-monotone Armijo). The returned point is z₊ = max(z, 0).
#include "vinci/sim/solvers/fischer_burmeister.h"

#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

#include "solver_util.h"
#include "vinci/sim/solvers/lcp_acceptance.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim {
namespace {

// Non-monotone reference: the largest Ψ among the last kHistory iterates (Grippo, Lampariello
// & Lucidi 1986); lets Newton take full steps through the kinks of Φ.
constexpr int kHistory = 5;
// Armijo sufficient-decrease constant and backtracking factor.
constexpr double kArmijo = 1e-4;
constexpr double kBacktrack = 0.5;
// Smallest step tried is 0.5^40 ≈ 1e-12 of the direction.
constexpr int kMaxBacktracks = 40;
// Newton direction d is used only if ∇Ψᵀd ≤ −ρ‖d‖^p (De Luca, Facchinei & Kanzow 1996);
// otherwise the iteration takes the steepest-descent direction −∇Ψ.
constexpr double kDescentRho = 1e-10;
constexpr double kDescentP = 2.1;
// LU is trusted when its reciprocal condition estimate exceeds this; otherwise the direction is
// the minimum-norm least-squares solution from a complete orthogonal decomposition (column-
// pivoting QR, then an RZ step). Degenerate contact LCPs (indeterminate normal impulses) have
// non-isolated solutions and an exactly singular H; on the 10-box stack at rest the basic
// solution of plain column-pivoting QR, which puts arbitrary values on the null space, needed
// 138 iterations where the minimum-norm step needs 8.
constexpr double kMinRcond = std::numeric_limits<double>::epsilon();

// Proximal-point fallback (see fischer_burmeister.h): initial weight, its bounds and step, all
// relative to s = max(1, max_i |M_ii|); an outer step that does not reduce the residual by
// kProximalProgress counts as stalled; limits on outer steps and on Newton steps (in units of
// max_iterations). On the tilted pile (box_pile_tilted_step233.lcp, s = 15) every initial
// weight 1e-6·s … 1e-4·s solved in 2–5 outer steps; a fixed weight stalls for several outer
// steps at residual 6e-9 (moving z by r/c each step), which the decrease of c cures.
constexpr double kProximalWeight = 1e-5;
constexpr double kProximalMinWeight = 1e-10;
constexpr double kProximalMaxWeight = 1e-1;
constexpr double kProximalWeightStep = 10.0;
constexpr double kProximalProgress = 0.5;
constexpr int kProximalOuterSteps = 30;
constexpr int kProximalNewtonBudget = 1;
// Newton steps per subproblem: warm-started subproblems that Newton can solve take 1–17 steps on
// the pile LCPs; a larger limit only spends the budget on subproblems that stall (on a cold
// pile step, box_pile_tilted_cold_step232.lcp, 100 steps per subproblem took 12 s where 20 take
// 1.8 s for the same final residual).
constexpr int kProximalSubIterations = 20;

using internal::FormatDouble;

void ValidateOptions(const FischerBurmeisterOptions& o) {
  auto fail = [](const std::string& field, double value, const char* expected) {
    throw std::invalid_argument("FischerBurmeisterOptions." + field + " = " + FormatDouble(value) +
                                "; expected " + expected);
  };
  if (o.max_iterations < 0) fail("max_iterations", o.max_iterations, ">= 0");
  if (!(o.tolerance >= 0.0) || !std::isfinite(o.tolerance)) {
    fail("tolerance", o.tolerance, "a finite value >= 0");
  }
  if (!(o.lambda > 0.0 && o.lambda <= 1.0)) fail("lambda", o.lambda, "a value in (0, 1]");
}

// Φ(z) for a = z, b = w; returns Ψ = ½‖Φ‖² (NaN propagates).
double EvaluatePhi(const VectorXd& a, const VectorXd& b, double lambda, VectorXd* phi) {
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    const double ai = a(i), bi = b(i);
    (*phi)(i) = lambda * (std::hypot(ai, bi) - ai - bi) -
                (1.0 - lambda) * std::max(ai, 0.0) * std::max(bi, 0.0);
  }
  return 0.5 * phi->squaredNorm();
}

// Diagonals of H = D_a + D_b M. Where a_i = b_i = 0 the norm √(a² + b²) is not differentiable;
// the element of its subdifferential taken is the unit vector (1, 1)/√2. The penalty term uses
// the one-sided derivative of max(0, ·) that is 0 at 0.
void JacobianDiagonals(const VectorXd& a, const VectorXd& b, double lambda, VectorXd* da,
                       VectorXd* db) {
  const double kInvSqrt2 = 1.0 / std::sqrt(2.0);
  for (Eigen::Index i = 0; i < a.size(); ++i) {
    const double ai = a(i), bi = b(i);
    const double r = std::hypot(ai, bi);
    const double ua = r > 0.0 ? ai / r : kInvSqrt2;
    const double ub = r > 0.0 ? bi / r : kInvSqrt2;
    (*da)(i) = lambda * (ua - 1.0) - (1.0 - lambda) * (ai > 0.0 ? std::max(bi, 0.0) : 0.0);
    (*db)(i) = lambda * (ub - 1.0) - (1.0 - lambda) * (bi > 0.0 ? std::max(ai, 0.0) : 0.0);
  }
}

// ‖min(z, w)‖_∞, NaN if anything is NaN (as LcpResidual).
double Residual(const VectorXd& z, const VectorXd& w) {
  double r = 0.0;
  for (Eigen::Index i = 0; i < z.size(); ++i) {
    if (std::isnan(z(i)) || std::isnan(w(i))) return std::numeric_limits<double>::quiet_NaN();
    r = std::max(r, std::abs(std::min(z(i), w(i))));
  }
  return r;
}

struct ProximalOutcome {
  VectorXd z;  // the iterate with the smallest residual on the original problem
  double residual = 0.0;
  int outer_steps = 0;
  int newton_steps = 0;
  double c_min = 0.0, c_max = 0.0;  // range of the weights used
};

// Proximal-point outer loop: z_{k+1} solves LCP(M + c I, q − c z_k) by Newton (no fallbacks),
// warm-started at z_k; stops once the residual on the original problem passes `tolerance`.
ProximalOutcome ProximalPoint(const LcpProblem& problem, const FischerBurmeisterOptions& options,
                              double tolerance, const VectorXd& start, double start_residual) {
  const double s = std::max(1.0, problem.M.diagonal().cwiseAbs().maxCoeff());
  double c = kProximalWeight * s;
  FischerBurmeisterOptions sub_options = options;
  sub_options.lemke_fallback = false;
  sub_options.proximal_fallback = false;
  LcpProblem sub;
  sub.M = problem.M;
  sub.M.diagonal().array() += c;
  ProximalOutcome out;
  out.z = start;
  out.residual = start_residual;
  out.c_min = out.c_max = c;
  VectorXd z_k = start, z_sub;
  double r_k = start_residual;
  const int budget = kProximalNewtonBudget * std::max(1, options.max_iterations);
  while (out.outer_steps < kProximalOuterSteps && out.residual > tolerance &&
         out.newton_steps < budget) {
    sub.q = problem.q - c * z_k;
    sub_options.max_iterations =
        std::min({options.max_iterations, kProximalSubIterations, budget - out.newton_steps});
    const SolverReport r = FischerBurmeisterSolver(sub_options).Solve(sub, &z_k, &z_sub);
    out.newton_steps += r.iterations;
    ++out.outer_steps;
    const double residual = LcpResidual(problem, z_sub);
    if (residual < out.residual) {
      out.z = z_sub;
      out.residual = residual;
    }
    double c_next = c;
    // The iterate moves only if the subproblem was solved or its result improved.
    bool move = true;
    if (!r.ok()) {
      // Subproblem not solved: a larger weight makes it better conditioned.
      c_next = c * kProximalWeightStep;
      if (c_next > kProximalMaxWeight * s) break;
      move = residual < r_k;
    } else if (!(residual <= kProximalProgress * r_k)) {
      // Stalled: a smaller weight takes longer steps.
      c_next = std::max(c / kProximalWeightStep, kProximalMinWeight * s);
    }
    if (move) {
      z_k = z_sub;
      r_k = residual;
    }
    if (c_next != c) {
      sub.M.diagonal().array() += c_next - c;
      c = c_next;
      out.c_min = std::min(out.c_min, c);
      out.c_max = std::max(out.c_max, c);
    }
  }
  return out;
}

}  // namespace

SolverReport FischerBurmeisterSolver::Solve(const LcpProblem& problem, const VectorXd* warm_start,
                                            VectorXd* z) const {
  if (z == nullptr) {
    throw std::invalid_argument(
        "FischerBurmeisterSolver::Solve: z is null; expected an output vector");
  }
  ValidateOptions(options_);
  const auto start = std::chrono::steady_clock::now();
  SolverReport report;
  auto finish = [&]() {
    report.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return report;
  };

  const Eigen::Index n = problem.q.size();
  if (std::string invalid = CheckLcpData(problem); !invalid.empty()) {
    z->setZero(n);
    report.status = SolverStatus::kInvalidInput;
    report.residual = std::numeric_limits<double>::quiet_NaN();
    report.message = std::move(invalid);
    return finish();
  }
  if (n == 0) {
    z->resize(0);
    report.status = SolverStatus::kSolved;
    return finish();
  }
  const double tolerance = options_.tolerance * std::max(1.0, problem.q.lpNorm<Eigen::Infinity>());
  const double lambda = options_.lambda;
  const MatrixXd& M = problem.M;

  // Iterate x (may leave the orthant); the candidate answer is x₊ = max(x, 0).
  VectorXd x = VectorXd::Zero(n);
  if (warm_start != nullptr && warm_start->size() == n && warm_start->allFinite()) {
    x = *warm_start;  // before *z is written: warm_start may alias z
  }
  VectorXd best = x.cwiseMax(0.0);
  double best_residual = LcpResidual(problem, best);
  // `tolerance` has an absolute floor (max(1, ‖q‖∞)) that would accept z = 0 on a problem in
  // small units: every acceptance also needs the scale-aware check (lcp_acceptance.h).
  const auto acceptable = [&](const VectorXd& candidate_z, double r) {
    return r <= tolerance && CheckLcpSolution(problem, candidate_z).empty();
  };
  if (acceptable(best, best_residual)) {
    *z = std::move(best);
    report.status = SolverStatus::kSolved;
    report.residual = best_residual;
    report.tolerance = tolerance;
    return finish();
  }

  // Per-solve scratch; nothing below allocates per iteration except Eigen's internal LU/QR
  // temporaries.
  VectorXd w = M * x + problem.q;
  VectorXd phi(n), da(n), db(n), grad(n), d(n), md(n), x_trial(n), w_trial(n), phi_trial(n);
  VectorXd candidate(n), w_candidate(n);
  MatrixXd H(n, n);
  Eigen::PartialPivLU<MatrixXd> lu(n);
  Eigen::CompleteOrthogonalDecomposition<MatrixXd> cod(n, n);
  double psi = EvaluatePhi(x, w, lambda, &phi);
  std::array<double, kHistory> history;
  history.fill(psi);
  int least_squares = 0, gradient_steps = 0;
  bool solved = false;
  std::string failure;

  // Backtracking along d from x with slope ∇Ψᵀd < 0 against `reference`; on success x_trial
  // holds the accepted point.
  auto line_search = [&](double slope, double reference) {
    md.noalias() = M * d;
    double t = 1.0;
    for (int k = 0; k < kMaxBacktracks; ++k, t *= kBacktrack) {
      x_trial = x + t * d;
      w_trial = w + t * md;
      const double psi_t = EvaluatePhi(x_trial, w_trial, lambda, &phi_trial);
      if (psi_t <= reference + kArmijo * t * slope) return true;
    }
    return false;
  };

  int iteration = 0;
  while (iteration < options_.max_iterations) {
    JacobianDiagonals(x, w, lambda, &da, &db);
    H.noalias() = db.asDiagonal() * M;
    H.diagonal() += da;
    grad.noalias() = H.transpose() * phi;

    // Newton direction H d = −Φ: LU, or the minimum-norm least-squares solution if H is
    // (near) singular.
    lu.compute(H);
    bool newton = false;
    if (lu.rcond() > kMinRcond) {
      d.noalias() = lu.solve(phi);
      d = -d;
      newton = d.allFinite();
    }
    if (!newton) {
      ++least_squares;
      cod.compute(H);
      d.noalias() = cod.solve(phi);
      d = -d;
      newton = d.allFinite();
    }
    double slope = newton ? grad.dot(d) : 0.0;
    if (!newton || !(slope <= -kDescentRho * std::pow(d.norm(), kDescentP))) {
      newton = false;
      d = -grad;
      slope = -grad.squaredNorm();
    }
    if (!(slope < 0.0)) {
      failure = "Psi = 0.5*|Phi|^2 = " + FormatDouble(psi) +
                " is stationary at a point that does not solve the LCP (gradient " +
                FormatDouble(grad.norm()) + ")";
      break;
    }
    const double reference = *std::max_element(history.begin(), history.end());
    bool accepted = line_search(slope, reference);
    if (!accepted && newton) {
      newton = false;
      d = -grad;
      slope = -grad.squaredNorm();
      accepted = slope < 0.0 && line_search(slope, reference);
    }
    if (!accepted) {
      failure = "the line search found no decrease of Psi = " + FormatDouble(psi) +
                " along the Newton or the gradient direction at iteration " +
                std::to_string(iteration + 1);
      break;
    }
    if (!newton) ++gradient_steps;
    ++iteration;
    x.swap(x_trial);
    // Recompute w exactly rather than accumulating t·Md.
    w.noalias() = M * x;
    w += problem.q;
    psi = EvaluatePhi(x, w, lambda, &phi);
    std::rotate(history.begin(), history.begin() + 1, history.end());
    history.back() = psi;
    if (!std::isfinite(psi)) {
      failure = "non-finite iterate at iteration " + std::to_string(iteration);
      break;
    }

    candidate = x.cwiseMax(0.0);
    w_candidate.noalias() = M * candidate;
    w_candidate += problem.q;
    const double r = Residual(candidate, w_candidate);
    if (r < best_residual) {
      best_residual = r;
      best = candidate;
    }
    if (acceptable(candidate, r)) {
      best_residual = r;
      best = candidate;
      solved = true;
      break;
    }
  }

  *z = std::move(best);
  report.iterations = iteration;
  report.residual = LcpResidual(problem, *z);
  std::string stats;
  if (least_squares > 0 || gradient_steps > 0) {
    stats = " (" + std::to_string(least_squares) + " least-squares directions, " +
            std::to_string(gradient_steps) + " gradient steps)";
  }
  if (solved && acceptable(*z, report.residual)) {
    report.status = SolverStatus::kSolved;
    // Only the safeguards are worth a message on success.
    if (!stats.empty()) report.message = "solved" + stats;
  } else if (failure.empty()) {
    report.status = SolverStatus::kMaxIterations;
    report.message = "FB Newton reached the iteration limit " +
                     std::to_string(options_.max_iterations) + " with residual " +
                     FormatDouble(report.residual) + " > tolerance " + FormatDouble(tolerance) +
                     stats + "; returning the best iterate";
  } else {
    report.status = SolverStatus::kNumericalFailure;
    report.message = "FB Newton: " + failure + stats + "; returning the best iterate (residual " +
                     FormatDouble(report.residual) + ")";
  }
  if (!report.ok() && options_.proximal_fallback) {
    const ProximalOutcome prox = ProximalPoint(problem, options_, tolerance, *z, report.residual);
    report.restarts = 1;
    report.iterations += prox.newton_steps;
    const std::string what = std::to_string(prox.outer_steps) +
                             " proximal-point steps on M + c*I, c in [" + FormatDouble(prox.c_min) +
                             ", " + FormatDouble(prox.c_max) + "], " +
                             std::to_string(prox.newton_steps) + " Newton steps";
    if (prox.residual < report.residual) {
      *z = prox.z;
      report.residual = LcpResidual(problem, *z);
    }
    if (acceptable(*z, report.residual)) {
      report.status = SolverStatus::kSolved;
      report.message =
          "solved by the proximal-point fallback (" + what + ") after " + report.message;
    } else {
      report.message += "; the proximal-point fallback (" + what + ") reached residual " +
                        FormatDouble(report.residual);
    }
  }
  if (!report.ok() && options_.lemke_fallback) {
    // Fallback: Lemke warm-started at the best iterate, then Newton from Lemke's answer to
    // reach this solver's (tighter) tolerance. Both nested solves run without fallbacks.
    VectorXd z_lemke;
    const SolverReport lemke = LemkeSolver().Solve(problem, z, &z_lemke);
    report.restarts += 1;
    report.iterations += lemke.iterations;
    if (lemke.ok()) {
      FischerBurmeisterOptions polish_options = options_;
      polish_options.lemke_fallback = false;
      VectorXd z_polished;
      const SolverReport polish =
          FischerBurmeisterSolver(polish_options).Solve(problem, &z_lemke, &z_polished);
      report.iterations += polish.iterations;
      VectorXd& chosen = polish.ok() ? z_polished : z_lemke;
      const double r = LcpResidual(problem, chosen);
      if (acceptable(chosen, r)) {
        report.status = SolverStatus::kSolved;
        report.residual = r;
        report.message = "solved by the Lemke fallback (" + std::to_string(lemke.iterations) +
                         " pivots, then " + std::to_string(polish.iterations) +
                         " Newton steps) after " + report.message;
        *z = std::move(chosen);
      } else {
        report.message += "; the Lemke fallback reached residual " + FormatDouble(r);
      }
    } else {
      report.message += "; the Lemke fallback failed too (" + lemke.message + ")";
    }
  }
  report.tolerance = tolerance;
  ConfirmSolved(problem, *z, &report);
  return finish();
}

}  // namespace vinci::sim
