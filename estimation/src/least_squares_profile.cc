// Least squares' profile standard errors (LeastSquaresStdErrors::kProfile).
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "least_squares_internal.h"
#include "vinci/estimation/least_squares.h"

namespace vinci::estimation::internal {

using sim::VectorXd;

// LeastSquaresStdErrors::kProfile: for each parameter θ_k, the cost with θ_k held at
// θ̂_k ± d (the other parameters and the initial states fitted again from the solution's,
// `states`) for d = s, 2 s, 4 s, … (s: the linearized standard error, else 1e-3 |θ̂_k|), on each
// side until Δχ² = 2 (cost − cost at θ̂) / σ² reaches 9 or a bound; the crossing interpolated
// linearly in √Δχ². θ_k's standard error: the wider side's distance / 3. A profile point cheaper
// than the solution by more than Δχ² = 0.01 is said in the reason, and by more than 1 makes it
// not converged (the fit stopped in a local minimum).
void ProfileStdErrors(const sim::Simulator& simulator, const Log& log,
                      const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                      const std::vector<VectorXd>& states, EstimateResult* r) {
  const Eigen::Index np = r->estimates.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  r->std_error_method = "profile";
  r->linearized_std_errors = r->std_errors;
  r->profile_low = VectorXd::Constant(np, nan);
  r->profile_high = VectorXd::Constant(np, nan);
  r->std_errors = VectorXd::Constant(np, nan);
  if (!r->estimates.allFinite() || !(r->sigma > 0) || !std::isfinite(r->final_cost) ||
      static_cast<int>(states.size()) != static_cast<int>(log.episodes.size())) {
    r->reason += "; no profile standard errors (no usable solution)";
    return;
  }
  LeastSquaresOptions po = options;
  po.progress = nullptr;
  const double scale = 2.0 / (r->sigma * r->sigma);  // Δχ² per unit of cost
  double cheapest = r->final_cost;
  VectorXd cheapest_theta;
  for (Eigen::Index k = 0; k < np; ++k) {
    const double center = r->estimates[k];
    const double lin = r->linearized_std_errors[k];
    const double step =
        std::isfinite(lin) && lin > 0 ? lin : 1e-3 * std::max(std::abs(center), 1e-3);
    double width[2] = {nan, nan};
    for (int side = 0; side < 2; ++side) {
      const double sign = side == 0 ? -1.0 : 1.0;
      const double bound = side == 0 ? sel.lower()[k] : sel.upper()[k];
      double prev_d = 0.0, prev_q = 0.0;
      for (int m = 0; m < 10; ++m) {
        double d = step * std::exp2(m);
        const bool at_bound = sign * (center + sign * d - bound) >= 0;
        if (at_bound) d = std::abs(bound - center);
        if (!(d > prev_d)) break;
        VectorXd theta = r->estimates;
        theta[k] = center + sign * d;
        std::vector<VectorXd> st = states;
        const EstimateResult f = Fit(simulator, log, po, theta, &st, {static_cast<int>(k)});
        r->iterations += f.iterations;
        // A failed fit (Ceres reports a cost of −1 when it cannot start, e.g. a rollout that
        // fails at a mass near its bound 0) ends this side without a crossing.
        if (!(f.final_cost >= 0) || !std::isfinite(f.final_cost) || !f.estimates.allFinite() ||
            !std::isfinite(f.sigma_residual))
          break;
        if (f.final_cost < cheapest) {
          cheapest = f.final_cost;
          cheapest_theta = f.estimates;
        }
        const double q = std::sqrt(std::max(0.0, scale * (f.final_cost - r->final_cost)));
        if (q >= 3.0) {
          width[side] = prev_d + (d - prev_d) * (3.0 - prev_q) / (q - prev_q);
          break;
        }
        if (at_bound) break;
        prev_d = d;
        prev_q = q;
      }
    }
    r->profile_low[k] = center - width[0];
    r->profile_high[k] = center + width[1];
    r->std_errors[k] = std::max(width[0], width[1]) / 3.0;  // NaN if a side is
  }
  const double gain = scale * (r->final_cost - cheapest);
  if (cheapest_theta.size() > 0 && gain > 0.01) {
    // Below Δχ² = 1 the kinks' shallow local minima (measured on a plate's box: 0.2) do not
    // move the interval; beyond it the fit is not at the cost's minimum.
    std::ostringstream m;
    m << "; the profile found a lower cost (Δχ² " << gain << ") at";
    for (Eigen::Index i = 0; i < np; ++i) m << " " << r->names[i] << " " << cheapest_theta[i];
    m << (gain > 1.0 ? ": the fit stopped in a local minimum" : "");
    r->reason += m.str();
    if (gain > 1.0) r->converged = false;
  }
}

}  // namespace vinci::estimation::internal
