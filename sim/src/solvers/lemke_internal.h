// Private pieces shared by the dense (lemke.cc) and sparse (sparse_lemke.cc) Lemke solvers: the
// tolerances of the ratio test and of the acceptance test, the power-of-two scaling factors, the
// options check and the ratio test itself, so that both variants pivot by the same rules.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/lemke.h"

namespace vinci::sim::internal::lemke {

// Ratios within this relative distance of the minimum ratio are ties (degenerate pivots).
// Degenerate basic values carry roundoff of order ε‖B⁻¹‖‖q‖ ≈ 1e-14, which pivots of order
// 1e-3 turn into ratios of 1e-11; 1e-12 missed such ties on a random contact LCP (n = 108)
// and ended on a spurious secondary ray, 1e-10 solved 14 400 random stress problems.
//
// The same constant, times max(1, ‖q‖∞), is also an absolute tolerance on the basic values
// (Harris' two-pass ratio test): row i is a tie if stepping to its ratio leaves no other row
// below −kRatioTieTolerance·max(1, ‖q‖∞). A purely ratio-relative tolerance is not enough:
// on a 10-box stack (tests/data/lcp/box_stack_cold_step425.lcp) ~200 rows, z0 among them,
// blocked at the same ratio 9.81e-3 up to a relative noise of 5e-8 (basic values carry errors
// of ~5e-11, and dividing by pivots of ~0.04 spreads the ratios by 1e-9 > 1e-10); z0 was not
// recognized as blocking, was left at 1e-11 instead of leaving the basis, and the next pivot
// ended on a spurious secondary ray.
constexpr double kRatioTieTolerance = 1e-10;
// Among tied rows, pivots smaller than this fraction of the largest tied pivot are not used
// (unless all are that small). In degenerate steps (ratio 0) the lexicographic rule otherwise
// happily picks a pivot that is pure noise: on a sliding-box LCP
// (tests/data/lcp/incline_sliding_step9744.lcp) it pivoted on d = 1.5e-12 (the M entries that
// are physically zero are ~1e-12 from the contact geometry) next to a tied pivot of 1, which
// scaled B⁻¹ by 1e12 and ended with a residual of 0.54. Skipping a tied row keeps the iterate
// feasible (its value stays within the tie tolerance of 0).
constexpr double kTiePivotFraction = 1e-7;
// Relative tolerance of the lexicographic comparisons of B⁻¹ rows among tied ratios.
constexpr double kLexTieTolerance = 1e-12;
// A secondary-ray iterate is accepted as a solution only if z0 fell below this fraction of its
// initial value (it was driven to 0 by the pivoting, not merely small because q is tiny) and
// the residual passes.
constexpr double kSecondaryRayZ0Fraction = 1e-6;
// Symmetric equilibration sweeps; the loop stops earlier once no scale factor changes.
constexpr int kScalingSweeps = 10;
// Iterative-refinement steps at termination (each O(n²) with the kept inverse), skipped once
// the residual is below kRefineBelow·max(1, ‖q‖∞) (roundoff level of the data).
constexpr int kRefinementSteps = 2;
constexpr double kRefineBelow = 1e-15;
// Cap of the ‖M‖∞‖z‖∞ term of the acceptance scale, relative to max(1, ‖q‖∞). Without a cap
// a huge z would make any residual pass: a regularized retry of an infeasible LCP
// (M = −I, q = −1, ε = 1e-10) returns ‖z‖ ≈ 1e10 with residual 2. The 10-box stack needs
// ‖M‖∞‖z‖∞ ≈ 6–12 next to max(1, ‖q‖∞) = 1.
constexpr double kMaxAcceptanceGrowth = 1e3;

constexpr double kInf = std::numeric_limits<double>::infinity();

// NaN sorts last: a NaN residual is worse than any number.
inline double OrInf(double v) { return std::isnan(v) ? kInf : v; }

// Throws std::invalid_argument for a negative or non-finite option (lemke.h).
void ValidateOptions(const LemkeOptions& o);

// −trunc(½·log2 m) for a finite m > 0 (the exponent of the power-of-two scale factor that
// brings m to about 1), without a call to log2 where the result cannot depend on its rounding.
int MinusTruncHalfLog2(double m);
// 2^k, exactly std::ldexp(1, k).
double PowerOfTwo(int k);

// The scale-aware acceptance test of lemke.h:
//   residual ≤ rtol·max(b, min(‖M‖∞‖z‖∞, kMaxAcceptanceGrowth·b)),   b = max(1, ‖q‖∞).
struct Acceptance {
  double rtol = 0.0;
  double q_norm = 0.0;  // ‖q‖∞
  double m_norm = 0.0;  // ‖M‖∞ = max_i Σ_j |M_ij| (the solver's scan of M)
  double For(const VectorXd& z) const {
    const double z_norm = z.size() > 0 ? z.lpNorm<Eigen::Infinity>() : 0.0;
    const double base = std::max(1.0, q_norm);
    return rtol * std::max(base, std::min(m_norm * z_norm, kMaxAcceptanceGrowth * base));
  }
};

// Dense Lemke's warm start (lemke.h): the guessed basis B = {i : warm_i > 0}, z_B from M_BB
// anchored at the guess, accepted iff z_B ≥ −τ, w_N ≥ −τ, the residual passes τ and the
// scale-aware check (lcp_acceptance.h) passes. `acceptance.m_norm` must be ‖M‖∞ of a finite M.
bool TryWarmStart(const LcpProblem& problem, const VectorXd& warm, const Acceptance& acceptance,
                  VectorXd* z, double* residual);

// Fischer–Burmeister Newton polish of a terminated Lemke iterate z_lemke that misses τ by
// roundoff, or (z_lemke null) Newton from z = 0 as the final fallback; true with *z if the
// result passes τ and the scale-aware check. *iterations: Newton steps; *note: FB's message.
bool PolishTerminalIterate(const LcpProblem& problem, const VectorXd* z_lemke,
                           const Acceptance& acceptance, VectorXd* z, int* iterations,
                           std::string* note);

// The ratio test of one Lemke pivot (Harris' two-pass test with ties, then the lexicographic
// rule), for the entering column d (basis coordinates) and the basic values x, with basis[i]
// the variable basic in row i and z0 the artificial variable's index. Returns the leaving row,
// or −1 if no row blocks (a secondary ray). binv_at(i, k) is entry (i, k) of B⁻¹; before the
// lexicographic rule reads column k, prepare(ties, k) is called with the rows still tied (a
// sparse basis computes the entries it will be asked for there; the dense one has them).
template <class BinvAt, class Prepare>
int ChooseLeavingRow(const VectorXd& x, const VectorXd& d, const std::vector<int>& basis, int z0,
                     double tau_x, const LemkeOptions& options, std::vector<int>* ties_out,
                     std::vector<int>* kept_out, BinvAt&& binv_at, Prepare&& prepare) {
  std::vector<int>& ties = *ties_out;
  std::vector<int>& kept = *kept_out;
  const int n = static_cast<int>(x.size());
  const double pivot_tol = options.pivot_tolerance * std::max(1.0, d.cwiseAbs().maxCoeff());
  // Harris' two-pass ratio test: theta is the minimum ratio, theta_max the largest step
  // that keeps every basic value ≥ −tau_x; rows whose ratio is ≤ theta_max are ties.
  double theta = kInf;
  double theta_max = kInf;
  for (int i = 0; i < n; ++i) {
    if (d(i) > pivot_tol) {
      const double xi = std::max(x(i), 0.0);
      theta = std::min(theta, xi / d(i));
      theta_max = std::min(theta_max, (xi + tau_x) / d(i));
    }
  }
  if (theta == kInf) return -1;
  const double tie_bound = std::max(theta_max, theta + kRatioTieTolerance * std::max(1.0, theta));
  ties.clear();
  int r = -1;
  double d_tied_max = 0.0;
  for (int i = 0; i < n; ++i) {
    if (d(i) > pivot_tol && std::max(x(i), 0.0) / d(i) <= tie_bound) {
      ties.push_back(i);
      d_tied_max = std::max(d_tied_max, d(i));
      if (basis[i] == z0) r = i;  // z0 blocks: leave now and terminate
    }
  }
  if (r >= 0) return r;
  if (ties.size() > 1) {
    // Stability: drop tied pivots that are negligible next to the largest tied one.
    kept.clear();
    for (int i : ties) {
      if (d(i) >= kTiePivotFraction * d_tied_max) kept.push_back(i);
    }
    ties.swap(kept);
  }
  if (options.lexicographic) {
    for (int k = 0; k < n && ties.size() > 1; ++k) {
      prepare(ties, k);
      double m = kInf;
      for (int i : ties) m = std::min(m, binv_at(i, k) / d(i));
      const double tau_k = kLexTieTolerance * std::max(1.0, std::abs(m));
      kept.clear();
      for (int i : ties) {
        if (binv_at(i, k) / d(i) <= m + tau_k) kept.push_back(i);
      }
      ties.swap(kept);
    }
    return ties.front();
  }
  r = ties.front();  // largest pivot among the ties, for stability
  for (int i : ties) {
    if (d(i) > d(r)) r = i;
  }
  return r;
}

}  // namespace vinci::sim::internal::lemke
