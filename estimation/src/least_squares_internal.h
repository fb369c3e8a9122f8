// Least squares (least_squares.cc) internals shared with its covariance
// (least_squares_covariance.cc), its growing horizon (least_squares_horizon.cc) and its profile
// standard errors (least_squares_profile.cc): one fit, the segment derivatives, the information
// about θ, the thread-safe logs of the segment evaluations. Private to vinci::estimation.
#pragma once

#include <atomic>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/params.h"
#include "vinci/sim/types.h"

namespace vinci::estimation::internal {

/// Throws std::invalid_argument (CheckEnoughSamples) if `log` has fewer residuals than the fit's
/// unknowns: the parameters and, unless held, each episode's initial state.
void CheckEnoughSamplesForFit(const sim::Simulator& simulator, const Log& log,
                              const LeastSquaresOptions& options, int num_params);

/// One least-squares fit of the whole `log` (least_squares.cc). theta_start: θ's starting values
/// (empty: the scene's). *first_states: each episode's first-segment state unknowns to start
/// from (empty: guessed from the log); on return, the solution's. `held`: indices of θ held at
/// theta_start.
EstimateResult Fit(const sim::Simulator& simulator, const Log& log,
                   const LeastSquaresOptions& options, const sim::VectorXd& theta_start,
                   std::vector<sim::VectorXd>* first_states, const std::vector<int>& held = {});

/// options.horizon_samples > 0: the growing-horizon continuation (LeastSquaresOptions::
/// horizon_samples; least_squares_horizon.cc). Returns the whole log's fit with the iterations
/// and horizons of all fits; *final_states: its initial states (Fit's). `held_theta` non-null:
/// θ is held at *held_theta in every fit (no scan), only the initial states are fitted.
EstimateResult FitGrowingHorizon(const sim::Simulator& simulator, const Log& log,
                                 const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                                 std::vector<sim::VectorXd>* final_states,
                                 const sim::VectorXd* held_theta = nullptr);

/// LeastSquaresOptions::episode_restarts (least_squares_restart.cc): after a fit *r of several
/// episodes by single shooting with a stated σ, from its initial states *states, each episode
/// whose residuals contradict the noise is fitted alone (θ free, the options' horizon), then
/// with θ held at r's θ̂ from that fit's initial state, and (with a horizon) alone over the
/// growing horizon with θ held at r's θ̂ throughout; where the better of these fits the episode
/// better than *r did, its initial state replaces *r's and the whole log is fitted again from
/// there, replacing *r and *states if cheaper. r->reason names the episodes and the outcome; the
/// iterations of every fit are added to r's.
void RestartStrayEpisodes(const sim::Simulator& simulator, const Log& log,
                          const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                          std::vector<sim::VectorXd>* states, EstimateResult* r);

/// LeastSquaresStdErrors::kProfile (least_squares_profile.cc): replaces r's standard errors by
/// the profile's, keeping the linearized ones and the Δχ² ≤ 9 intervals in r. `states`: the
/// solution's initial states.
void ProfileStdErrors(const sim::Simulator& simulator, const Log& log,
                      const LeastSquaresOptions& options, const sim::ParamSelection& sel,
                      const std::vector<sim::VectorXd>& states, EstimateResult* r);

// Derivatives of one shooting segment's rollout: its measured residuals and its end state (the
// next segment's start state coordinates) with respect to θ and its own start state s_j.
struct SegmentDerivatives {
  sim::MatrixXd measured_theta, measured_state;  // measured rows × θ, × s_j
  sim::MatrixXd end_theta, end_state;            // empty for an episode's last segment
};

/// The information about θ of one episode (the Schur complement that profiles out its free
/// initial-state components; least_squares_covariance.cc).
sim::MatrixXd EpisodeInformation(const std::vector<SegmentDerivatives>& chain,
                                 const std::vector<bool>& is_free);

/// The diagonal of the inverse of a parameter information matrix; false if it is singular (a
/// parameter the data do not determine), judged on its correlation form.
bool ParameterVariances(const sim::MatrixXd& information, sim::VectorXd* variances);

// Events of segment evaluations (failures, fallbacks), counted, with one reported: the first
// by evaluation pass, then by segment, so that the message does not depend on which thread got
// there first. Record is thread-safe; NextPass is called between passes only.
class OrderedLog {
 public:
  void NextPass() { ++pass_; }
  void Record(int segment, const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::pair<long, int> key(pass_, segment);
    if (count_++ == 0 || key < first_key_) {
      first_key_ = key;
      first_ = what;
    }
  }
  int count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }
  std::string first() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return first_;
  }
  /// "N evaluation(s) failed, first: ..." or "" (as internal::FailureLog).
  std::string Summary() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count_ == 0) return "";
    return std::to_string(count_) + " evaluation(s) failed, first: " + first_;
  }

 private:
  mutable std::mutex mutex_;
  long pass_ = 0;
  int count_ = 0;
  std::pair<long, int> first_key_;
  std::string first_;
};

// How the segments' Jacobians were obtained (shared by all segments; thread-safe).
class JacobianStats {
 public:
  explicit JacobianStats(bool use_sensitivity)
      : sensitivity(use_sensitivity), active_(use_sensitivity) {}
  /// Step sensitivities still possible (false: finite differences; cleared by Unsupported).
  std::atomic<bool> sensitivity;
  /// Whether segment evaluations try the step sensitivities: `sensitivity` as of the last
  /// Sync(), so that all segments of one (parallel) evaluation pass take the same path whatever
  /// their order.
  bool active() const { return active_; }
  /// Call between evaluation passes only (not while segments are being evaluated).
  void Sync() {
    active_ = sensitivity.load();
    unsupported_.NextPass();
    fallbacks_.NextPass();
  }
  void Unsupported(int segment, const std::string& why) {
    sensitivity = false;
    unsupported_.Record(segment, why);
  }
  void Fallback(int segment, const std::string& why) { fallbacks_.Record(segment, why); }
  void Count(int degenerate, int mode_change) {
    std::lock_guard<std::mutex> lock(mutex_);
    degenerate_ += degenerate;
    mode_change_ += mode_change;
  }
  void Report(EstimateResult* r) const {
    std::lock_guard<std::mutex> lock(mutex_);
    r->jacobian = sensitivity ? "sensitivity" : "fd";
    r->jacobian_note = unsupported_.count() > 0 ? "no step sensitivities (" + unsupported_.first() +
                                                      "): finite differences"
                                                : "";
    const int fallbacks = fallbacks_.count();
    if (fallbacks > 0)
      r->jacobian_note += (r->jacobian_note.empty() ? "" : "; ") + std::to_string(fallbacks) +
                          " evaluation(s) by finite differences, first: " + fallbacks_.first();
    r->jacobian_fallbacks = fallbacks;
    r->degenerate_steps = degenerate_;
    r->mode_change_steps = mode_change_;
  }

 private:
  mutable std::mutex mutex_;
  OrderedLog unsupported_, fallbacks_;
  bool active_;
  long long degenerate_ = 0, mode_change_ = 0;
};

}  // namespace vinci::estimation::internal
