// Least squares over a growing horizon (LeastSquaresOptions::horizon_samples): each fit starts
// from the last kept one's θ, after a line search of θ, and its initial states.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>
#include <vector>

#include "estimation_internal.h"
#include "least_squares_internal.h"
#include "vinci/estimation/least_squares.h"

namespace vinci::estimation::internal {

using sim::Params;
using sim::State;
using sim::VectorXd;

namespace {

// The log with every episode cut to its first `samples` samples.
Log FirstSamples(const Log& log, int samples) {
  Log part = log;
  for (Episode& ep : part.episodes)
    if (ep.num_samples() > samples) ep = Slice(ep, 0, samples - 1);
  return part;
}

// Before a horizon's fit: a geometric line search of each positive parameter in turn over
// θ_k × 2^{±1/2}, 2^{±1} (within its bounds), repeated from the best while that is an end
// point (up to 2^{±8}), then refined about the best by halving steps down to 2^{±1/64}, at the
// initial states `states` (the last fit's), by the rollouts' sum of squared residuals over
// `log`; θ_k moves to the cheapest. Levenberg–Marquardt from the
// last fit's θ follows the local slope, and when a new impact enters the horizon that slope
// can lead away from the data (measured on tossed cubes: to μ = 6 and 774 for 0.4).
void ScanParameters(const sim::Simulator& simulator, const sim::ParamSelection& sel, const Log& log,
                    const std::vector<VectorXd>& states, double orientation_length,
                    VectorXd* theta) {
  const Params base = simulator.DefaultParams();
  std::vector<State> x0;
  for (size_t e = 0; e < log.episodes.size(); ++e) {
    VectorXd se;
    const State ref = GuessInitialState(simulator, log.episodes[e], &se);
    x0.push_back(StateFromVector(simulator, log.episodes[e], ref, states[e].data()));
  }
  auto cost = [&](const VectorXd& th) {
    const Params p = sel.Set(base, th);
    double c = 0.0;
    for (size_t e = 0; e < log.episodes.size(); ++e) {
      VectorXd r;
      std::string failure;
      if (!EpisodeResiduals(simulator, p, log.episodes[e], x0[e], orientation_length, &r, &failure))
        return std::numeric_limits<double>::infinity();
      c += r.squaredNorm();
    }
    return c;
  };
  double best = cost(*theta);
  // θ_k of `center` scaled by f, within its bounds: taken (true) if cheaper than the best.
  auto improves = [&](const VectorXd& center, Eigen::Index k, double f) {
    VectorXd th = center;
    th[k] *= f;
    if (th[k] < sel.lower()[k] || th[k] > sel.upper()[k]) return false;
    const double c = cost(th);
    if (!(c < best)) return false;
    best = c;
    *theta = th;
    return true;
  };
  for (Eigen::Index k = 0; k < theta->size(); ++k) {
    if (!((*theta)[k] > 0)) continue;
    for (int pass = 0; pass < 8; ++pass) {
      const VectorXd center = *theta;
      double moved = 1.0;
      for (const double f : {0.5, M_SQRT1_2, M_SQRT2, 2.0})
        if (improves(center, k, f)) moved = f;
      if (moved != 0.5 && moved != 2.0) break;
    }
    // Then finer, about the best: θ_k × 2^{±1/4}, 2^{±1/8}, …, 2^{±1/64} (at an impact the cost
    // can be sharp in μ: measured on a tossed cube, σ̂ 0.9 mm at μ = 0.424 and 35 µm at 0.4 from
    // the same initial state).
    for (const double step : {0.25, 0.125, 0.0625, 0.03125, 0.015625}) {
      const VectorXd center = *theta;
      for (const double f : {std::exp2(-step), std::exp2(step)}) improves(center, k, f);
    }
  }
}

}  // namespace

EstimateResult FitGrowingHorizon(const sim::Simulator& simulator, const Log& log,
                                 const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                                 std::vector<VectorXd>* final_states, const VectorXd* held_theta) {
  // Growing horizon: H, ⌈g H⌉, … samples per episode, then the whole log; each fit starts
  // from the last one's θ and initial states.
  int longest = 0;
  for (const Episode& ep : log.episodes) longest = std::max(longest, ep.num_samples());
  // Horizons with fewer residuals than unknowns are skipped.
  auto enough = [&](int h) {
    try {
      CheckEnoughSamplesForFit(simulator, FirstSamples(log, h), options, sel.size());
    } catch (const std::invalid_argument&) {
      return false;
    }
    return true;
  };
  std::vector<int> horizons;
  for (double h = options.horizon_samples; h < longest;
       h = std::max(h + 1, std::ceil(h * options.horizon_growth)))
    if (enough(static_cast<int>(h))) horizons.push_back(static_cast<int>(h));
  horizons.push_back(longest);

  LeastSquaresOptions o = options;
  int done = 0;  // iterations of the earlier fits, so that progress counts on
  if (options.progress)
    o.progress = [&done, &options](int it, double cost, const VectorXd& p) {
      options.progress(done + it, cost, p);
    };
  // The last kept fit's θ (first: the scene's, or the held one).
  VectorXd theta = held_theta ? *held_theta : sel.Get(simulator.DefaultParams());
  std::vector<int> held;
  if (held_theta)
    for (int i = 0; i < sel.size(); ++i) held.push_back(i);
  std::vector<VectorXd> from;  // and its initial states (empty: guessed from the log)
  int kept = 0;                // its samples per episode (0: none yet)
  // One log (horizon_refinement): a fit whose residuals contradict the stated noise
  // (EpisodeContradictsNoise) where the kept fit's agreed, over a step of ≥ 2 samples, is
  // discarded (θ back to the kept fit's) and the halfway horizon fitted first. Not with several:
  // measured on 50 tossed cubes, continuing such an episode alone from its kept fit (its state
  // replacing the joint fit's) did not last into the next joint fit, and μ̂ ended further from
  // the truth (docs/estimation.md); several episodes are restarted after the whole log's fit
  // instead (LeastSquaresOptions::episode_restarts, least_squares_restart.cc).
  const bool refine = options.horizon_refinement && log.episodes.size() == 1;
  bool agreed = false;  // the kept fit's residuals agreed with the stated noise
  std::vector<int> fitted;
  std::vector<int> pending(horizons.rbegin(), horizons.rend());  // the next at the back
  for (;;) {
    const int h = pending.back();
    const bool last = pending.size() == 1;
    const Log part = FirstSamples(log, h);  // the whole log for the last
    std::vector<VectorXd> states = from;
    const VectorXd before = theta;
    if (!from.empty() && !held_theta)
      ScanParameters(simulator, sel, part, from, options.orientation_length, &theta);
    EstimateResult fit = Fit(simulator, part, o, theta, &states, held);
    done += fit.iterations;
    fitted.push_back(h);
    const bool agrees = !refine || !EpisodeContradictsNoise(fit.episodes[0], options.noise_sigma);
    const bool lost = agreed && !agrees && kept > 0 && h - kept >= 2;
    if (options.horizon_progress && (!last || lost)) {
      try {
        options.horizon_progress(h, fit, lost ? std::vector<int>{0} : std::vector<int>{});
      } catch (...) {
        // progress reporting must not end the solve
      }
    }
    if (lost) {
      theta = before;
      pending.push_back(kept + (h - kept) / 2);
      continue;
    }
    if (last) {
      fit.iterations = done;
      fit.horizons = std::move(fitted);
      *final_states = std::move(states);
      return fit;
    }
    // A failed fit (a rollout that failed: σ̂ NaN with residuals to spare) does not carry over:
    // the next starts from the last finite one.
    const bool failed = !fit.estimates.allFinite() || (fit.num_residuals > fit.num_unknowns &&
                                                       !std::isfinite(fit.sigma_residual));
    if (!failed) {
      // A parameter this horizon does not determine (standard error ≥ its magnitude, or none)
      // keeps its value from before the scan and the fit: over a flat direction
      // Levenberg–Marquardt's scaled step can carry it anywhere (measured: a box on a vibrating
      // plate, μ 0.5 → 3.2 over its first 10 samples with σ̂ at the noise, then stuck at 6.5
      // and 9.1), and so can the scan's noise-level gains (a tossed cube's first impact sticks,
      // where any μ above the threshold fits alike: the scan took μ from 0.6 to 1.7, where the
      // next impact slips at 0.4 and no step of the next scan was cheaper, 0.85 sticking too).
      if (!held_theta)
        for (Eigen::Index k = 0; k < theta.size(); ++k)
          theta[k] = fit.std_errors[k] < std::abs(fit.estimates[k]) ? fit.estimates[k] : before[k];
      from = std::move(states);
      kept = h;
      agreed = agrees;
    }
    pending.pop_back();
  }
}

}  // namespace vinci::estimation::internal
