// The MPEC estimator's driver: builds the problem, runs the homotopy (mpec.h), and reports the
// estimates, standard errors and violations (mpec_estimator.h).
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "estimation_internal.h"
#include "mpec_problem.h"
#include "vinci/estimation/mpec_decomposed.h"

namespace vinci::estimation {

using mpec_internal::kDefaultSigma;
using mpec_internal::kInf;
using mpec_internal::ParallelFor;
using mpec_internal::ResidualRow;
using mpec_internal::StepBlock;
using sim::Params;
using sim::State;
using sim::VectorXd;

namespace {

double Seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

// MpecOptions::least_squares_start: the fit, then EstimateMpec from its rollout.
MpecEstimateResult EstimateFromLeastSquares(const sim::Simulator& simulator, const Log& log,
                                            const MpecOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const LeastSquaresOptions lo = mpec_internal::StartFitOptions(options);
  EstimateResult ls = EstimateLeastSquares(simulator, log, lo);
  std::ostringstream note;
  note << "least-squares start (" << ls.iterations << " iterations, " << ls.time_s << " s";
  // A rough fit whose residuals contradict the stated noise has not found the data's contact
  // modes, and its rollout is no start (measured: a tossed cube's, σ̂ 358 µm for 30 µm; the
  // start's NLP from it ended at a χ² 13 times its degrees of freedom). It is fitted again with
  // the careful continuation (LeastSquaresOptions' growth, iterations and refinement), which fits
  // tossed cubes at the noise, and the better of the two fits is the start.
  const auto contradicted = [&](const EstimateResult& f) {
    const int dof = f.num_residuals - f.num_unknowns;
    return !std::isfinite(f.sigma_residual) ||
           internal::ResidualsContradictNoise(f.sigma_residual * f.sigma_residual * dof, dof,
                                              options.noise_sigma);
  };
  if (options.least_squares_horizon > 0 && contradicted(ls)) {
    LeastSquaresOptions careful = lo;
    const LeastSquaresOptions defaults;
    careful.horizon_growth = defaults.horizon_growth;
    careful.max_iterations = defaults.max_iterations;
    careful.horizon_refinement = defaults.horizon_refinement;
    careful.episode_restarts = defaults.episode_restarts;
    EstimateResult again = EstimateLeastSquares(simulator, log, careful);
    note << "; its residuals contradict the noise (σ̂ = " << ls.sigma_residual
         << " m), fitted again with growth " << careful.horizon_growth << ": " << again.iterations
         << " iterations, " << again.time_s << " s, σ̂ = " << again.sigma_residual << " m";
    if (again.estimates.allFinite() && again.final_cost < ls.final_cost) ls = std::move(again);
  }
  note << "):";
  for (Eigen::Index i = 0; i < ls.estimates.size(); ++i)
    note << " " << options.params[i] << " " << ls.estimates[i];
  MpecOptions o = options;
  o.least_squares_start = false;
  o.bootstrap = 0;
  const bool usable = ls.estimates.size() == static_cast<Eigen::Index>(options.params.size()) &&
                      ls.estimates.allFinite() && ls.episodes.size() == log.episodes.size();
  if (usable) {
    o.start_theta = ls.estimates;
    for (const EpisodeEstimate& e : ls.episodes) o.start_states.push_back(e.x0);
  } else {
    note << " unusable (" << ls.reason << "), the log's poses instead";
  }
  if (options.progress) options.progress("mpec: " + note.str());
  MpecEstimateResult r = EstimateMpec(simulator, log, o);
  r.initial_values = ls.initial_values;
  r.reason = note.str() + "; " + r.reason;
  if (options.bootstrap > 0 && log.episodes.size() >= 2)
    mpec_internal::BootstrapOverEpisodes(simulator, log, options, EstimateMpec, &r);
  r.time_s = Seconds(start);
  return r;
}

}  // namespace

MpecEstimateResult EstimateMpec(const sim::Simulator& simulator, const Log& log,
                                const MpecOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Validate();
  if (options.episodes == MpecEpisodes::kDecomposed && log.episodes.size() >= 2)
    return EstimateMpecDecomposed(simulator, log, options);
  if (options.least_squares_start) return EstimateFromLeastSquares(simulator, log, options);
  const bool stated = options.noise_sigma > 0;
  const double sigma_w = stated ? options.noise_sigma : kDefaultSigma;
  MpecEstimationProblem problem(simulator, log, options, sigma_w);
  MpecEstimateResult r;
  r.method = "mpec";
  r.names = options.params;
  const VectorXd x0 = problem.StartingPoint();
  r.initial_values = problem.Parameters(x0);
  r.complementarity = ToString(options.solver.method);
  r.num_constraints = problem.num_constraints();
  r.num_pairs = static_cast<int>(problem.ComplementarityPairs().size());
  r.num_steps = problem.num_steps();
  r.num_unknowns = problem.num_variables();
  r.num_residuals = problem.num_residuals();
  r.initial_cost = 0.5 * problem.SquaredResiduals(x0);
  r.process_noise = problem.process_noise();
  if (options.progress) {
    std::ostringstream s;
    s << "mpec: " << r.num_steps << " steps, " << r.num_unknowns << " unknowns, "
      << r.num_constraints << " constraints, " << r.num_pairs << " complementarity pairs ("
      << r.complementarity << ")";
    options.progress(s.str());
  }
  MpecSolverOptions so = options.solver;
  if (!so.progress) so.progress = options.progress;
  if (!stated) so.early_polish_tolerance = -1.0;  // the objective's scale is unknown
  MpecSolution sol;
  const bool simulated = !options.start_states.empty();
  // The whole estimation again with `retry` (from `guess`), counting the iterations and NLPs
  // spent so far (sol's) and saying why.
  const auto restart = [&](const MpecOptions& retry, const std::string& guess,
                           const std::string& why) {
    if (options.progress) options.progress("mpec: " + why + "; restarted from " + guess);
    MpecEstimateResult rt = EstimateMpec(simulator, log, retry);
    rt.iterations += sol.iterations;
    rt.stages += sol.stages;
    rt.reason = "restarted from " + guess + " (" + why + "); " + rt.reason;
    rt.time_s = Seconds(start);
    return rt;
  };
  // The start's solution rejected: from the log's poses.
  MpecOptions from_log = options;
  from_log.start_theta.resize(0);
  from_log.start_states.clear();
  bool from_start = false;
  if (simulated && stated && options.start_polish_iterations > 0) {
    // The simulated start is exactly complementary: its active set's NLP (every pair's zero
    // side fixed, θ free) instead of the homotopy, accepted if it solves with its objective
    // (χ² of the measurements plus the process noise's) consistent with the stated noise.
    // Otherwise the estimation restarts from the log's poses.
    // A start whose residuals are all at round-off (≤ 1e-6 σ: a noise-free log and an exact
    // fit) is feasible with the objective's least value 0, a global minimum; its NLP is not
    // solved (from there Ipopt's bound push and the many biactive pairs made restoration fail).
    double f0 = kInf;
    if (problem.Objective(x0, &f0) && f0 <= 1e-12 * problem.num_residuals()) {
      sol.x = x0;
      sol.objective = f0;
      sol.converged = sol.solved = sol.iterate_solved = true;
      std::ostringstream why;
      why << "not solved, the start fits exactly (objective " << f0 << ")";
      sol.reason = why.str();
    } else {
      const mpec_internal::FixedThetaProblem kept(problem, VectorXd(), x0, true);
      MpecSolverOptions ko = so;
      ko.max_iterations = options.start_polish_iterations;
      sol = SolveMpec(kept, ko);
    }
    const int dof = mpec_internal::ResidualDof(simulator, log, r.names.size(), r.num_residuals);
    const bool fits =
        sol.converged && sol.x.allFinite() &&
        !internal::ResidualsContradictNoise(sol.objective * sigma_w * sigma_w, dof, sigma_w);
    if (!fits) {
      std::ostringstream why;
      why << "the start's active set: " << sol.reason;
      if (sol.converged) why << ", objective " << sol.objective << " for " << dof << " d.o.f.";
      return restart(from_log, "the log's poses", why.str());
    }
    from_start = true;
    sol.polished = true;
    sol.reason = "the start's active set: " + sol.reason;
  } else {
    sol = SolveMpec(problem, so);
  }
  if (sol.first_stage_failed && !options.tracking_guess && !simulated) {
    // No relaxation stage solved from the smoothed poses (Ipopt took the first stage to a point
    // of local infeasibility: measured on a noise-free block log without orientation, whose
    // polish then "solved" at μ̂ = 0 with χ²/2 = 2.6e4): the whole estimation again from the
    // tracking guess, where every step equation and complementarity pair holds at the start.
    MpecOptions tracking = options;
    tracking.tracking_guess = true;
    return restart(tracking, "the tracking guess",
                   "the first relaxation stage failed from the smoothed guess: " + sol.reason);
  }
  r.estimates = problem.Parameters(sol.x);
  r.iterations = sol.iterations;
  r.stages = sol.stages;
  r.polished = sol.polished;
  r.start_kept = from_start;
  r.converged = sol.converged;
  r.reason = sol.reason;
  if (so.deterministic_ordering) r.ordering = ToString(sol.ordering);
  std::vector<double> per_episode;
  const double ss = problem.SquaredResiduals(sol.x, &per_episode, &r.max_process_noise);
  r.final_cost = 0.5 * ss;
  problem.StepViolation(sol.x, &r.equality_violation, &r.complementarity_violation);
  r.dropped_jacobian = problem.dropped_jacobian();
  mpec_internal::SetResidualSigma(simulator, log, static_cast<int>(options.params.size()),
                                  options.noise_sigma, ss, &r);
  sim::MatrixXd cov;
  bool have_cov = false;
  if (!sol.polished && sol.relaxed.lambda.size() > 0) {
    // A relaxed iterate: the profile's curvature (mpec_internal::ProfileCovariance).
    if (options.progress) options.progress("mpec: standard errors from the relaxed profile");
    std::string why;
    r.std_error_method = "profile";
    have_cov =
        mpec_internal::ProfileCovariance(problem, sol, so, &cov, &r.iterations, &r.stages, &why);
    if (!have_cov) r.reason += "; no profile standard errors: " + why;
  } else {
    have_cov = problem.ParameterCovariance(
        sol.x, problem.ClassifyPairs(sol.x, mpec_internal::kBiactive), &cov);
  }
  const double scale = (r.sigma * r.sigma) / (sigma_w * sigma_w);
  r.covariance = mpec_internal::CovarianceWithStdErrors(have_cov ? cov : sim::MatrixXd(),
                                                        r.estimates.size(), scale, &r.std_errors);
  if (from_start) {
    // The rollout's contact modes are only as determined as θ̂: a parameter known to no better
    // than start_max_relative_std_error of its value leaves other modes that fit as well
    // (measured: a plate particle at 0.1 mm noise, 0.070 ± 0.016 from the start where the
    // homotopy gives 0.192 ± 0.020; docs/estimation.md, "Start from least squares").
    for (Eigen::Index i = 0; i < r.estimates.size(); ++i) {
      if (r.std_errors[i] <= options.start_max_relative_std_error * std::abs(r.estimates[i]))
        continue;
      std::ostringstream why;
      why << "the start's active set: " << r.names[i] << " = " << r.estimates[i];
      if (std::isfinite(r.std_errors[i]))
        why << " ± " << r.std_errors[i] << ", a standard error above "
            << options.start_max_relative_std_error << " of its value";
      else
        why << " without a standard error";
      return restart(from_log, "the log's poses", why.str());
    }
  }
  if (r.std_error_method == "laplace") {
    VectorXd yl, yu, gl, gu;
    problem.Bounds(&yl, &yu, &gl, &gu);
    r.reason +=
        mpec_internal::MissingStdErrors(r.names, r.estimates, r.std_errors, problem.Parameters(yl),
                                        problem.Parameters(yu), have_cov);
  }
  r.robust_std_errors = VectorXd::Constant(r.estimates.size(), std::nan(""));  // decomposed only
  for (int e = 0; e < static_cast<int>(log.episodes.size()); ++e) {
    EpisodeEstimate ee;
    ee.file = log.episodes[e].file;
    ee.x0 = problem.InitialState(sol.x, e);
    const int per_sample = ResidualsPerSample(log.episodes[e], simulator.scene().dim);
    ee.rms_residual =
        std::sqrt(per_episode[e] / std::max(1, per_sample * log.episodes[e].num_samples()));
    r.episodes.push_back(ee);
  }
  if (options.bootstrap > 0 && log.episodes.size() >= 2)
    mpec_internal::BootstrapOverEpisodes(simulator, log, options, EstimateMpec, &r);
  r.time_s = Seconds(start);
  return r;
}

void mpec_internal::BootstrapOverEpisodes(
    const sim::Simulator& simulator, const Log& log, const MpecOptions& options,
    const std::function<MpecEstimateResult(const sim::Simulator&, const Log&, const MpecOptions&)>&
        estimate,
    MpecEstimateResult* r) {
  // Resamples of the episodes; their estimates' standard deviation (ordered sums).
  const int ne = static_cast<int>(log.episodes.size());
  const Eigen::Index nt = r->estimates.size();
  std::mt19937 rng(options.bootstrap_seed);
  std::uniform_int_distribution<int> pick(0, ne - 1);
  MpecOptions bo = options;
  bo.bootstrap = 0;
  bo.progress = nullptr;
  bo.solver.progress = nullptr;
  std::vector<VectorXd> draws;
  for (int b = 0; b < options.bootstrap; ++b) {
    Log resample;
    for (int k = 0; k < ne; ++k) resample.episodes.push_back(log.episodes[pick(rng)]);
    const MpecEstimateResult rb = estimate(simulator, resample, bo);
    // A resample whose residuals contradict the stated noise counts if its solver converged:
    // model error is what the bootstrap's spread is for.
    const bool usable = rb.converged || rb.noise_contradicted;
    r->bootstrap_converged += usable;
    if (usable) draws.push_back(rb.estimates);
    if (options.progress) {
      std::ostringstream s;
      s << "mpec bootstrap " << b + 1 << "/" << options.bootstrap << ": "
        << (rb.converged ? "converged"
            : usable     ? "converged, its residuals contradict the stated noise"
                         : "not converged");
      options.progress(s.str());
    }
  }
  r->std_error_method = "bootstrap";
  sim::MatrixXd cov;
  if (draws.size() >= 2) {
    VectorXd mean = VectorXd::Zero(nt);
    for (const VectorXd& d : draws) mean += d;
    mean /= static_cast<double>(draws.size());
    cov = sim::MatrixXd::Zero(nt, nt);
    for (const VectorXd& d : draws) cov += (d - mean) * (d - mean).transpose();
    cov /= static_cast<double>(draws.size() - 1);
  }
  // The resamples' spread can be exactly 0 (every resample the same data): a standard error of
  // 0, not an undefined one.
  r->covariance = mpec_internal::CovarianceWithStdErrors(cov, nt, 1.0, &r->std_errors, true);
}

int mpec_internal::ResidualDof(const sim::Simulator& simulator, const Log& log, int num_params,
                               int num_residuals) {
  int p = num_params;
  for (const Episode& ep : log.episodes)
    p += internal::ObservedDynamic(ep) * internal::StateBlockSize(internal::Planar(simulator));
  return num_residuals - p;
}

void mpec_internal::SetResidualSigma(const sim::Simulator& simulator, const Log& log,
                                     int num_params, double stated_sigma, double ss,
                                     MpecEstimateResult* r) {
  const int dof = ResidualDof(simulator, log, num_params, r->num_residuals);
  const double sigma_hat = std::sqrt(ss / std::max(1, dof));
  r->sigma = stated_sigma > 0 ? stated_sigma : sigma_hat;
  if (!(stated_sigma > 0) || !internal::ResidualsContradictNoise(ss, dof, stated_sigma)) return;
  std::ostringstream m;
  m << "; the residuals contradict the stated noise (σ̂ = " << sigma_hat << " m for --noise "
    << stated_sigma
    << " m): a local minimum, a model mismatch (e.g. a step coarser than the motion needs, "
       "--mpec-substeps) or more noise than stated; the standard errors use σ̂";
  r->reason += m.str();
  r->sigma = sigma_hat;
  r->noise_contradicted = r->converged;
  r->converged = false;
}

std::string mpec_internal::MissingStdErrors(const std::vector<std::string>& names,
                                            const VectorXd& estimates, const VectorXd& std_errors,
                                            const VectorXd& lower, const VectorXd& upper,
                                            bool have_covariance) {
  if (!have_covariance) return "; no standard errors: the Laplace covariance's KKT solves failed";
  std::ostringstream s;
  for (Eigen::Index i = 0; i < estimates.size(); ++i) {
    if (!std::isnan(std_errors[i])) continue;
    const double v = estimates[i];
    auto at = [v](double b) { return std::abs(v - b) <= 1e-9 * std::max(1.0, std::abs(b)); };
    s << "; no standard error for " << names[static_cast<std::size_t>(i)] << ": ";
    if (at(lower[i]) || at(upper[i])) {
      s << "it ends at the bound " << (at(lower[i]) ? lower[i] : upper[i])
        << " of its range, where the Laplace approximation does not apply";
    } else {
      s << "its variance is not positive (the data do not determine it)";
    }
  }
  return s.str();
}

sim::MatrixXd mpec_internal::CovarianceWithStdErrors(const sim::MatrixXd& covariance,
                                                     Eigen::Index p, double scale,
                                                     VectorXd* std_errors, bool zero_is_defined) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  sim::MatrixXd c = sim::MatrixXd::Constant(p, p, nan);
  *std_errors = VectorXd::Constant(p, nan);
  if (covariance.rows() != p || covariance.cols() != p) return c;
  c = 0.5 * scale * (covariance + covariance.transpose());  // the solves' rounding
  for (Eigen::Index i = 0; i < p; ++i) {
    if (c(i, i) > 0 || (zero_is_defined && c(i, i) == 0)) {
      (*std_errors)[i] = std::sqrt(c(i, i));
    } else {
      c.row(i).setConstant(nan);
      c.col(i).setConstant(nan);
    }
  }
  return c;
}

}  // namespace vinci::estimation
