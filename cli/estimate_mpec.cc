// `vinci estimate --method mpec`: the MPEC non-recursive filter (docs/estimation.md), run from
// RunEstimateCommand.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include "estimate_command.h"
#include "json.h"
#include "vinci/estimation/holdout.h"
#include "vinci/estimation/log.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::cli {
namespace {

// The complementarity tolerance the estimate is held to (the estimator's default unless given).
double ComplementarityTolerance(const EstimateOptions& o) {
  return o.complementarity_tolerance.value_or(
      estimation::MpecOptions().solver.complementarity_tolerance);
}

// --mpec-start resolved: auto is lsq with a stated noise and joint episodes, else log.
std::string MpecStart(const EstimateOptions& o) {
  if (!o.mpec_start.empty() && o.mpec_start != "auto") return o.mpec_start;
  const bool scholtes = o.complementarity.empty() || o.complementarity == "scholtes";
  return o.noise > 0 && scholtes && o.mpec_episodes != "decomposed" ? "lsq" : "log";
}

std::string MpecJson(const EstimateOptions& o, const estimation::MpecEstimateResult& r,
                     const estimation::HoldoutResult* holdout) {
  std::ostringstream j;
  j << "{\n  \"scene\": " << JsonString(o.scene_path) << ",\n  \"logs\": [";
  for (size_t i = 0; i < o.logs.size(); ++i) j << (i ? ", " : "") << JsonString(o.logs[i]);
  j << "],\n  \"methods\": {\n    \"mpec\": {\n"
    << "      \"estimates\": " << JsonNamedNumbers(r.names, r.estimates) << ",\n"
    << "      \"std_errors\": " << JsonNamedNumbers(r.names, r.std_errors) << ",\n"
    << "      \"std_error_method\": " << JsonString(r.std_error_method) << ",\n"
    << "      \"robust_std_errors\": " << JsonNamedNumbers(r.names, r.robust_std_errors) << ",\n"
    << "      \"covariance\": " << JsonMatrix(r.covariance) << ",\n"
    << "      \"bootstrap\": " << o.bootstrap << ",\n"
    << "      \"bootstrap_converged\": " << r.bootstrap_converged << ",\n"
    << "      \"initial_values\": " << JsonNamedNumbers(r.names, r.initial_values) << ",\n"
    << "      \"iterations\": " << r.iterations << ",\n"
    << "      \"time_s\": " << JsonNumber(r.time_s) << ",\n"
    << "      \"converged\": " << (r.converged ? "true" : "false") << ",\n"
    << "      \"reason\": " << JsonString(r.reason) << ",\n"
    << "      \"noise_contradicted\": " << (r.noise_contradicted ? "true" : "false") << ",\n"
    << "      \"complementarity\": " << JsonString(r.complementarity) << ",\n"
    << "      \"complementarity_violation\": " << JsonNumber(r.complementarity_violation) << ",\n"
    << "      \"complementarity_tolerance\": " << JsonNumber(ComplementarityTolerance(o)) << ",\n"
    << "      \"equality_violation\": " << JsonNumber(r.equality_violation) << ",\n"
    << "      \"stages\": " << r.stages << ",\n"
    << "      \"polished\": " << (r.polished ? "true" : "false") << ",\n"
    << "      \"sigma\": " << JsonNumber(r.sigma) << ",\n"
    << "      \"noise_stated\": " << (o.noise > 0 ? "true" : "false") << ",\n"
    << "      \"process_noise\": " << JsonNumber(r.process_noise) << ",\n"
    << "      \"max_process_noise\": " << JsonNumber(r.max_process_noise) << ",\n"
    << "      \"dropped_jacobian\": " << JsonNumber(r.dropped_jacobian) << ",\n"
    << "      \"initial_cost\": " << JsonNumber(r.initial_cost) << ",\n"
    << "      \"final_cost\": " << JsonNumber(r.final_cost) << ",\n"
    << "      \"num_residuals\": " << r.num_residuals << ",\n"
    << "      \"num_unknowns\": " << r.num_unknowns << ",\n"
    << "      \"num_constraints\": " << r.num_constraints << ",\n"
    << "      \"num_complementarity_pairs\": " << r.num_pairs << ",\n"
    << "      \"num_steps\": " << r.num_steps << ",\n"
    << "      \"substeps\": " << std::max(0, o.mpec_substeps) << ",\n"
    << "      \"episode_mode\": \"" << (o.mpec_episodes.empty() ? "joint" : o.mpec_episodes)
    << "\",\n"
    << "      \"ordering\": \"" << (o.mpec_ordering.empty() ? "auto" : o.mpec_ordering) << "\",\n"
    << "      \"start\": \"" << MpecStart(o) << "\",\n"
    << "      \"start_kept\": " << (r.start_kept ? "true" : "false") << ",\n";
  if (!r.ordering.empty()) j << "      \"ordering_used\": \"" << r.ordering << "\",\n";
  if (holdout) j << HoldoutJson(o, *holdout);
  j << "      \"episodes\": [";
  for (size_t e = 0; e < r.episodes.size(); ++e) {
    j << (e ? ", " : "") << "{\"file\": " << JsonString(r.episodes[e].file)
      << ", \"rms_residual\": " << JsonNumber(r.episodes[e].rms_residual) << "}";
  }
  j << "]\n    }\n  }\n}\n";
  return j.str();
}

}  // namespace

ExitCode RunEstimateMpec(const EstimateOptions& o) {
  if (o.noise < 0 || !std::isfinite(o.noise))
    throw std::invalid_argument("--noise: expected a finite σ ≥ 0 in m");
  if (!(o.process_noise >= 0) || !std::isfinite(o.process_noise))
    throw std::invalid_argument("--process-noise: expected a finite σ_Q ≥ 0 in N (N·m)");
  if (o.complementarity_tolerance &&
      (!(*o.complementarity_tolerance > 0) || !std::isfinite(*o.complementarity_tolerance)))
    throw std::invalid_argument("--complementarity-tolerance: expected a finite TOL > 0");
  if (o.mpec_substeps < -1)
    throw std::invalid_argument("--mpec-substeps " + std::to_string(o.mpec_substeps) +
                                ": expected N ≥ 0 (0: the scene's dt; N: N steps per log "
                                "interval)");
  if (o.fixed_initial_state)
    throw std::invalid_argument(
        "--fixed-initial-state: only for --method lsq (mpec estimates "
        "all states)");
  estimation::MpecOptions mo;
  mo.params = o.params;
  mo.noise_sigma = o.noise;
  mo.process_noise = o.process_noise;
  mo.threads = o.threads;
  mo.substeps = std::max(0, o.mpec_substeps);
  if (!o.mpec_episodes.empty()) mo.episodes = estimation::ParseMpecEpisodes(o.mpec_episodes);
  if (!o.mpec_ordering.empty()) mo.solver.ordering = estimation::ParseMpecOrdering(o.mpec_ordering);
  if (!o.mpec_start.empty() && o.mpec_start != "auto" && o.mpec_start != "log" &&
      o.mpec_start != "lsq")
    throw std::invalid_argument("--mpec-start " + o.mpec_start + ": expected auto, log or lsq");
  mo.least_squares_start = MpecStart(o) == "lsq";
  if (mo.least_squares_start && !(o.noise > 0))
    throw std::invalid_argument(
        "--mpec-start lsq: needs --noise SIGMA (the start's solution is kept only if its χ² "
        "fits the stated noise)");
  if (mo.least_squares_start && mo.episodes == estimation::MpecEpisodes::kDecomposed)
    throw std::invalid_argument("--mpec-start lsq: not with --mpec-episodes decomposed");
  mo.solver.method = estimation::ParseComplementarityMethod(o.complementarity);
  if (o.max_iterations) mo.solver.max_iterations = *o.max_iterations;
  if (o.complementarity_tolerance)
    mo.solver.complementarity_tolerance = *o.complementarity_tolerance;
  mo.Validate();
  CheckOutWritable(o.out);
  const sim::Simulator simulator(sim::LoadSceneFile(o.scene_path));
  const estimation::Log all = estimation::ReadLog(o.logs, simulator.scene());
  estimation::Log log = all, held_out;
  if (o.holdout > 0) estimation::SplitHoldout(all, o.holdout, &log, &held_out);
  if (o.bootstrap > 0 && log.episodes.size() < 2)
    throw std::invalid_argument(
        "--bootstrap " + std::to_string(o.bootstrap) +
        ": resamples the episodes (log files) and needs at least 2 fitted episodes, got " +
        std::to_string(log.episodes.size()) + (o.holdout > 0 ? " after --holdout" : ""));
  mo.bootstrap = o.bootstrap;
  if (!o.quiet) {
    mo.progress = [](const std::string& line) { std::cerr << line << "\n"; };
    std::cerr << "vinci estimate: mpec (" << o.complementarity << "), " << log.episodes.size()
              << " episode(s) fitted";
    if (o.holdout > 0) std::cerr << ", " << held_out.episodes.size() << " held out";
    std::cerr << ", " << o.params.size() << " parameter(s)";
    if (o.bootstrap > 0) std::cerr << ", " << o.bootstrap << " bootstrap resamples";
    std::cerr << std::endl;
  }
  const estimation::MpecEstimateResult r = estimation::EstimateMpec(simulator, log, mo);
  const std::unique_ptr<estimation::HoldoutResult> holdout =
      FittedHoldout(o, simulator, r.names, r.estimates, held_out);
  WriteOut(o.out, MpecJson(o, r, holdout.get()));
  if (!o.quiet) {
    std::ostringstream s;
    s.precision(6);
    s << EstimateLines(r.names, r.estimates, r.std_errors, r.initial_values);
    s << "iterations " << r.iterations << " in " << r.stages << " NLPs, " << r.time_s
      << " s, complementarity violation " << r.complementarity_violation << " (tolerance "
      << ComplementarityTolerance(o) << "), " << (r.converged ? "converged" : "did not converge")
      << ": " << r.reason << "\n";
    // Correlations of the estimates (two or more parameters).
    for (Eigen::Index i = 0; i < r.covariance.rows(); ++i)
      for (Eigen::Index j = i + 1; j < r.covariance.cols(); ++j) {
        const double c = r.covariance(i, j) / std::sqrt(r.covariance(i, i) * r.covariance(j, j));
        if (std::isfinite(c))
          s << "correlation " << r.names[i] << ", " << r.names[j] << ": " << c << "\n";
      }
    if (r.std_error_method == "bootstrap")
      s << "standard errors from " << o.bootstrap << " bootstrap resamples ("
        << r.bootstrap_converged << " converged)\n";
    if (r.std_error_method == "profile")
      s << "standard errors from the relaxed problem's profile (the polish did not succeed)\n";
    if (r.robust_std_errors.size() > 0 && r.robust_std_errors.allFinite()) {
      // The episodes' scatter against their own errors: ≫ 1 means model error, and the robust
      // standard errors are the honest ones.
      double worst = 0.0;
      s << "robust standard errors over the " << r.episodes.size() << " episodes (jackknife):";
      for (std::size_t i = 0; i < r.names.size(); ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        const double ratio = r.robust_std_errors[k] / r.std_errors[k];
        s << " " << r.names[i] << " " << r.robust_std_errors[k] << " (" << ratio
          << " times the above)";
        if (std::isfinite(ratio)) worst = std::max(worst, ratio);
      }
      s << "\n";
      if (worst > 3)
        s << "the episodes disagree beyond their standard errors (model error?): the robust ones "
             "are the honest uncertainty\n";
    }
    s << PoorEpisodesLine(r.episodes);
    if (holdout) s << HoldoutSummary(*holdout);
    s << "result      " << o.out << "\n";
    std::cout << s.str() << std::flush;
  }
  if (!r.converged) {
    PrintError("the MPEC estimator did not converge (" + r.reason + "); the result in '" + o.out +
               "' is the last iterate");
    return ExitCode::kSolveFailed;
  }
  return ExitCode::kOk;
}

}  // namespace vinci::cli
