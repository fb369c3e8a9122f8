// Episodes restarted from their own fits (LeastSquaresOptions::episode_restarts): a joint fit
// of several episodes can hold one episode's initial state in a local minimum that the shared θ
// keeps it in; that episode fitted alone finds its own basin.
#include <sstream>
#include <utility>
#include <vector>

#include "estimation_internal.h"
#include "least_squares_internal.h"
#include "vinci/estimation/least_squares.h"

namespace vinci::estimation::internal {

using sim::VectorXd;

void RestartStrayEpisodes(const sim::Simulator& simulator, const Log& log,
                          const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                          std::vector<VectorXd>* states, EstimateResult* r) {
  const int num_episodes = static_cast<int>(log.episodes.size());
  if (!options.episode_restarts || num_episodes < 2 || !(options.noise_sigma > 0) ||
      options.shooting != Shooting::kSingle || !options.estimate_initial_state ||
      !r->estimates.allFinite() || static_cast<int>(states->size()) != num_episodes ||
      static_cast<int>(r->episodes.size()) != num_episodes)
    return;
  LeastSquaresOptions alone = options;
  alone.horizon_progress = nullptr;  // the horizons of the joint fit only
  std::vector<int> held(sel.size());
  for (int i = 0; i < sel.size(); ++i) held[i] = i;
  std::vector<VectorXd> tried = *states;
  std::vector<int> replaced;
  int iterations = 0;
  for (int e = 0; e < num_episodes; ++e) {
    if (!EpisodeContradictsNoise(r->episodes[e], options.noise_sigma)) continue;
    Log one;
    one.episodes = {log.episodes[e]};
    // Alone, θ free (the options' horizon), then θ held at the joint θ̂ from there: the episode's
    // own basin, moved to the shared θ. The better of that and the next candidate is kept.
    double best = r->episodes[e].rms_residual;
    const auto consider = [&](const EstimateResult& at, std::vector<VectorXd>& state) {
      iterations += at.iterations;
      if (state.size() != 1 || at.episodes.size() != 1 || !(at.episodes[0].rms_residual < best))
        return;
      best = at.episodes[0].rms_residual;
      tried[e] = state[0];
    };
    std::vector<VectorXd> own;
    const EstimateResult fit = options.horizon_samples == 0
                                   ? Fit(simulator, one, alone, VectorXd(), &own)
                                   : FitGrowingHorizon(simulator, one, alone, sel, &own);
    iterations += fit.iterations;
    if (own.size() == 1 && fit.estimates.allFinite())
      consider(Fit(simulator, one, alone, r->estimates, &own, held), own);
    // And the episode's states alone at the joint θ̂ from the log's guess, the horizon growing
    // with θ held there: an episode whose own θ̂ is far from the joint one can settle in another
    // basin of its state when moved to it.
    if (options.horizon_samples > 0) {
      std::vector<VectorXd> at_joint;
      consider(FitGrowingHorizon(simulator, one, alone, sel, &at_joint, &r->estimates), at_joint);
    }
    if (best < r->episodes[e].rms_residual) replaced.push_back(e);
  }
  if (replaced.empty()) return;
  EstimateResult again = Fit(simulator, log, options, r->estimates, &tried);
  std::ostringstream m;
  m << "; episodes";
  for (int e : replaced) m << " " << e;
  m << " started again from their own fits (" << (again.final_cost < r->final_cost ? "" : "not ")
    << "kept: σ̂ " << r->sigma_residual << " → " << again.sigma_residual << " m)";
  if (again.final_cost < r->final_cost) {
    again.iterations += r->iterations + iterations;
    again.initial_values = r->initial_values;
    again.initial_cost = r->initial_cost;
    again.horizons = r->horizons;
    *r = std::move(again);
    *states = std::move(tried);
  } else {
    r->iterations += iterations + again.iterations;
  }
  r->reason += m.str();
}

}  // namespace vinci::estimation::internal
