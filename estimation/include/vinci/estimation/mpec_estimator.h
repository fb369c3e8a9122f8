// The MPEC non-recursive filter (thesis chapter 7; docs/estimation.md, method mpec): scene
// parameters, states, contact impulses and process noise estimated together from logged poses,
// with the formulation's own step equations as constraints, solved by Ipopt (mpec.h).
//
// Time grid of an episode: its log times t_0 < … < t_n, each interval [t_i, t_i+1] divided
// into n_i = max(1, round((t_i+1 − t_i)/dt)) steps of h_i = (t_i+1 − t_i)/n_i (dt the scene's;
// h_i = dt exactly when |h_i − dt| ≤ 1e-9 dt, so a log written every k-th step of a simulation
// has the simulator's own grid), or, with MpecOptions::substeps = N ≥ 1, n_i = N. Node ℓ has the
// state x_ℓ = (q_ℓ, ν_ℓ) of all dynamic bodies.
//
// Unknowns: θ (the chosen ParamTable entries: friction coefficients, support friction, masses,
// within their table bounds), per episode x_0, and per step ℓ its step unknowns z_ℓ (the
// formulation's StepLayout: q_ℓ+1, ν_ℓ+1 — so z_ℓ's head IS the next state — impulses, …), the
// process noise w_ℓ (a generalized force, N / N·m, the step input u), and slacks s = c(·) ≥ 0 for
// complementarity rows that are not a single unknown.
//
//   min  Σ_samples ‖y_i − h(q_ℓ(i))‖² / σ_R²  +  Σ_ℓ ‖w_ℓ‖² / σ_Q²
//   s.t. for every step ℓ, the frozen step model (sim/formulations/step_model.h) at
//        (z_ℓ, θ, x_ℓ, u = w_ℓ):  equality = 0,  0 ≤ comp_a ⊥ comp_b ≥ 0;
//        spatial scenes: ‖quaternion of x_0‖ = 1 per dynamic body
//
// h(q): the observed dynamic bodies' positions and, where logged, orientations times
// orientation_length (planar: θ − θ_y; spatial: 2 vec(q̄_y ⊗ q), the rotation vector to first
// order, linear in q). All residuals are linear in the unknowns.
//
// The contact set of every step is frozen at the initial guess (StepModel, Freeze): contacts
// found at the measured poses, within the envelope plus contact_margin (3 σ_R by default), stay
// candidate contacts (p_n may vanish) and no other contact can appear. The initial guess: measured
// poses (linear interpolation between samples; quaternions slerped), velocities by backward
// differences (ν_ℓ+1 = (q_ℓ+1 − q_ℓ)/h, the step's kinematics), impulses from one simulator step
// from each guessed state (then the next state overwritten by the guess), w = 0, θ the scene's
// values. Unobserved dynamic bodies start at the scene's initial state.
//
// Standard errors: the Laplace approximation at the solution, from the solution alone. With the
// zero side of every complementarity pair (ClassifyPairs: neither side of a biactive pair) and θ at
// a bound fixed, the covariance of the free unknowns is the
// upper-left block of the inverse KKT matrix [H J_Fᵀ; J_F 0], H = ½ ∇²(objective) (the Gauss–
// Newton Hessian of the negative log-likelihood, the step equations' curvature neglected), J_F
// the constraint Jacobian: the reduced-Hessian inverse Z (Zᵀ H Z)⁻¹ Zᵀ. Without a stated σ_R the
// fit is weighted with 1 mm and σ_R estimated afterwards, σ̂² = Σ r² / (m − p) (p = parameters +
// observed initial-state components), scaling the covariance by σ̂² / (1 mm)² (σ_Q scaled along).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "vinci/estimation/least_squares.h"
#include "vinci/estimation/log.h"
#include "vinci/estimation/mpec.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation {

/// MpecSolverOptions with the homotopy start the estimator uses (epsilon_start = 1e-2), the
/// warm-started Scholtes stages ε inside their bounds
/// (MpecSolverOptions::warm_start_push_per_epsilon), the relaxation rows' curvature left out of
/// the Hessian (MpecSolverOptions::relaxation_curvature), and the early polish on after the ε =
/// 1e-4 stage, accepted if its objective (χ² with a stated σ_R) is at most the stage's value +
/// 1e-3 + 2 ε Σ λ_k (MpecSolverOptions::early_polish_rise_factor: twice the relaxation's
/// first-order rise; the stage's value is a lower bound of the MPEC's near its iterate, so the
/// polished point's χ² is within that much of the full homotopy's reach — with 1e-3 alone a
/// Δχ² of ~0.03 standard errors, with the rise term as much as the relaxation's own gain: up
/// to 5.5 on the 1 mm block's 500 samples; docs/estimation.md, "Early polish"). Without a stated
/// σ_R the objective's scale is unknown and EstimateMpec turns the early polish off. Stages that
/// stall at their value end after 5 iterations (MpecSolverOptions::stall_iterations).
inline MpecSolverOptions EstimatorSolverDefaults() {
  MpecSolverOptions o;
  o.epsilon_start = 1e-2;
  o.early_polish_epsilon = 1e-4;
  o.relaxation_curvature = false;
  o.warm_start_push_per_epsilon = 1.0;
  o.penalty_start = 10;  // ρ = 1 left products of 0.45–0.67 on noisy block logs: never an entry
  o.penalty_entry_epsilon = 1e-4;  // the entry's product bound, measured on the noisy block
  o.early_polish_tolerance = 1e-3;
  o.early_polish_rise_factor = 2.0;
  o.stall_iterations = 5;
  o.deterministic_ordering = true;  // results bitwise independent of threads and run order
  o.epsilon_floor = 1e-12;          // past a failed polish, to the tolerance's √ε
  return o;
}

/// How the episodes (log files) of a log, which share only θ, are estimated together.
enum class MpecEpisodes {
  kJoint,       ///< one NLP over θ and every episode's unknowns
  kDecomposed,  ///< a profile over θ: per-episode NLPs at fixed θ (mpec_decomposed.h)
};
/// "joint" or "decomposed".
const char* ToString(MpecEpisodes episodes);
/// Parses "joint" / "decomposed"; throws std::invalid_argument naming the value otherwise.
MpecEpisodes ParseMpecEpisodes(const std::string& name);

struct MpecOptions {
  std::vector<std::string> params;  ///< names in the scene's ParamTable, differentiable
  /// Measurement noise σ_R (m); 0: the fit is weighted with 1 mm and σ_R estimated afterwards.
  double noise_sigma = 0.0;
  /// Process noise σ_Q of each generalized-force component (N, N·m); ≤ 0: 1% of the weight
  /// m |g| of the lightest dynamic body (m if g = 0). Too large a σ_Q lets w replace friction
  /// (measured: σ_Q = 1 N on a 20 g part drove μ̂ to 0).
  double process_noise = 0.0;
  double orientation_length = 0.1;  ///< m per rad for orientation residuals
  /// Added to the scene's envelope when the contact sets are frozen at the measured poses, so
  /// that noise lifting a resting part does not drop its contacts (m); < 0: 3 σ_R (the stated
  /// σ_R, else 1 mm). 0 with a log on the scene's dt grid freezes exactly the simulator's sets.
  double contact_margin = -1.0;
  /// Steps per log interval (the time grid, file comment). 0: the scene's dt, n_i = max(1,
  /// round((t_i+1 − t_i)/dt)), which reproduces the simulator's grid for a log written every
  /// k-th step. N ≥ 1: N steps of (t_i+1 − t_i)/N per interval (1: one step per sample), a
  /// problem k/N times smaller for a log every k-th step, at the cost of the model error of the
  /// coarser step (docs/estimation.md, "Time grid").
  int substeps = 0;
  /// Initial guess of the states from the log smoothed by local quadratic fits whose width is
  /// chosen from the log's own noise (an exact log is used as is); false: the raw poses.
  bool smooth_initial_guess = true;
  /// Initial guess of the states, impulses and process noise from a simulation that tracks the
  /// guessed poses (from each state, the generalized force on the observed bodies that reaches
  /// the next guessed pose in one step, refined twice against the step's contact response), so
  /// that every step equation and complementarity pair holds exactly at the start and the frozen
  /// contact sets come from non-penetrating states; false: the guessed poses themselves (and
  /// if the first relaxation stage fails from them, the estimation restarts from the tracking
  /// guess).
  bool tracking_guess = false;
  /// The initial guess from a simulation instead of the log: θ_0 = start_theta (in params'
  /// order, clamped to the table's bounds) and per episode the model's rollout at θ_0 from
  /// start_states[e] (one per episode, at its first logged time) on the MPEC's grid, w = 0, so
  /// that every step equation and complementarity pair holds at the start (the contact sets are
  /// frozen at the rollout's states). Both empty: the log's poses (above). Set by
  /// least_squares_start.
  sim::VectorXd start_theta;
  std::vector<sim::State> start_states;
  /// With start_states and a stated noise_sigma: the first NLP is the start's active set (every
  /// pair's zero side at the guess fixed, the other ≥ 0; θ free; no homotopy), at most this
  /// many Ipopt iterations, accepted if it solves with its objective (measurements' and process
  /// noise's χ²) consistent with the stated noise (the least squares' χ² test); otherwise the
  /// estimation restarts from the log's poses. When the rollout has the solution's contact
  /// modes it converges in a few iterations (measured: 8–40 on 500-sample planar logs; 188 on a
  /// tossed cube on the simulator's 1 ms grid, 42 000 unknowns, whose start at 100 had not been
  /// accepted yet). 0, or no stated noise: the homotopy from the simulated guess.
  int start_polish_iterations = 300;
  /// The start's solution is also rejected (the estimation restarts from the log's poses) when
  /// a parameter's standard error exceeds this fraction of its magnitude (or is undefined): the
  /// rollout's contact modes are then no better determined than θ̂, and other modes fit the data
  /// as well. Measured (docs/estimation.md): 0.2–1.9 % on the block and 10 µm plate studies,
  /// where the start is the homotopy's estimate, 3.5–24 % on the 0.1 mm plate, where it is
  /// biased. +∞: no such test.
  double start_max_relative_std_error = 0.03;
  /// Start from a least-squares fit (EstimateLeastSquares: single shooting over a growing
  /// horizon, least_squares_horizon samples first, × least_squares_horizon_growth, at most
  /// least_squares_iterations iterations per fit, no horizon_refinement — a rough fit, only the
  /// start; the same parameters, noise, threads and orientation_length; if its residuals
  /// contradict the stated noise, fitted again with LeastSquaresOptions' horizon_growth,
  /// max_iterations and horizon_refinement and the cheaper fit kept): start_theta and start_states
  /// from its θ̂ and initial states. Needs a stated noise_sigma. The result's iterations (Ipopt's)
  /// and time include the fit; its reason says what the start was. Not with
  /// MpecEpisodes::kDecomposed. The result is the MPEC on the rollout's contact modes, not the
  /// homotopy's: measured (docs/estimation.md) within a standard error of it on 79 of 80 block logs
  /// and most 10 µm plate logs; where the noise is large against the motion (a plate particle at
  /// 0.1 mm) it is biased, and start_max_relative_std_error sends those logs to the homotopy.
  bool least_squares_start = false;
  /// 20: on the 500-sample block and plate logs (seeds 1–7) every rough fit agreed with the
  /// noise, where 10 left one to the careful refit (bench/README.md, session 41).
  int least_squares_iterations = 20;
  int least_squares_horizon = 10;
  double least_squares_horizon_growth = 4.0;
  int threads = 1;  ///< threads evaluating the step equations (the result is bitwise the same)
  /// Several episodes: one joint NLP, or the decomposition over episodes (EstimateMpecDecomposed
  /// in mpec_decomposed.h; with one episode both are the joint NLP).
  MpecEpisodes episodes = MpecEpisodes::kJoint;
  /// Bootstrap over episodes: with B > 0 and at least two episodes, the estimation is repeated
  /// on B resamples of the episodes (drawn with replacement, seeded by bootstrap_seed), each
  /// from the scene's values, and the standard errors are the resamples' standard deviation
  /// (std_error_method "bootstrap") instead of the Laplace approximation. 0: off.
  int bootstrap = 0;
  unsigned bootstrap_seed = 1;
  /// Complementarity method, homotopy, Ipopt settings. The Scholtes homotopy starts at ε = 1e-2
  /// here (the products are impulses per step, ~m g h ≈ 1e-2 N·s, times velocities: ε = 0.1
  /// relaxes complementarity away, and measured, took thousands of iterations in its next stage;
  /// ε = 1e-4 lets a noisy log's wrong guessed active set change only slowly, bench/README.md).
  MpecSolverOptions solver = EstimatorSolverDefaults();
  /// Progress lines (setup, each NLP). May be empty. Must not throw.
  std::function<void(const std::string&)> progress;
  /// Throws std::invalid_argument naming the first invalid field.
  void Validate() const;
};

/// EstimateResult (method "mpec") plus what the MPEC reports.
struct MpecEstimateResult : EstimateResult {
  std::string complementarity;  ///< "scholtes" or "penalty"
  /// max over steps of |min(comp_a, comp_b)| of the step equations at the solution.
  double complementarity_violation = 0.0;
  double equality_violation = 0.0;  ///< max |equality rows| at the solution
  int stages = 0;                   ///< NLPs solved
  bool polished = false;            ///< the fixed-active-set NLP gave the result
  /// The simulated start's active-set NLP gave the result (MpecOptions::start_polish_iterations);
  /// false after a restart from the log's poses, or without a simulated start.
  bool start_kept = false;
  int num_constraints = 0, num_pairs = 0, num_steps = 0;
  double process_noise = 0.0;      ///< σ_Q used
  double max_process_noise = 0.0;  ///< max |w| at the solution (N, N·m)
  /// Largest Jacobian entry dropped for falling outside the structure (0: none).
  double dropped_jacobian = 0.0;
  /// MUMPS' ordering the NLPs used ("scotch" or "qamd", MpecSolution::ordering); empty where
  /// the estimate comes from several solves that may differ (MpecEpisodes::kDecomposed).
  std::string ordering;
  /// The solver converged but the measurement residuals contradict the stated noise (Σ r² / σ²
  /// above its χ² mean by 4 standard deviations: a wrong local solution or a model mismatch,
  /// e.g. a coarse MpecOptions::substeps), so converged is false. Whenever the residuals
  /// contradict the stated noise (converged or not) the reason says so and the standard errors
  /// use σ̂ = √(Σ r² / dof) (sigma).
  bool noise_contradicted = false;
  /// "laplace" (reduced Hessian of the polished NLP), "profile" (a relaxed, unpolished
  /// iterate: the curvature of the relaxed problem's profile over θ, mpec_estimator.cc) or
  /// "bootstrap" (MpecOptions::bootstrap).
  std::string std_error_method = "laplace";
  /// Resamples used (bootstrap only): converged, or converged with residuals that contradict the
  /// stated noise (noise_contradicted).
  int bootstrap_converged = 0;
  /// The parameters' covariance (p × p, in names' order) by std_error_method: std_errors are
  /// the square roots of its diagonal. NaN rows and columns where there is none (a θ at a
  /// bound, a failed covariance).
  sim::MatrixXd covariance;
  /// Standard errors from the episodes' scatter: the delta-method jackknife over episodes, from
  /// each episode's gradient and curvature of its χ² at θ̂ (MpecEpisodes::kDecomposed with ≥ 2
  /// episodes; NaN otherwise; mpec_outer.h): close to std_errors when the model is right, larger
  /// when the episodes disagree beyond their own errors (model error). Meaningful with several
  /// episodes (≳ 10).
  sim::VectorXd robust_std_errors;
};

/// The MPEC of a log (for EstimateMpec, tests and tools). Not thread-safe (evaluation caches).
class MpecEstimationProblem final : public MpecProblem {
 public:
  /// Builds the grid, the frozen step models and the initial guess. `sigma` is σ_R used in the
  /// objective. Throws std::invalid_argument for invalid options, an unknown or
  /// non-differentiable parameter, a formulation whose step unknowns do not start with the next
  /// state (GI), or too few samples.
  MpecEstimationProblem(const sim::Simulator& simulator, const Log& log, const MpecOptions& options,
                        double sigma);
  ~MpecEstimationProblem() override;

  int num_variables() const override;
  int num_constraints() const override;
  void Bounds(sim::VectorXd* x_l, sim::VectorXd* x_u, sim::VectorXd* g_l,
              sim::VectorXd* g_u) const override;
  sim::VectorXd StartingPoint() const override;
  std::vector<std::pair<int, int>> ComplementarityPairs() const override;
  bool Objective(const sim::VectorXd& x, double* f) const override;
  bool Gradient(const sim::VectorXd& x, sim::VectorXd* grad) const override;
  bool Constraints(const sim::VectorXd& x, sim::VectorXd* g) const override;
  std::vector<Entry> JacobianStructure() const override;
  bool JacobianValues(const sim::VectorXd& x, sim::VectorXd* values) const override;
  bool has_hessian() const override { return true; }
  /// The objective's Hessian (exact, constant) and the quaternion-norm rows'; the step
  /// equations' curvature is neglected (Gauss–Newton: exact at a zero-residual solution, where
  /// their multipliers vanish).
  std::vector<Entry> HessianStructure() const override;
  bool HessianValues(const sim::VectorXd& x, double obj_factor, const sim::VectorXd& lambda,
                     sim::VectorXd* values) const override;

  int num_steps() const;
  int num_residuals() const;
  double process_noise() const;  ///< σ_Q used (N, N·m)
  /// The largest |entry| of a step's Jacobian that fell outside the fixed structure (the union
  /// of the entries at the guess and four perturbed points) and was dropped, over all
  /// evaluations so far.
  double dropped_jacobian() const;
  /// The chosen parameters' values in x.
  sim::VectorXd Parameters(const sim::VectorXd& x) const;
  /// The state at an episode's first node.
  sim::State InitialState(const sim::VectorXd& x, int episode) const;
  /// Σ r² (m²) of the measurement residuals and Σ per episode; max |w|.
  double SquaredResiduals(const sim::VectorXd& x, std::vector<double>* per_episode = nullptr,
                          double* max_w = nullptr) const;
  /// max |equality| and max |min(comp_a, comp_b)| of all steps' frozen equations at x.
  void StepViolation(const sim::VectorXd& x, double* equality, double* complementarity) const;
  /// The unknowns of an exact solution: per episode a rollout whose states include every grid
  /// node (matched by time to 1e-9 s), mapped by StepModel::UnknownsFromStep, w = 0, slacks =
  /// their rows, θ = params' chosen entries. Throws std::invalid_argument if a node has no state.
  sim::VectorXd VariablesFromRollouts(const std::vector<sim::Trajectory>& rollouts,
                                      const sim::Params& params) const;
  /// How the Laplace approximation treats a complementarity pair: the side(s) held at zero.
  enum class PairTreatment : char { kFirstZero, kSecondZero, kBothZero, kFree };
  /// The treatment of every pair (in ComplementarityPairs() order) at the solution x, from x
  /// alone (see the file comment): a side is zero when at most `zero_tolerance` in the solver's
  /// scaled unknowns; one side zero: that side held (strictly active); both zero (biactive):
  /// kFree (neither held: holding both can pin θ); neither zero (a relaxed, unpolished
  /// iterate): the smaller side held.
  std::vector<PairTreatment> ClassifyPairs(const sim::VectorXd& x, double zero_tolerance) const;
  /// Variances of the chosen parameters at x (the Laplace approximation of the file comment,
  /// in σ_R units of the objective) with the pairs treated as `treatment`; θ at a bound is
  /// held. false if the KKT matrix is singular.
  bool ParameterVariances(const sim::VectorXd& x, const std::vector<PairTreatment>& treatment,
                          sim::VectorXd* variances) const;
  /// The chosen parameters' covariance matrix at x (as ParameterVariances; rows and columns of
  /// a held θ are NaN). false if the KKT matrix is singular.
  bool ParameterCovariance(const sim::VectorXd& x, const std::vector<PairTreatment>& treatment,
                           sim::MatrixXd* covariance) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Runs the MPEC estimator. Throws std::invalid_argument for bad input (as the problem's
/// constructor); numerical trouble (Ipopt failure, complementarity not reached) is reported in
/// the result (converged = false, reason).
MpecEstimateResult EstimateMpec(const sim::Simulator& simulator, const Log& log,
                                const MpecOptions& options);

}  // namespace vinci::estimation
