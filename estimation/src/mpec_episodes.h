// The decomposed MPEC's episodes (mpec_decomposed.cc): one episode's fit at the current θ, and
// the loop that runs a job on every episode, in this process or in forked worker processes.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mpec_problem.h"
#include "vinci/estimation/mpec.h"
#include "vinci/sim/types.h"

namespace vinci::estimation::mpec_internal {

// One episode: its problem, and its solution at the current θ.
struct EpisodeFit {
  std::unique_ptr<MpecEstimationProblem> problem;
  sim::VectorXd x;           // solution at the current θ (empty: none yet)
  double f = 0.0;            // objective (χ²) at x
  sim::VectorXd gradient;    // ∂f/∂θ (envelope theorem)
  sim::MatrixXd hessian;     // 2 C⁻¹ (the Laplace covariance with θ free)
  sim::MatrixXd covariance;  // C
  // A relaxed (unpolished) solution's covariance from its profile (ProfileCovariance),
  // computed at the first such solution and kept: 2p + 1 (at most 4p + 1) more NLPs for p
  // parameters (empty: none yet).
  sim::MatrixXd profile_covariance;
  // When x is a relaxed iterate: its ε and multipliers (MpecSolution::relaxed), else empty.
  double final_epsilon = 0.0;
  MpecMultipliers relaxed;
  double violation = 0.0;  // x's complementarity violation
  // converged: the NLP met every tolerance. usable: x is a solved relaxation's iterate with a
  // finite gradient, above the complementarity tolerance when not converged (the outer loop
  // may go on from it; the estimate is not converged while an episode is only usable).
  bool converged = false, usable = false;
  std::string reason;
};

// What one episode's work hands back besides its EpisodeFit.
struct EpisodeRun {
  int iterations = 0, stages = 0;
  std::vector<std::string> solver_lines;  // its NLPs' summary lines (worker processes only)
  std::vector<std::string> lines;         // its estimator progress lines (worker processes only)
  bool have_cov = false;                  // the start's θ̂_e converged and has a covariance
};

using Progress = std::function<void(const std::string&)>;
// job(e, fit, run, so, say): one episode's work on its fit, NLP lines to so.progress, estimator
// lines to say.
using EpisodeJob =
    std::function<void(int, EpisodeFit*, EpisodeRun*, const MpecSolverOptions&, const Progress&)>;

// Runs job on every episode of *fits: with one worker here, in episode order, lines as they
// come; with more, each episode in a forked worker process (Ipopt is not thread-safe), its
// fit and lines taken back (the lines replayed) as it ends. *runs in episode order. The result
// is bitwise the same for any number of workers.
void ForEachEpisode(std::vector<EpisodeFit>* fits, int workers, const MpecSolverOptions& so,
                    const Progress& say, const EpisodeJob& job, std::vector<EpisodeRun>* runs);

}  // namespace vinci::estimation::mpec_internal
