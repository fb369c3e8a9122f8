#include "estimate_command.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "json.h"
#include "vinci/estimation/filter.h"
#include "vinci/estimation/holdout.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/estimation/log.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::cli {
namespace {

std::string ErrorJson(const estimation::RolloutError& e) {
  std::ostringstream j;
  j << "{\"position_m\": " << JsonNumber(e.position_m)
    << ", \"position_percent\": " << JsonNumber(e.position_percent)
    << ", \"orientation_deg\": " << JsonNumber(e.orientation_deg) << ", \"samples\": " << e.samples
    << ", \"failed_rollouts\": " << e.failed_rollouts << "}";
  return j.str();
}

std::string ResultJson(const EstimateOptions& o, const estimation::EstimateResult& r,
                       const estimation::HoldoutResult* holdout) {
  std::ostringstream j;
  j << "{\n  \"scene\": " << JsonString(o.scene_path) << ",\n  \"logs\": [";
  for (size_t i = 0; i < o.logs.size(); ++i) j << (i ? ", " : "") << JsonString(o.logs[i]);
  j << "],\n  \"methods\": {\n    " << JsonString(r.method) << ": {\n"
    << "      \"estimates\": " << JsonNamedNumbers(r.names, r.estimates) << ",\n"
    << "      \"std_errors\": " << JsonNamedNumbers(r.names, r.std_errors) << ",\n"
    << "      \"initial_values\": " << JsonNamedNumbers(r.names, r.initial_values) << ",\n"
    << "      \"iterations\": " << r.iterations << ",\n"
    << "      \"time_s\": " << JsonNumber(r.time_s) << ",\n"
    << "      \"converged\": " << (r.converged ? "true" : "false") << ",\n"
    << "      \"reason\": " << JsonString(r.reason) << ",\n"
    << "      \"sigma\": " << JsonNumber(r.sigma) << ",\n"
    << "      \"noise_stated\": " << (o.noise > 0 ? "true" : "false") << ",\n"
    << "      \"initial_cost\": " << JsonNumber(r.initial_cost) << ",\n"
    << "      \"final_cost\": " << JsonNumber(r.final_cost) << ",\n"
    << "      \"num_residuals\": " << r.num_residuals << ",\n"
    << "      \"num_unknowns\": " << r.num_unknowns << ",\n";
  if (r.method == "lsq") {
    j << "      \"shooting\": " << JsonString(o.shooting) << ",\n"
      << "      \"horizons\": [";
    for (size_t i = 0; i < r.horizons.size(); ++i) j << (i ? ", " : "") << r.horizons[i];
    j << "],\n"
      << "      \"num_segments\": " << r.num_segments << ",\n"
      << "      \"num_continuity_residuals\": " << r.num_continuity_residuals << ",\n"
      << "      \"continuity_defect\": " << JsonNumber(r.continuity_defect) << ",\n"
      << "      \"initial_state_estimated\": " << (o.fixed_initial_state ? "false" : "true")
      << ",\n      \"frozen_state_components\": " << r.frozen_state_components << ",\n"
      << "      \"jacobian\": " << JsonString(r.jacobian) << ",\n"
      << "      \"jacobian_note\": " << JsonString(r.jacobian_note) << ",\n"
      << "      \"jacobian_fallbacks\": " << r.jacobian_fallbacks << ",\n"
      << "      \"degenerate_steps\": " << r.degenerate_steps << ",\n"
      << "      \"mode_change_steps\": " << r.mode_change_steps << ",\n"
      << "      \"std_error_method\": "
      << JsonString(r.std_error_method.empty() ? "linearized" : r.std_error_method) << ",\n";
    if (r.std_error_method == "profile") {
      j << "      \"linearized_std_errors\": " << JsonNamedNumbers(r.names, r.linearized_std_errors)
        << ",\n"
        << "      \"profile_interval\": {";
      for (size_t i = 0; i < r.names.size(); ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        j << (i ? ", " : "") << JsonString(r.names[i]) << ": [" << JsonNumber(r.profile_low[k])
          << ", " << JsonNumber(r.profile_high[k]) << "]";
      }
      j << "},\n";
    }
  }
  if (holdout) j << HoldoutJson(o, *holdout);
  j << "      \"episodes\": [";
  for (size_t e = 0; e < r.episodes.size(); ++e) {
    j << (e ? ", " : "") << "{\"file\": " << JsonString(r.episodes[e].file)
      << ", \"rms_residual\": " << JsonNumber(r.episodes[e].rms_residual) << "}";
  }
  j << "]\n    }\n  }\n}\n";
  return j.str();
}

// Prints one line per iteration / update to stderr.
std::function<void(int, double, const sim::VectorXd&)> ProgressPrinter(const EstimateOptions& o) {
  if (o.quiet) return {};
  return [&o](int iteration, double cost, const sim::VectorXd& p) {
    std::ostringstream line;
    line.precision(8);
    line << "iteration " << iteration;
    if (std::isfinite(cost)) line << "  cost " << cost;
    for (size_t i = 0; i < o.params.size(); ++i)
      line << "  " << o.params[i] << " " << p[static_cast<Eigen::Index>(i)];
    std::cerr << line.str() << "\n";
  };
}

// --method lsq: least squares with the simulator in the loop (Ceres).
estimation::EstimateResult RunLeastSquares(const EstimateOptions& o,
                                           const sim::Simulator& simulator,
                                           const estimation::Log& log) {
  estimation::LeastSquaresOptions lo;
  lo.params = o.params;
  lo.noise_sigma = o.noise;
  lo.threads = o.threads;
  if (o.max_iterations) lo.max_iterations = *o.max_iterations;
  lo.estimate_initial_state = !o.fixed_initial_state;
  if (o.shooting == "multiple")
    lo.shooting = estimation::Shooting::kMultiple;
  else if (o.shooting != "single")
    throw std::invalid_argument("--shooting " + o.shooting + ": expected single or multiple");
  lo.segment_samples = o.segment_samples;
  if (o.lsq_horizon != 0 && lo.shooting == estimation::Shooting::kMultiple)
    throw std::invalid_argument(
        "--lsq-horizon: only for --shooting single (multiple shooting's segments are short "
        "already)");
  lo.horizon_samples = o.lsq_horizon;
  if (o.lsq_horizon_growth) lo.horizon_growth = *o.lsq_horizon_growth;
  if (!o.jacobian.empty()) lo.jacobian = estimation::ParseLeastSquaresJacobian(o.jacobian);
  if (!o.lsq_std_errors.empty())
    lo.std_errors = estimation::ParseLeastSquaresStdErrors(o.lsq_std_errors);
  if (!o.lsq_episode_restarts.empty()) lo.episode_restarts = o.lsq_episode_restarts == "on";
  lo.progress = ProgressPrinter(o);
  if (!o.quiet) {
    lo.horizon_progress = [&o](int horizon, const estimation::EstimateResult& fit,
                               const std::vector<int>& discarded) {
      std::ostringstream line;
      line.precision(8);
      line << "horizon " << horizon << " samples fitted:";
      for (size_t i = 0; i < o.params.size(); ++i)
        line << "  " << o.params[i] << " " << fit.estimates[static_cast<Eigen::Index>(i)];
      line << "  residual sigma " << fit.sigma_residual << " m";
      if (!discarded.empty()) {
        line << "  discarded (the residuals contradict --noise; approached in smaller steps):";
        for (int e : discarded) line << " " << fit.episodes[static_cast<size_t>(e)].file;
      }
      std::cerr << line.str() << "\n";
    };
  }
  return estimation::EstimateLeastSquares(simulator, log, lo);
}

// --method filter: the augmented-state unscented Kalman filter.
estimation::EstimateResult RunFilter(const EstimateOptions& o, const sim::Simulator& simulator,
                                     const estimation::Log& log) {
  if (o.fixed_initial_state || o.shooting != "single")
    throw std::invalid_argument(
        "--method filter: --fixed-initial-state and --shooting apply to lsq only");
  estimation::FilterOptions fo;
  fo.params = o.params;
  fo.noise_sigma = o.noise;
  const auto print = ProgressPrinter(o);
  if (print) {
    fo.progress = [print](int sample, const sim::VectorXd& p) {
      if (sample % 50 == 0) print(sample, std::nan(""), p);
    };
  }
  return estimation::EstimateFilter(simulator, log, fo);
}

}  // namespace

std::string HoldoutJson(const EstimateOptions& o, const estimation::HoldoutResult& holdout) {
  std::ostringstream j;
  j << "      \"holdout_error\": {\"k\": " << o.holdout << ", \"episodes\": [";
  for (size_t e = 0; e < holdout.files.size(); ++e)
    j << (e ? ", " : "") << JsonString(holdout.files[e]);
  j << "],\n        \"fitted\": " << ErrorJson(holdout.fitted)
    << ",\n        \"stationary\": " << ErrorJson(holdout.stationary)
    << ",\n        \"initial_guess\": " << ErrorJson(holdout.initial_guess) << "},\n";
  return j.str();
}

std::string HoldoutSummary(const estimation::HoldoutResult& holdout) {
  std::ostringstream s;
  s.precision(6);
  s << "hold-out rollout error (" << holdout.files.size() << " episodes): fitted "
    << holdout.fitted.position_m << " m (" << holdout.fitted.position_percent << " %), stationary "
    << holdout.stationary.position_m << " m, initial guess " << holdout.initial_guess.position_m
    << " m\n";
  return s.str();
}

void CheckOutWritable(const std::string& path) {
  std::ofstream test(path, std::ios::app);
  if (!test) throw std::invalid_argument("--out: cannot open '" + path + "' for writing");
}

void WriteOut(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::out | std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::invalid_argument("--out: writing '" + path + "' failed");
}

std::unique_ptr<estimation::HoldoutResult> FittedHoldout(const EstimateOptions& o,
                                                         const sim::Simulator& simulator,
                                                         const std::vector<std::string>& names,
                                                         const sim::VectorXd& estimates,
                                                         const estimation::Log& held_out) {
  if (o.holdout <= 0) return nullptr;
  const sim::ParamSelection sel(simulator.scene().param_table(), names);
  return std::make_unique<estimation::HoldoutResult>(estimation::EvaluateHoldout(
      simulator, sel.Set(simulator.DefaultParams(), estimates), held_out));
}

std::string EstimateLines(const std::vector<std::string>& names, const sim::VectorXd& estimates,
                          const sim::VectorXd& std_errors, const sim::VectorXd& initial_values) {
  std::ostringstream s;
  s.precision(6);
  for (size_t i = 0; i < names.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    s << names[i] << " = " << estimates[k] << " ± " << std_errors[k] << " (from "
      << initial_values[k] << ")\n";
  }
  for (size_t i = 0; i < names.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    if (std::isfinite(std_errors[k]) && std_errors[k] > std::abs(estimates[k])) {
      const bool mass = names[i].rfind("mass.", 0) == 0;
      s << "warning: " << names[i]
        << " is not determined by these logs (its standard error exceeds its value): the "
           "logged motion hardly depends on it ("
        << (mass ? "e.g. a body moved only by gravity and its contacts, whose forces all scale "
                   "with its mass"
                 : "e.g. a contact that never slides, a part that rolls without slipping, or "
                   "friction that only scales a quasistatic limit surface")
        << ")\n";
    }
  }
  return s.str();
}

std::string PoorEpisodesLine(const std::vector<estimation::EpisodeEstimate>& episodes) {
  double median = 0.0;
  const std::vector<int> poor = estimation::PoorlyFittingEpisodes(episodes, 3.0, &median);
  if (poor.empty()) return "";
  std::ostringstream s;
  s.precision(3);
  s << "episodes fitting far worse than the others (rms residual, typical " << median << " m):";
  for (const int e : poor) {
    const estimation::EpisodeEstimate& ep = episodes[static_cast<std::size_t>(e)];
    s << " " << ep.file << " " << ep.rms_residual << " m";
  }
  s << " — a wrong local solution, a log problem or another model: look at them, or estimate "
       "without them\n";
  return s.str();
}

ExitCode RunEstimateCommand(const EstimateOptions& o) {
  if (o.holdout < 0 || o.holdout == 1)
    throw std::invalid_argument("--holdout " + std::to_string(o.holdout) +
                                ": expected K ≥ 2 (every K-th episode is held out)");
  if (o.bootstrap < 0 || o.bootstrap == 1)
    throw std::invalid_argument("--bootstrap " + std::to_string(o.bootstrap) +
                                ": expected B ≥ 2 resamples (0: off)");
  if (o.bootstrap > 0 && o.method != "mpec")
    throw std::invalid_argument(
        "--bootstrap: only for --method mpec (lsq and filter report "
        "linearized standard errors)");
  if (o.mpec_substeps >= 0 && o.method != "mpec")
    throw std::invalid_argument("--mpec-substeps: only for --method mpec");
  if (o.complementarity_tolerance && o.method != "mpec")
    throw std::invalid_argument("--complementarity-tolerance: only for --method mpec");
  if (!o.mpec_episodes.empty() && o.method != "mpec")
    throw std::invalid_argument("--mpec-episodes: only for --method mpec");
  if (!o.mpec_ordering.empty() && o.method != "mpec")
    throw std::invalid_argument("--mpec-ordering: only for --method mpec");
  if (!o.mpec_start.empty() && o.method != "mpec")
    throw std::invalid_argument("--mpec-start: only for --method mpec");
  if (!o.jacobian.empty() && o.method != "lsq")
    throw std::invalid_argument("--jacobian: only for --method lsq");
  if (!o.lsq_std_errors.empty() && o.method != "lsq")
    throw std::invalid_argument("--lsq-std-errors: only for --method lsq");
  if (!o.lsq_episode_restarts.empty() && o.method != "lsq")
    throw std::invalid_argument("--lsq-episode-restarts: only for --method lsq");
  if (!o.lsq_episode_restarts.empty() && o.lsq_episode_restarts != "on" &&
      o.lsq_episode_restarts != "off")
    throw std::invalid_argument("--lsq-episode-restarts '" + o.lsq_episode_restarts +
                                "': expected on or off");
  if ((o.lsq_horizon != 0 || o.lsq_horizon_growth) && o.method != "lsq")
    throw std::invalid_argument("--lsq-horizon, --lsq-horizon-growth: only for --method lsq");
  if (o.lsq_horizon_growth && o.lsq_horizon == 0)
    throw std::invalid_argument("--lsq-horizon-growth: only with --lsq-horizon H");
  if (o.lsq_horizon == 1)
    throw std::invalid_argument("--lsq-horizon 1: expected 0 (the whole log at once) or H ≥ 2");
  if (o.lsq_horizon_growth && !(*o.lsq_horizon_growth > 1 && *o.lsq_horizon_growth <= 16))
    throw std::invalid_argument("--lsq-horizon-growth: expected 1 < G ≤ 16");
  if (o.method == "mpec") return RunEstimateMpec(o);
  if (o.method != "lsq" && o.method != "filter")
    throw std::invalid_argument("--method " + o.method + ": expected lsq, mpec or filter");
  if (o.noise < 0 || !std::isfinite(o.noise))
    throw std::invalid_argument("--noise: expected a finite σ ≥ 0 in m");
  // Check that the output can be written before the work.
  CheckOutWritable(o.out);
  const sim::Simulator simulator(sim::LoadSceneFile(o.scene_path));
  const estimation::Log all = estimation::ReadLog(o.logs, simulator.scene());
  estimation::Log log = all, held_out;
  if (o.holdout > 0) estimation::SplitHoldout(all, o.holdout, &log, &held_out);
  if (!o.quiet) {
    std::cerr << "vinci estimate: " << o.method << ", " << log.episodes.size()
              << " episode(s) fitted";
    if (o.holdout > 0) std::cerr << ", " << held_out.episodes.size() << " held out";
    std::cerr << ", " << o.params.size() << " parameter(s)" << std::endl;
  }
  const estimation::EstimateResult r =
      o.method == "filter" ? RunFilter(o, simulator, log) : RunLeastSquares(o, simulator, log);
  const std::unique_ptr<estimation::HoldoutResult> holdout =
      FittedHoldout(o, simulator, r.names, r.estimates, held_out);
  WriteOut(o.out, ResultJson(o, r, holdout.get()));
  if (!o.quiet) {
    std::ostringstream s;
    s.precision(6);
    s << EstimateLines(r.names, r.estimates, r.std_errors, r.initial_values);
    if (r.std_error_method == "profile") {
      s << "standard errors from the cost's profile; Δχ² ≤ 9 interval and linearized s.e.:";
      for (size_t i = 0; i < r.names.size(); ++i) {
        const auto k = static_cast<Eigen::Index>(i);
        s << "  " << r.names[i] << " [" << r.profile_low[k] << ", " << r.profile_high[k] << "] "
          << r.linearized_std_errors[k];
      }
      s << "\n";
    }
    s << "iterations " << r.iterations << ", " << r.time_s << " s, "
      << (r.converged ? "converged" : "did not converge") << ": " << r.reason << "\n";
    s << PoorEpisodesLine(r.episodes);
    if (holdout) s << HoldoutSummary(*holdout);
    s << "result      " << o.out << "\n";
    std::cout << s.str() << std::flush;
  }
  if (!r.converged) {
    PrintError("the estimator did not converge (" + r.reason + "); the result in '" + o.out +
               "' is the last iterate");
    return ExitCode::kSolveFailed;
  }
  return ExitCode::kOk;
}

Command RegisterEstimateCommand(CLI::App& app) {
  auto options = std::make_shared<EstimateOptions>();
  CLI::App* sub = app.add_subcommand(
      "estimate", "Estimate scene parameters (friction, masses) from logged trajectories");
  sub->add_option("SCENE", options->scene_path, "Scene file (YAML, see docs/scene-format.md)")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("LOGS", options->logs,
                  "Log files (CSV with the columns of `vinci simulate --out`), one episode each")
      ->required()
      ->check(CLI::ExistingFile);
  sub->add_option("--param,-p", options->params,
                  "A parameter to estimate (repeat for several): a differentiable entry of the "
                  "scene's parameter table, e.g. mu.default, mu.<a>.<b>, support_mu.<body>, "
                  "mass.<body>; its start value is the scene's")
      ->required()
      ->type_name("NAME");
  sub->add_option("--method", options->method,
                  "Estimator: lsq (least squares with the simulator in the loop, Ceres; "
                  "default), mpec (the MPEC non-recursive filter, Ipopt) or filter "
                  "(augmented-state unscented Kalman filter)")
      ->type_name("NAME");
  sub->add_option("--complementarity", options->complementarity,
                  "mpec: scholtes (relaxation homotopy x∘y ≤ ε, ε → 1e-8) or penalty (ℓ1)")
      ->type_name("NAME");
  sub->add_option_function<double>(
         "--complementarity-tolerance",
         [options](const double& tol) { options->complementarity_tolerance = tol; },
         "mpec: converged when every pair's max |min(x_a, x_b)| is at most TOL (the "
         "solver's scaled unknowns; default 1e-6); with --mpec-episodes decomposed, "
         "every episode's at the estimate")
      ->type_name("TOL");
  sub->add_option("--process-noise", options->process_noise,
                  "mpec: process noise σ_Q of each generalized force (N, N·m; default 1% of the "
                  "lightest dynamic body's weight)")
      ->type_name("SIGMA");
  sub->add_option("--mpec-substeps", options->mpec_substeps,
                  "mpec: steps per log interval (default 0: the scene's dt, the simulator's "
                  "grid; 1: one step per sample, a smaller problem with the coarser step's model "
                  "error, docs/estimation.md)")
      ->type_name("N");
  sub->add_option("--mpec-episodes", options->mpec_episodes,
                  "mpec: joint (one NLP over all episodes; default) or decomposed (a profile "
                  "over the shared parameters: each episode's NLP at fixed θ, Newton steps on θ; "
                  "docs/estimation.md)")
      ->type_name("joint|decomposed");
  sub->add_option("--mpec-ordering", options->mpec_ordering,
                  "mpec: MUMPS' fill-reducing ordering: auto (default: scotch, or qamd where "
                  "MUMPS' analysis predicts scotch's factorization 100x dearer: e.g. six or more "
                  "particles, or four or more log files, sharing the parameters; "
                  "docs/estimation.md), scotch or qamd")
      ->type_name("auto|scotch|qamd");
  sub->add_option("--mpec-start", options->mpec_start,
                  "mpec: the initial guess: auto (default: lsq with --noise, the scholtes "
                  "homotopy and joint episodes, else log), log (the logged poses, smoothed; the "
                  "relaxation homotopy from there) or lsq (a rough least-squares fit over a "
                  "growing horizon, fitted again carefully if its residuals contradict --noise, "
                  "its rollout as the guess, and that rollout's contact modes "
                  "solved as one NLP, kept if its χ² fits --noise and every parameter's standard "
                  "error is within 3 % of its value, else the log start; needs --noise; several "
                  "times faster on noisy logs; docs/estimation.md)")
      ->type_name("auto|log|lsq");
  sub->add_option("--shooting", options->shooting,
                  "lsq: single (one rollout per episode; default) or multiple (segments of "
                  "--segment-samples samples from their own start states, with continuity)")
      ->type_name("single|multiple");
  sub->add_option("--segment-samples", options->segment_samples,
                  "lsq --shooting multiple: logged samples per segment (default 20)")
      ->type_name("N")
      ->check(CLI::Range(2, 1000000));
  sub->add_option("--lsq-horizon", options->lsq_horizon,
                  "lsq single shooting: fit each log's first H samples, then a growing horizon "
                  "(x --lsq-horizon-growth each time) up to the whole log, each fit started "
                  "from the last (its parameters line-searched first): for bodies that tumble "
                  "or bounce, whose long rollouts stop a fit in local minima; with --noise and "
                  "one log, a fit that loses its agreement with the noise is discarded and its "
                  "horizon approached in halved steps (0, default: the whole log at once)")
      ->type_name("H")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--lsq-horizon-growth", options->lsq_horizon_growth,
                  "lsq --lsq-horizon: the horizon's growth factor per fit, in (1, 16] "
                  "(default 1.2)")
      ->type_name("G");
  sub->add_option("--jacobian", options->jacobian,
                  "lsq: how the residuals' Jacobians are computed: fd (central differences of "
                  "rollouts; default) or sensitivity (forward step sensitivities along each "
                  "rollout, experimental: see docs/estimation.md)")
      ->type_name("fd|sensitivity");
  sub->add_option("--lsq-episode-restarts", options->lsq_episode_restarts,
                  "lsq with several logs, single shooting and --noise: on (default) fits each "
                  "log whose residuals contradict the noise alone, then at the joint estimate, "
                  "and refits all logs from those initial states, kept if cheaper; off: the "
                  "joint fit only (docs/estimation.md)")
      ->type_name("on|off");
  sub->add_option("--lsq-std-errors", options->lsq_std_errors,
                  "lsq: linearized (the Gauss-Newton covariance at the solution; default) or "
                  "profile (the cost's profile in each parameter, the others and the initial "
                  "states fitted again: the interval where it rises by 9 sigma^2 / 2, its wider "
                  "side / 3; for logs that stick and slip, where the cost has kinks in mu; 4-8 "
                  "extra fits per parameter; docs/estimation.md)")
      ->type_name("linearized|profile")
      ->check(CLI::IsMember({"linearized", "profile"}));
  sub->add_option("--bootstrap", options->bootstrap,
                  "mpec: standard errors from B bootstrap resamples of the episodes (log files; "
                  "at least 2 fitted) instead of the reduced Hessian")
      ->type_name("B");
  sub->add_option("--holdout", options->holdout,
                  "Keep every K-th log file out of the fit and report the fitted model's "
                  "rollout error on them next to two baselines (holdout_error; every method)")
      ->type_name("K");
  sub->add_option("--noise", options->noise,
                  "Measurement noise σ of the logged positions in m for the standard errors "
                  "(default: estimated from the residuals)")
      ->type_name("SIGMA");
  sub->add_option("--threads,-j", options->threads,
                  "Threads (default 1): lsq evaluates episodes and segments in parallel, and "
                  "with fewer of them than threads each one's finite-difference columns; mpec "
                  "steps; mpec with --mpec-episodes decomposed solves episodes in N worker "
                  "processes. Results are the same for any N")
      ->type_name("N")
      ->check(CLI::PositiveNumber);
  sub->add_option("--max-iterations", options->max_iterations,
                  "Solver iterations at most: lsq Ceres iterations (default 100; per fit with "
                  "--lsq-horizon), mpec Ipopt "
                  "iterations per NLP (default 3000); the filter has none")
      ->type_name("N")
      ->check(CLI::PositiveNumber);
  sub->add_flag("--fixed-initial-state", options->fixed_initial_state,
                "Take each episode's initial state from its first sample (logged velocity or "
                "a finite difference) instead of estimating it");
  sub->add_option("--out,-o", options->out, "Result file (JSON)")->required()->type_name("FILE");
  sub->add_flag("--quiet,-q", options->quiet, "Print nothing but errors");
  sub->footer(
      "result.json: {scene, logs, methods: {lsq|mpec|filter: {estimates, std_errors, "
      "initial_values, iterations, time_s, converged, reason, sigma, holdout_error, ...}}}.\nExit "
      "0 converged, 1 bad input, 3 "
      "did not converge (the result is still written).");
  return Command{sub, [options] { return RunEstimateCommand(*options); }};
}

}  // namespace vinci::cli
