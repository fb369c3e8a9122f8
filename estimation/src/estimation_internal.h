// Shared internals of the estimators (least squares single and multiple shooting, the
// unscented filter, hold-out validation): the state unknowns of observed bodies, the log's
// initial-state guess, rollouts against logged samples. Not installed.
#pragma once

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "vinci/estimation/log.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation::internal {

// Runs f(0), ..., f(n − 1) on up to `threads` threads (indices handed out dynamically; each f(i)
// must write only its own outputs, so the results do not depend on the thread count).
template <typename F>
void ParallelFor(int n, int threads, const F& f) {
  const int workers = std::min(threads, n);
  if (workers <= 1) {
    for (int i = 0; i < n; ++i) f(i);
    return;
  }
  std::atomic<int> next{0};
  auto work = [&] {
    for (int i = next++; i < n; i = next++) f(i);
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < workers; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
}

bool Planar(const sim::Simulator& s);
/// Unknowns per observed dynamic body: planar x, y, θ, vx, vy, ω; spatial p, δ, v_W, w_W.
int StateBlockSize(bool planar);
/// Observed dynamic bodies of an episode.
int ObservedDynamic(const Episode& ep);
Eigen::Quaterniond LoggedQuaternion(const BodyTrack& b, int i);
Eigen::Matrix3d Exp(const Eigen::Vector3d& w);
/// The rotation vector of q (angle ≤ π).
Eigen::Vector3d RotationLog(const Eigen::Quaterniond& q);

/// The state `ref` with the observed dynamic bodies set from the unknown vector s (blocks of
/// StateBlockSize per observed dynamic body, in track order; spatial rotation vectors δ with
/// R = exp(δ) R̂, R̂ the episode's first logged orientation, or ref's without one).
sim::State StateFromVector(const sim::Simulator& sim, const Episode& ep, const sim::State& ref,
                           const double* s);
/// The unknown vector of a state (inverse of StateFromVector).
sim::VectorXd VectorFromState(const sim::Simulator& sim, const Episode& ep, const sim::State& x);

/// The log's initial state (the scene's, with the observed dynamic bodies at the first logged
/// pose and the logged velocity or the slope at t0 of a least-squares quadratic through the
/// first samples) and, in the layout of the state unknowns, the standard error of each
/// velocity component from the fit (0 for poses, logged velocities, or no spare samples).
/// With follow_quadratic the velocity is c1 − c2 dt (quadratic c0 + c1 τ + c2 τ²), which the
/// simulator's position update (q += dt v_next) turns into a rollout following the quadratic.
sim::State GuessInitialState(const sim::Simulator& simulator, const Episode& ep,
                             sim::VectorXd* velocity_se, bool follow_quadratic = false);

/// The samples first..last (inclusive) of an episode as an episode of their own.
Episode Slice(const Episode& ep, int first, int last);

/// x without its warm start: a rollout from it (WarmStartPolicy::kKeep) solves its first step
/// cold and each next one from the last one's solution, as `vinci simulate` runs from a scene's
/// initial state, and is a function of (params, t, q, v) alone. Where a step's contact solution
/// is not unique (a cube landing flat) the solver's start picks one, so from the same state the
/// estimators' rollouts are the simulator's, to the bit; a rollout whose every step starts
/// cold can leave it by millimetres.
sim::State ColdStart(sim::State x);

/// Rolls out from ColdStart(x0) (at ep.t.front()) to ep.t.back() with the scene's dt and returns
/// the residuals at the logged times (EpisodeResiduals) and, if tr is not null, the trajectory.
/// False (with *failure) if the rollout failed.
bool RolloutResiduals(const sim::Simulator& simulator, const sim::Params& params, const Episode& ep,
                      const sim::State& x0, double orientation_length, sim::VectorXd* residuals,
                      std::string* failure, sim::Trajectory* tr);

/// The residuals (measured − simulated, as EpisodeResiduals) of sample i of `ep` for the
/// simulated states a and b bracketing its time, interpolated at fraction al; writes
/// ResidualsPerSample entries to out.
void SampleResiduals(const sim::Simulator& simulator, const Episode& ep, int i, const sim::State& a,
                     const sim::State& b, double al, double orientation_length, double* out);

/// Steps of the scene's dt from t0 to the first grid time at or after t.
int StepsTo(const sim::Simulator& simulator, double t0, double t);

/// The step k and fraction al with states[k].t ≤ t ≤ states[k+1].t (clamped to the
/// trajectory; states on a uniform grid, at least two).
void Bracket(const std::vector<sim::State>& states, double t, int* k, double* al);

/// The unknown vector (VectorFromState, references of `ep`) of the trajectory at time t,
/// interpolated linearly between the bracketing steps.
sim::VectorXd VectorAt(const sim::Simulator& sim, const Episode& ep, const sim::Trajectory& tr,
                       double t);

/// Throws std::invalid_argument "<method>: <field> = <value>, expected <expected>" (the options'
/// Validate()).
[[noreturn]] void FailOption(const std::string& method, const std::string& field, double value,
                             const std::string& expected);

/// Whether measured residuals contradict a stated noise σ > 0: ss / σ² (ss = Σ r² over dof
/// degrees of freedom) above its χ²_dof mean by 4 standard deviations (p < 1e-4). False for
/// dof ≤ 0. The least squares' and the MPEC's convergence test.
bool ResidualsContradictNoise(double ss, int dof, double sigma);

/// Throws std::invalid_argument for an unknown or non-differentiable parameter name.
void CheckDifferentiable(const sim::Scene& scene, const std::vector<std::string>& params);

class FailureLog {
 public:
  void Record(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++count_;
    if (first_.empty()) first_ = what;
  }
  std::string Summary() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count_ == 0) return "";
    return std::to_string(count_) + " evaluation(s) failed, first: " + first_;
  }

 private:
  mutable std::mutex mutex_;
  int count_ = 0;
  std::string first_;
};

}  // namespace vinci::estimation::internal
