// The MPEC estimator decomposed by episode: a profile over the shared θ, per-episode NLPs at
// fixed θ, Newton steps from the envelope gradients and the episodes' reduced Hessians
// (mpec_decomposed.h).
#include "vinci/estimation/mpec_decomposed.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mpec_episodes.h"
#include "mpec_outer.h"
#include "mpec_problem.h"
#include "vinci/parallel/fork.h"
#include "vinci/parallel/wire.h"

namespace vinci::estimation {

using sim::MatrixXd;
using sim::VectorXd;

using mpec_internal::EnvelopeGradient;
using mpec_internal::EpisodeFit;
using mpec_internal::EpisodeJob;
using mpec_internal::EpisodeRun;
using mpec_internal::FixedThetaProblem;
using mpec_internal::ForEachEpisode;
using mpec_internal::Progress;

namespace {

// Outer (θ) iterations at most, and step halvings per iteration.
constexpr int kMaxOuterIterations = 30;
constexpr int kMaxHalvings = 6;
// Converged when the Newton decrement ½ ∇Fᵀ H⁻¹ ∇F is below this (χ² units; the decrement is
// ½ (Δθ / s.e.)²: 1e-8 is a step of ~1e-4 standard errors) or the step below
// kStepTolerance (1 + |θ|).
constexpr double kDecrementTolerance = 1e-8;
// The tolerance when some episode's solution is a relaxed iterate: its f_e and ∂f_e/∂θ are
// known only to the relaxation's precision (measured on two tossed-cube episodes, one relaxed:
// the gradient at the optimum jumped between −2.6 and +0.24 χ²/unit from one outer iteration
// to the next, i.e. decrements of ~1e-8 … 5e-6, and three of five outer iterations were spent
// there). 1e-6 is a step of ~1.4e-3 standard errors.
constexpr double kRelaxedDecrementTolerance = 1e-6;
constexpr double kStepTolerance = 1e-9;
// Below this decrement a full Newton step is taken without asking F to decrease: F is known
// only to the episodes' solver tolerances (an episode's homotopy may end at an early polish
// accepted within 1e-3 + 2 ε Σ λ_k of its relaxed value, EstimatorSolverDefaults), so near the
// optimum its changes are noise.
constexpr double kNoiseDecrement = 1e-2;
// MpecSolverOptions::early_polish_max_iterations of the episodes' NLPs (unless set).
constexpr int kEarlyPolishIterations = 200;
// MpecSolverOptions::continued_max_iterations of the episodes' NLPs (unless set): 95 % of the
// continued stages on 50 tossed cubes ended within 490 iterations.
constexpr int kContinuedIterations = 500;
// A relaxed episode's warm-started tail that ends above the complementarity tolerance, at an
// iterate of a solved stage within this factor of it, is kept without the homotopy from the
// start (until the outer loop converges, when such an episode is solved again in full).
constexpr double kLooseTailFactor = 10.0;

// The covariance C of θ at an episode's solution `sol` (θ free or fixed): the Laplace
// approximation of a polished NLP, or for a relaxed iterate (at which holding every pair's
// smaller side can pin θ) the profile's, computed once (EpisodeFit::profile_covariance).
// false if there is none.
bool EpisodeCovariance(EpisodeFit* fit, const MpecSolution& sol, const MpecSolverOptions& so,
                       int* iterations, int* stages, MatrixXd* cov) {
  if (sol.polished || sol.relaxed.lambda.size() == 0) {
    return fit->problem->ParameterCovariance(
        sol.x, fit->problem->ClassifyPairs(sol.x, mpec_internal::kBiactive), cov);
  }
  if (fit->profile_covariance.size() == 0) {
    std::string why;
    if (!mpec_internal::ProfileCovariance(*fit->problem, sol, so, &fit->profile_covariance,
                                          iterations, stages, &why))
      fit->reason += "; no profile standard errors: " + why;
  }
  *cov = fit->profile_covariance;
  return cov->diagonal().array().isFinite().any();
}

// fit's covariance C of its nt parameters at its solution `sol` (EpisodeCovariance) into
// fit->covariance, and its curvature 2 C⁻¹ into fit->hessian (θ held at a bound: NaN rows of C,
// curvature 0); NaN and 0, and false, if there is none.
bool UpdateCurvature(EpisodeFit* fit, int nt, const MpecSolution& sol, const MpecSolverOptions& so,
                     int* iterations, int* stages) {
  fit->covariance = MatrixXd::Constant(nt, nt, std::nan(""));
  fit->hessian = MatrixXd::Zero(nt, nt);
  MatrixXd cov;
  if (!EpisodeCovariance(fit, sol, so, iterations, stages, &cov)) return false;
  fit->covariance = cov;
  std::vector<int> free;
  for (int i = 0; i < nt; ++i)
    if (std::isfinite(cov(i, i))) free.push_back(i);
  MatrixXd c(free.size(), free.size());
  for (std::size_t i = 0; i < free.size(); ++i)
    for (std::size_t j = 0; j < free.size(); ++j) c(i, j) = cov(free[i], free[j]);
  Eigen::LDLT<MatrixXd> ldlt(c);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive()) {
    const MatrixXd inv = ldlt.solve(MatrixXd::Identity(c.rows(), c.cols()));
    for (std::size_t i = 0; i < free.size(); ++i)
      for (std::size_t j = 0; j < free.size(); ++j) fit->hessian(free[i], free[j]) = 2 * inv(i, j);
  }
  return true;
}

// Whether a's solution is preferred to b's: converged before not, a solved NLP's iterate (an
// NLP failing mid-homotopy keeps its last solved stage's) before not, then the smaller
// complementarity violation; a non-finite iterate last.
bool Preferred(const MpecSolution& a, const MpecSolution& b) {
  const bool fa = a.x.size() > 0 && a.x.allFinite(), fb = b.x.size() > 0 && b.x.allFinite();
  if (fa != fb) return fa;
  if (a.converged != b.converged) return a.converged;
  if (a.iterate_solved != b.iterate_solved) return a.iterate_solved;
  return a.complementarity_violation < b.complementarity_violation;
}

// Solves episode `fit` at θ from `start` (its previous solution, or its guess); fills f,
// gradient and, with `curvature`, the curvature at the new solution (UpdateCurvature; without,
// a polished solution keeps the curvature fit had — a relaxed one's is its profile's, computed
// once, so it is always updated). When the warm start fails, the homotopy from the previous
// solution; of the two the preferred (Preferred) is kept, usable when it is a solved
// relaxation's iterate. Returns the NLP's iterations and stages through the pointers.
// `keep_loose_tail`: a relaxed episode's tail that ends usable within kLooseTailFactor × the
// complementarity tolerance is the result (no homotopy from the start after it).
EpisodeFit SolveEpisode(EpisodeFit&& fit, const VectorXd& theta, const MpecSolverOptions& so,
                        bool curvature, bool keep_loose_tail, int* iterations, int* stages) {
  const int nt = static_cast<int>(theta.size());
  MpecSolution sol;
  bool done = false;
  if (fit.x.size() > 0 && fit.relaxed.lambda.size() > 0) {
    // From a relaxed iterate at a nearby θ (its polish had failed, so would the kept active
    // set's NLP): the homotopy's tail from ε = max(its ε, 1e-8), warm-started with its
    // multipliers, and its continuation below epsilon_end, without the polish (measured on the
    // hard cube toss: it stalled again at every θ, 100 of the tail's ~350 iterations).
    MpecSolverOptions tail = so;
    tail.epsilon_start = tail.epsilon_end =
        std::max(fit.final_epsilon, mpec_internal::kProfileEpsilon);
    tail.early_polish_tolerance = -1.0;
    tail.polish = false;
    const FixedThetaProblem fixed(*fit.problem, theta, fit.x);
    sol = SolveMpec(fixed, tail, &fit.relaxed);
    *iterations += sol.iterations;
    *stages += sol.stages;
    done = sol.converged && sol.x.allFinite();
    // (Measured on 50 tossed cubes: the homotopy from the start after a failed tail cost
    // ~3 000 Ipopt iterations; the episodes kept above the tolerance were at 2e-6 … 7e-6.)
    if (keep_loose_tail && !done && sol.iterate_solved && sol.x.allFinite() &&
        sol.complementarity_violation <= kLooseTailFactor * so.complementarity_tolerance)
      done = true;
  } else if (fit.x.size() > 0) {
    // From a solution at a nearby θ: its active set's NLP first (one smooth NLP, no homotopy);
    // the homotopy only if that fails.
    const FixedThetaProblem kept(*fit.problem, theta, fit.x, true);
    sol = SolveMpec(kept, so);
    *iterations += sol.iterations;
    *stages += sol.stages;
    done = sol.converged && sol.x.allFinite();
    if (done) sol.reason = "polished (active set kept): " + sol.reason;
    // The kept active set's NLP has no relaxation: its failed iterate is not one.
    if (!done) sol = MpecSolution();
  }
  if (!done) {
    const VectorXd start = fit.x.size() > 0 ? fit.x : fit.problem->StartingPoint();
    const FixedThetaProblem fixed(*fit.problem, theta, start);
    MpecSolution again = SolveMpec(fixed, so);
    *iterations += again.iterations;
    *stages += again.stages;
    if (Preferred(again, sol) || !(sol.x.size() > 0)) sol = std::move(again);
  }
  fit.converged = sol.converged && sol.x.allFinite();
  fit.usable = false;
  fit.reason = sol.reason;
  if (!sol.x.allFinite()) return std::move(fit);
  fit.x = sol.x;
  fit.violation = sol.complementarity_violation;
  fit.final_epsilon = sol.final_epsilon;
  fit.relaxed = sol.relaxed;
  fit.problem->Objective(sol.x, &fit.f);
  fit.gradient = EnvelopeGradient(*fit.problem, nt, sol.x, sol.lambda);
  const bool polished = sol.polished || sol.relaxed.lambda.size() == 0;
  if (curvature || !polished || fit.hessian.rows() != nt)
    UpdateCurvature(&fit, nt, sol, so, iterations, stages);
  if (!fit.gradient.allFinite()) fit.converged = false;
  fit.usable = fit.gradient.allFinite() && (fit.converged || sol.iterate_solved);
  return std::move(fit);
}

}  // namespace

MatrixXd mpec_internal::SecantCorrected(const MatrixXd& h, const VectorXd& s, const VectorXd& y,
                                        double* ratio) {
  const VectorXd hs = h * s;
  const double shs = s.dot(hs), sy = s.dot(y);
  const double r = shs > 0 ? sy / shs : std::nan("");
  if (ratio) *ratio = r;
  if (!(sy > 0) || !(r >= 0.1 && r <= 10.0)) return h;
  return h - hs * hs.transpose() / shs + y * y.transpose() / sy;
}

MatrixXd mpec_internal::EpisodeJackknifeCovariance(const std::vector<MatrixXd>& hessians,
                                                   const std::vector<VectorXd>& gradients) {
  const int n = static_cast<int>(gradients.size());
  if (n < 2 || static_cast<int>(hessians.size()) != n) return MatrixXd();
  const Eigen::Index p = gradients[0].size();
  MatrixXd h = MatrixXd::Zero(p, p);
  for (const MatrixXd& he : hessians) {
    if (he.rows() != p || he.cols() != p) return MatrixXd();
    h += he;
  }
  std::vector<VectorXd> d(n);
  VectorXd mean = VectorXd::Zero(p);
  for (int e = 0; e < n; ++e) {
    if (gradients[e].size() != p) return MatrixXd();
    Eigen::LDLT<MatrixXd> ldlt(h - hessians[e]);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return MatrixXd();
    d[e] = ldlt.solve(gradients[e]);
    mean += d[e] / n;
  }
  MatrixXd c = MatrixXd::Zero(p, p);
  for (const VectorXd& de : d) c += (de - mean) * (de - mean).transpose();
  return (static_cast<double>(n - 1) / n) * c;
}

bool mpec_internal::PreferRestart(const EpisodeOutcome& restart, const EpisodeOutcome& warm) {
  if (restart.usable != warm.usable) return restart.usable;
  if (!restart.usable) return false;
  if (restart.f < warm.f - kRestartObjectiveGap * std::max(1.0, std::abs(warm.f))) return true;
  if (warm.f < restart.f - kRestartObjectiveGap * std::max(1.0, std::abs(restart.f))) return false;
  if (restart.converged != warm.converged) return restart.converged;
  return restart.f < warm.f;
}

const char* ToString(MpecEpisodes episodes) {
  return episodes == MpecEpisodes::kJoint ? "joint" : "decomposed";
}

MpecEpisodes ParseMpecEpisodes(const std::string& name) {
  if (name == "joint") return MpecEpisodes::kJoint;
  if (name == "decomposed") return MpecEpisodes::kDecomposed;
  throw std::invalid_argument("mpec episodes '" + name + "': expected joint or decomposed");
}

MpecEstimateResult EstimateMpecDecomposed(const sim::Simulator& simulator, const Log& log,
                                          const MpecOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Validate();
  if (log.episodes.empty()) throw std::invalid_argument("no log episode");
  const bool stated = options.noise_sigma > 0;
  const double sigma_w = stated ? options.noise_sigma : mpec_internal::kDefaultSigma;
  const int ne = static_cast<int>(log.episodes.size());
  const int nt = static_cast<int>(options.params.size());
  auto say = [&](const std::string& line) {
    if (options.progress) options.progress(line);
  };

  std::vector<EpisodeFit> fits(ne);
  MpecEstimateResult r;
  r.method = "mpec";
  r.names = options.params;
  r.complementarity = ToString(options.solver.method);
  // `threads` worker processes solve the episodes, each evaluating its steps on the rest.
  const int workers = std::min(options.threads, ne);
  MpecOptions per_episode = options;
  per_episode.threads = std::max(1, options.threads / workers);
  for (int e = 0; e < ne; ++e) {
    Log one;
    one.episodes.push_back(log.episodes[e]);
    fits[e].problem = std::make_unique<MpecEstimationProblem>(simulator, one, per_episode, sigma_w);
    const MpecEstimationProblem& p = *fits[e].problem;
    r.num_constraints += p.num_constraints();
    r.num_pairs += static_cast<int>(p.ComplementarityPairs().size());
    r.num_steps += p.num_steps();
    r.num_unknowns += p.num_variables() - (e > 0 ? nt : 0);
    r.num_residuals += p.num_residuals();
    r.initial_cost += 0.5 * p.SquaredResiduals(p.StartingPoint());
    r.process_noise = p.process_noise();
  }
  VectorXd x_l, x_u, g_l, g_u;
  fits[0].problem->Bounds(&x_l, &x_u, &g_l, &g_u);
  const VectorXd lo = x_l.head(nt), hi = x_u.head(nt);
  VectorXd theta = fits[0].problem->StartingPoint().head(nt).cwiseMax(lo).cwiseMin(hi);
  r.initial_values = fits[0].problem->Parameters(fits[0].problem->StartingPoint());
  {
    std::ostringstream s;
    s << "mpec decomposed: " << ne << " episodes, " << r.num_steps << " steps, " << r.num_unknowns
      << " unknowns, " << r.num_pairs << " complementarity pairs (" << r.complementarity << ")";
    if (workers > 1) s << ", " << workers << " worker processes";
    say(s.str());
  }
  MpecSolverOptions so = options.solver;
  // Each NLP's summary line (as EstimateMpec's), unless a solver callback was given.
  if (!so.progress) so.progress = options.progress;
  if (!stated) so.early_polish_tolerance = -1.0;  // the objective's scale is unknown
  // A failing early-polish attempt ends after 200 iterations (measured on the study's tossed
  // cube: > 2 100 creeping iterations in the 2-toss joint NLP, > 500 s of CPU on its second toss
  // alone); the joint path keeps 0 (no cap).
  if (so.early_polish_max_iterations == 0) so.early_polish_max_iterations = kEarlyPolishIterations;
  if (so.continued_max_iterations == 0) so.continued_max_iterations = kContinuedIterations;

  // Solves every episode at θ from `base`; false if one failed (no usable solution). An
  // episode that ends usable but above the complementarity tolerance is counted in *loose (its
  // relaxed iterate's f_e and gradient enter the model: the outer loop goes on, measured on a
  // tossed cube that ended at 5e-6 > 1e-6 away from its own θ̂_e). Episodes marked in
  // `restart` are also solved by the homotopy from their guess at θ, the one PreferRestart
  // prefers kept (a poorly fitting episode's own solution may be a wrong local one that the
  // warm starts would carry along). The curvatures H_e of polished episodes are those of their last
  // UpdateCurvature (the start's, at θ̂_e, until the final pass below): the Laplace covariance
  // (a solve with the episode's KKT matrix) cost about as much as a warm-started episode NLP
  // on the tossed cube while it was a GMRES solve, and the model's curvature is corrected
  // along each step by its secant anyway.
  // `only` (if not empty): the episodes solved; the others keep their solutions. `keep_loose`:
  // SolveEpisode's keep_loose_tail.
  auto evaluate = [&](const VectorXd& th, std::vector<EpisodeFit>* base, double* F, VectorXd* G,
                      MatrixXd* H, std::string* failure, std::vector<int>* loose,
                      const std::vector<bool>& restart = {}, bool keep_loose = true,
                      const std::vector<bool>& only = {}) {
    *F = 0.0;
    G->setZero(nt);
    H->setZero(nt, nt);
    loose->clear();
    bool ok = true;
    std::vector<EpisodeRun> runs;
    ForEachEpisode(
        base, workers, so, say,
        [&th, &restart, keep_loose, &only](int e, EpisodeFit* fit, EpisodeRun* run,
                                           const MpecSolverOptions& o, const Progress& out) {
          if (!only.empty() && !only[static_cast<std::size_t>(e)]) return;
          *fit = SolveEpisode(std::move(*fit), th, o, false, keep_loose, &run->iterations,
                              &run->stages);
          if (restart.empty() || !restart[static_cast<std::size_t>(e)]) return;
          EpisodeFit guess;
          guess.problem = std::move(fit->problem);
          guess = SolveEpisode(std::move(guess), th, o, true, keep_loose, &run->iterations,
                               &run->stages);
          const bool better = mpec_internal::PreferRestart({guess.usable, guess.converged, guess.f},
                                                           {fit->usable, fit->converged, fit->f});
          std::ostringstream s;
          s << "mpec decomposed: episode " << e << " also solved from its guess: objective "
            << (guess.usable ? std::to_string(guess.f) : "none (" + guess.reason + ")")
            << " against " << (fit->usable ? std::to_string(fit->f) : "none") << " warm-started, "
            << (better ? "the guess's" : "the warm start's") << " kept";
          out(s.str());
          if (better) {
            *fit = std::move(guess);
          } else {
            fit->problem = std::move(guess.problem);
          }
        },
        &runs);
    for (int e = 0; e < ne; ++e) {
      const EpisodeFit& fit = (*base)[e];
      r.iterations += runs[e].iterations;
      r.stages += runs[e].stages;
      if (!fit.converged && fit.usable) {
        loose->push_back(e);
        std::ostringstream s;
        s << "mpec decomposed: episode " << e << " above the complementarity tolerance here ("
          << fit.violation << "), its relaxed iterate kept: " << fit.reason;
        say(s.str());
      } else if (!fit.converged) {
        ok = false;
        if (failure->empty()) *failure = log.episodes[e].file + ": " + fit.reason;
      }
      *F += fit.f;
      if (fit.gradient.size() == nt) *G += fit.gradient;
      if (fit.hessian.rows() == nt) *H += fit.hessian;
    }
    return ok;
  };
  auto describe = [&](int k, const VectorXd& th, double F, const VectorXd& G) {
    std::ostringstream s;
    s << "mpec decomposed " << k << ": theta";
    for (int i = 0; i < nt; ++i) s << " " << th[i];
    s << ", objective " << F << ", gradient";
    for (int i = 0; i < nt; ++i) s << " " << G[i];
    s << ", " << r.iterations << " Ipopt iterations so far";
    say(s.str());
  };

  // Start: every episode's own MPEC with θ free (from its measured-pose guess), θ_0 their
  // information-weighted mean (Σ C_e⁻¹)⁻¹ Σ C_e⁻¹ θ̂_e — near the optimum when the episodes
  // agree — and the profile's first solutions warm-started from theirs. (Starting the profile
  // at the scene's θ instead carried the active sets of a far θ along the warm starts: on
  // noise-free block logs it ended at μ̂ − μ = −4e-6 with χ² = 0.14 where the joint NLP
  // reaches 3e-12 and 0.)
  std::vector<bool> restart(static_cast<std::size_t>(ne), false);
  {
    MatrixXd info = MatrixXd::Zero(nt, nt);
    VectorXd weighted = VectorXd::Zero(nt);
    int used = 0;
    std::vector<EpisodeRun> runs;
    ForEachEpisode(
        &fits, workers, so, say,
        [nt](int e, EpisodeFit* fit, EpisodeRun* run, const MpecSolverOptions& o,
             const Progress& out) {
          const MpecSolution sol = SolveMpec(*fit->problem, o);
          run->iterations += sol.iterations;
          run->stages += sol.stages;
          if (!sol.x.allFinite()) return;
          fit->x = sol.x;
          fit->final_epsilon = sol.final_epsilon;
          fit->relaxed = sol.relaxed;
          run->have_cov =
              sol.converged && UpdateCurvature(fit, nt, sol, o, &run->iterations, &run->stages);
          std::ostringstream s;
          s << "mpec decomposed: episode " << e << " alone: theta";
          for (int i = 0; i < nt; ++i) s << " " << sol.x[i];
          s << ", " << sol.iterations << " Ipopt iterations, " << sol.reason;
          out(s.str());
        },
        &runs);
    // Episodes whose own fit is far worse than the others' (PoorlyFittingEpisodes on
    // √(f_e / residuals_e), the objective's rms per residual, process noise included: > 3× the
    // median; measured on 50 tossed cubes: one toss's own θ̂_e = 0.13 against a median 0.395,
    // f_e 11.8× the median's (3.4× in rms) with a measurement rms below 3× the median's — a
    // wrong local solution explaining the poses by process noise, whose weight pulled θ_0 down
    // to 0.368) are left out of θ_0 and solved again from their guess at θ_0.
    std::vector<int> solved_alone;
    std::vector<EpisodeEstimate> alone;
    for (int e = 0; e < ne; ++e) {
      r.iterations += runs[e].iterations;
      r.stages += runs[e].stages;
      const EpisodeFit& fit = fits[e];
      if (fit.x.size() == 0) continue;
      double f = 0.0;
      if (!fit.problem->Objective(fit.x, &f) || !std::isfinite(f)) continue;
      EpisodeEstimate ee;
      ee.rms_residual = std::sqrt(f / std::max(1, fit.problem->num_residuals()));
      alone.push_back(ee);
      solved_alone.push_back(e);
    }
    double median = 0.0;
    for (int k : PoorlyFittingEpisodes(alone, 3.0, &median)) {
      const int e = solved_alone[static_cast<std::size_t>(k)];
      restart[static_cast<std::size_t>(e)] = true;
      std::ostringstream s;
      s << "mpec decomposed: episode " << e << " alone fits poorly (objective rms per residual "
        << alone[static_cast<std::size_t>(k)].rms_residual << " > 3 x the median " << median
        << "): left out of theta_0, solved again from its guess there";
      say(s.str());
    }
    for (int e = 0; e < ne; ++e) {
      const EpisodeFit& fit = fits[e];
      if (fit.x.size() == 0 || restart[static_cast<std::size_t>(e)]) continue;
      const VectorXd th = fit.x.head(nt);
      const MatrixXd& cov = fit.covariance;
      if (!runs[e].have_cov || !cov.allFinite()) continue;
      Eigen::LDLT<MatrixXd> ldlt(cov);
      if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) continue;
      const MatrixXd inv = ldlt.solve(MatrixXd::Identity(nt, nt));
      info += inv;
      weighted += inv * th;
      ++used;
    }
    if (used > 0) {
      Eigen::LDLT<MatrixXd> ldlt(info);
      if (ldlt.info() == Eigen::Success && ldlt.isPositive())
        theta = ldlt.solve(weighted).cwiseMax(lo).cwiseMin(hi);
    }
  }
  double F = 0.0;
  VectorXd G;
  MatrixXd H;
  std::string failure;
  std::vector<int> loose;  // episodes above the complementarity tolerance at θ
  bool ok = evaluate(theta, &fits, &F, &G, &H, &failure, &loose, restart);
  describe(0, theta, F, G);
  bool outer_converged = false;
  std::string outer_reason;
  int outer = 0;
  // The last accepted step s and its gradient change y, kept while that step's decrement was
  // above F's noise (kNoiseDecrement): the model Σ_e 2 C_e⁻¹ takes a relaxed episode's
  // curvature from its profile at its own θ̂_e (measured on 5 and 10 tossed cubes: the gradient
  // fell by a near-constant factor ~0.1–0.17 per Newton step), the secant along s corrects it.
  VectorXd secant_s, secant_y;
  bool final_pass = false;  // the episodes above the tolerance solved again in full at θ
  for (; ok && outer < kMaxOuterIterations; ++outer) {
    if (secant_s.size() == nt) {
      double ratio = 0.0;
      H = mpec_internal::SecantCorrected(H, secant_s, secant_y, &ratio);
      std::ostringstream s;
      s << "mpec decomposed: curvature along the last step, secant / model " << ratio;
      say(s.str());
    }
    // Newton step on the free θ (a θ at a bound with the gradient pushing outward is held).
    std::vector<int> free;
    for (int i = 0; i < nt; ++i) {
      const bool at_lo = theta[i] <= lo[i] + 1e-12 && G[i] > 0;
      const bool at_hi = theta[i] >= hi[i] - 1e-12 && G[i] < 0;
      if (!at_lo && !at_hi) free.push_back(i);
    }
    if (free.empty()) {
      outer_converged = true;
      outer_reason = "every parameter at a bound";
      break;
    }
    const int nf = static_cast<int>(free.size());
    MatrixXd Hf(nf, nf);
    VectorXd Gf(nf);
    for (int i = 0; i < nf; ++i) {
      Gf[i] = G[free[i]];
      for (int j = 0; j < nf; ++j) Hf(i, j) = H(free[i], free[j]);
    }
    Eigen::LDLT<MatrixXd> ldlt(Hf);
    VectorXd df;
    if (ldlt.info() == Eigen::Success && ldlt.isPositive() && Hf.diagonal().minCoeff() > 0) {
      df = -ldlt.solve(Gf);
    } else {
      outer_reason = "the profile's curvature is not positive definite";
      break;
    }
    const double decrement = -0.5 * Gf.dot(df);
    VectorXd d = VectorXd::Zero(nt);
    for (int i = 0; i < nf; ++i) d[free[i]] = df[i];
    bool relaxed = false;
    for (const EpisodeFit& fit : fits) relaxed = relaxed || fit.relaxed.lambda.size() > 0;
    if (decrement <= (relaxed ? kRelaxedDecrementTolerance : kDecrementTolerance) ||
        d.cwiseAbs().maxCoeff() <= kStepTolerance * (1 + theta.cwiseAbs().maxCoeff())) {
      if (!loose.empty() && !final_pass) {
        // Converged with episodes kept above the tolerance (their warm-started tails): each
        // solved again at θ with the homotopy from the start after its tail, once; the outer
        // loop goes on if the gradient they give calls for more steps.
        final_pass = true;
        std::vector<bool> only(static_cast<std::size_t>(ne), false);
        for (int e : loose) only[static_cast<std::size_t>(e)] = true;
        std::ostringstream s;
        s << "mpec decomposed: " << loose.size() << " episode" << (loose.size() > 1 ? "s" : "")
          << " above the complementarity tolerance at the converged theta, solved again in full";
        say(s.str());
        ok = evaluate(theta, &fits, &F, &G, &H, &failure, &loose, {}, false, only);
        describe(outer, theta, F, G);
        secant_s.resize(0);
        --outer;  // not a Newton step
        continue;
      }
      outer_converged = true;
      outer_reason = "Newton decrement " + std::to_string(decrement);
      break;
    }
    // Projected step, halved while F does not decrease (unless the decrement is at F's noise).
    bool accepted = false;
    double t = 1.0;
    for (int h = 0; h <= kMaxHalvings && !accepted; ++h, t *= 0.5) {
      const VectorXd trial = (theta + t * d).cwiseMax(lo).cwiseMin(hi);
      std::vector<EpisodeFit> next(ne);
      for (int e = 0; e < ne; ++e) {
        // Warm start from the accepted solutions; the problems are shared (moved back below).
        next[e].problem = std::move(fits[e].problem);
        next[e].x = fits[e].x;
        next[e].final_epsilon = fits[e].final_epsilon;
        next[e].relaxed = fits[e].relaxed;
        next[e].profile_covariance = fits[e].profile_covariance;
        next[e].covariance = fits[e].covariance;
        next[e].hessian = fits[e].hessian;
      }
      double Ft = 0.0;
      VectorXd Gt;
      MatrixXd Ht;
      std::string ft;
      std::vector<int> loose_t;
      const bool okt = evaluate(trial, &next, &Ft, &Gt, &Ht, &ft, &loose_t);
      const bool better = Ft <= F - 1e-4 * t * 2 * decrement;
      if (okt && (better || decrement <= kNoiseDecrement)) {
        accepted = true;
        fits = std::move(next);
        if (decrement > kNoiseDecrement) {
          secant_s = trial - theta;
          secant_y = Gt - G;
        } else {
          secant_s.resize(0);
        }
        theta = trial;
        loose = std::move(loose_t);
        F = Ft;
        G = Gt;
        H = Ht;
      } else {
        for (int e = 0; e < ne; ++e) fits[e].problem = std::move(next[e].problem);
        std::ostringstream s;
        s << "mpec decomposed: step " << t << " rejected ("
          << (okt ? "objective " + std::to_string(Ft) + " not below " + std::to_string(F)
                  : "episode failed: " + ft)
          << ")";
        say(s.str());
      }
    }
    describe(outer + 1, theta, F, G);
    if (!accepted) {
      outer_reason = "no decrease along the Newton step";
      break;
    }
  }
  if (ok && !outer_converged && outer_reason.empty())
    outer_reason = "outer iteration limit " + std::to_string(kMaxOuterIterations);

  // The polished episodes' curvatures at the final θ (a relaxed episode's, its profile's, is
  // current): the model standard error and the jackknife read them.
  if (ok) {
    std::vector<EpisodeRun> runs;
    ForEachEpisode(
        &fits, workers, so, say,
        [nt](int, EpisodeFit* fit, EpisodeRun* run, const MpecSolverOptions& o, const Progress&) {
          if (fit->x.size() == 0 || fit->relaxed.lambda.size() > 0) return;
          MpecSolution sol;
          sol.x = fit->x;
          sol.polished = true;
          UpdateCurvature(fit, nt, sol, o, &run->iterations, &run->stages);
        },
        &runs);
    for (const EpisodeRun& run : runs) {
      r.iterations += run.iterations;
      r.stages += run.stages;
    }
  }

  // Results at the final θ.
  r.estimates = theta;
  r.converged = ok && outer_converged && loose.empty();
  std::ostringstream reason;
  reason << "decomposed over " << ne << " episodes, " << outer
         << " Newton steps: " << (ok ? outer_reason : "an episode failed: " + failure);
  if (ok && !loose.empty()) {
    reason << "; " << loose.size() << " episode" << (loose.size() > 1 ? "s" : "")
           << " above the complementarity tolerance " << so.complementarity_tolerance
           << " at the estimate:";
    for (int e : loose)
      reason << " " << log.episodes[static_cast<std::size_t>(e)].file << " ("
             << fits[static_cast<std::size_t>(e)].violation << ")";
  }
  r.polished = true;
  double ss = 0.0;
  MatrixXd info = MatrixXd::Zero(nt, nt);  // Σ C_e⁻¹
  for (int e = 0; e < ne; ++e) {
    const EpisodeFit& fit = fits[e];
    const MpecEstimationProblem& p = *fit.problem;
    if (fit.x.size() != p.num_variables()) {
      r.converged = false;
      continue;
    }
    std::vector<double> per;
    double max_w = 0.0, eq = 0.0, comp = 0.0;
    ss += p.SquaredResiduals(fit.x, &per, &max_w);
    r.max_process_noise = std::max(r.max_process_noise, max_w);
    p.StepViolation(fit.x, &eq, &comp);
    r.equality_violation = std::max(r.equality_violation, eq);
    r.complementarity_violation = std::max(r.complementarity_violation, comp);
    r.dropped_jacobian = std::max(r.dropped_jacobian, p.dropped_jacobian());
    r.polished = r.polished && fit.reason.rfind("polished", 0) == 0;
    if (fit.relaxed.lambda.size() > 0) r.std_error_method = "profile";  // some episode's C_e
    info += 0.5 * fit.hessian;
    EpisodeEstimate ee;
    ee.file = log.episodes[e].file;
    ee.x0 = p.InitialState(fit.x, 0);
    const int per_sample = ResidualsPerSample(log.episodes[e], simulator.scene().dim);
    ee.rms_residual = std::sqrt(per[0] / std::max(1, per_sample * log.episodes[e].num_samples()));
    r.episodes.push_back(ee);
  }
  r.reason = reason.str();
  r.final_cost = 0.5 * ss;
  mpec_internal::SetResidualSigma(simulator, log, nt, options.noise_sigma, ss, &r);
  r.robust_std_errors = VectorXd::Constant(nt, std::numeric_limits<double>::quiet_NaN());
  {
    // C = (Σ_e C_e⁻¹)⁻¹ over the free θ (a θ with no information, e.g. at a bound: NaN).
    std::vector<int> free;
    for (int i = 0; i < nt; ++i)
      if (info(i, i) > 0) free.push_back(i);
    MatrixXd c(free.size(), free.size());
    for (std::size_t i = 0; i < free.size(); ++i)
      for (std::size_t j = 0; j < free.size(); ++j) c(i, j) = info(free[i], free[j]);
    Eigen::LDLT<MatrixXd> ldlt(c);
    MatrixXd full;
    if (!free.empty() && ldlt.info() == Eigen::Success && ldlt.isPositive()) {
      const MatrixXd cov = ldlt.solve(MatrixXd::Identity(c.rows(), c.cols()));
      full = MatrixXd::Constant(nt, nt, std::numeric_limits<double>::quiet_NaN());
      for (std::size_t i = 0; i < free.size(); ++i)
        for (std::size_t j = 0; j < free.size(); ++j) full(free[i], free[j]) = cov(i, j);
      // The episodes' jackknife from their envelope gradients and curvatures at θ̂ (scale-free:
      // g_e, H_e ∝ 1 / σ²).
      std::vector<VectorXd> g;
      std::vector<MatrixXd> he;
      for (const EpisodeFit& fit : fits) {
        if (fit.gradient.size() != nt || !fit.gradient.allFinite() || fit.hessian.rows() != nt)
          break;
        g.emplace_back(free.size());
        he.emplace_back(free.size(), free.size());
        for (std::size_t i = 0; i < free.size(); ++i) {
          g.back()[i] = fit.gradient[free[i]];
          for (std::size_t j = 0; j < free.size(); ++j)
            he.back()(i, j) = fit.hessian(free[i], free[j]);
        }
      }
      const MatrixXd robust =
          g.size() == fits.size() ? mpec_internal::EpisodeJackknifeCovariance(he, g) : MatrixXd();
      for (std::size_t i = 0; i < free.size() && robust.size() > 0; ++i)
        if (robust(i, i) > 0) r.robust_std_errors[free[i]] = std::sqrt(robust(i, i));
    }
    const double scale = (r.sigma * r.sigma) / (sigma_w * sigma_w);
    r.covariance = mpec_internal::CovarianceWithStdErrors(full, nt, scale, &r.std_errors);
  }

  if (options.bootstrap > 0 && ne >= 2)
    mpec_internal::BootstrapOverEpisodes(simulator, log, options, EstimateMpecDecomposed, &r);
  r.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace vinci::estimation
