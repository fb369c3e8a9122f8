#include "vinci/estimation/least_squares.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <utility>

#include "estimation_internal.h"
#include "least_squares_internal.h"
#include "least_squares_segment_cost.h"
#include "segment_sensitivity.h"
#include "vinci/sim/formulations/geometrically_implicit.h"
#include "vinci/sim/model/state_util.h"

namespace vinci::estimation {

using sim::Dim;
using sim::Params;
using sim::State;
using sim::VectorXd;
using namespace internal;  // NOLINT(google-build-using-namespace): this file's own helpers

void LeastSquaresOptions::Validate() const {
  auto fail = [](const std::string& field, double v, const std::string& expected) {
    FailOption("least squares", field, v, expected);
  };
  if (params.empty()) throw std::invalid_argument("least squares: no parameter to estimate");
  if (!(noise_sigma >= 0) || !std::isfinite(noise_sigma)) fail("noise", noise_sigma, "finite ≥ 0");
  if (!(orientation_length > 0) || !std::isfinite(orientation_length))
    fail("orientation_length", orientation_length, "finite > 0");
  if (threads < 1) fail("threads", threads, "≥ 1");
  if (max_iterations < 1) fail("max_iterations", max_iterations, "≥ 1");
  if (segment_samples < 2) fail("segment_samples", segment_samples, "≥ 2");
  if (horizon_samples != 0 && horizon_samples < 2)
    fail("horizon_samples", horizon_samples, "0 (off) or ≥ 2");
  if (!(horizon_growth > 1) || !(horizon_growth <= 16))
    fail("horizon_growth", horizon_growth, "in (1, 16]");
  if (horizon_samples != 0 && shooting == Shooting::kMultiple)
    throw std::invalid_argument(
        "least squares: a growing horizon (horizon_samples) is for single shooting; multiple "
        "shooting's segments are already short");
  if (std_errors == LeastSquaresStdErrors::kProfile && shooting == Shooting::kMultiple)
    throw std::invalid_argument(
        "least squares: profile standard errors are for single shooting (a profile point's fit "
        "starts from the solution's initial states; multiple shooting's segments would restart "
        "from the log)");
  if (!(continuity_weight > 0) || !std::isfinite(continuity_weight))
    fail("continuity_weight", continuity_weight, "finite > 0");
  if (shooting == Shooting::kMultiple && !estimate_initial_state)
    throw std::invalid_argument(
        "least squares: multiple shooting estimates the segments' start states; it cannot be "
        "combined with a fixed initial state");
  if (!(fd_relative_step > 0) || !(fd_relative_step < 1e-2))
    fail("fd_relative_step", fd_relative_step, "in (0, 1e-2)");
}

State InitialStateFromLog(const sim::Simulator& simulator, const Episode& ep) {
  VectorXd se;
  return GuessInitialState(simulator, ep, &se);
}

bool EpisodeResiduals(const sim::Simulator& simulator, const Params& params, const Episode& ep,
                      const State& x0, double orientation_length, VectorXd* residuals,
                      std::string* failure) {
  return RolloutResiduals(simulator, params, ep, x0, orientation_length, residuals, failure,
                          nullptr);
}

namespace {

// One segment's residuals and Jacobian blocks, evaluated by ParallelEvaluation at the point
// Ceres is about to evaluate, for SegmentCeresCost to hand over.
struct SegmentSlot {
  std::vector<double*> blocks;  // the segment's parameter blocks (user memory)
  std::vector<bool> wanted;     // blocks whose Jacobian Ceres needs (not constant)
  std::vector<VectorXd> point;  // the parameter values the slot was evaluated at
  VectorXd residuals;
  std::vector<RowMajor> jacobians;  // per block; empty if not evaluated
  bool valid = false, ok = false;

  // Whether the slot was evaluated at `params` (block b at params[b]) with the Jacobian of
  // every block b for which need_jacobian(b).
  template <class Params, class NeedJacobian>
  bool Holds(const Params& params, const std::vector<int32_t>& sizes,
             NeedJacobian need_jacobian) const {
    const int nb = static_cast<int>(sizes.size());
    if (!valid || static_cast<int>(point.size()) != nb) return false;
    for (int b = 0; b < nb; ++b) {
      if (Eigen::Map<const VectorXd>(params[b], sizes[b]) != point[b]) return false;
      if (need_jacobian(b) && jacobians[b].size() == 0) return false;
    }
    return true;
  }
};

// Determinism: Ceres with several threads sums the cost and gradient over residual blocks in
// per-thread partial sums whose partition depends on scheduling, and its Schur eliminator adds
// the blocks' outer products into the reduced system in thread order, so its iterates (and a
// fit's end point near a stick–slip kink) changed with the thread count and from run to run.
// So Ceres runs single-threaded, and the expensive part — the segment rollouts — is done here:
// before every evaluation Ceres calls PrepareForEvaluation, which evaluates all segments in
// parallel into their own slots; SegmentCeresCost then copies them in Ceres' fixed order. Every
// number Ceres sees is then a function of the point alone, whatever the thread count.
class ParallelEvaluation : public ceres::EvaluationCallback {
 public:
  ParallelEvaluation(int threads, JacobianStats* stats, OrderedLog* failures)
      : threads_(threads), stats_(stats), failures_(failures) {}
  void Add(const SegmentCost* cost, SegmentSlot* slot) {
    costs_.push_back(cost);
    slots_.push_back(slot);
  }
  /// Forget the slots (e.g. after the continuity weight changed).
  void Invalidate() {
    for (SegmentSlot* s : slots_) s->valid = false;
  }
  void PrepareForEvaluation(bool evaluate_jacobians, bool /*new_evaluation_point*/) override {
    stats_->Sync();
    failures_->NextPass();
    ParallelFor(static_cast<int>(slots_.size()), threads_,
                [&](int k) { Fill(*costs_[k], slots_[k], evaluate_jacobians); });
  }

 private:
  // A slot that already holds this point (and its Jacobians, if asked for) is kept: with bounds
  // on θ, Ceres' projected line search evaluates the trust-region step's point, then Ceres
  // evaluates it again as the candidate, then asks for its Jacobians once accepted.
  static void Fill(const SegmentCost& cost, SegmentSlot* slot, bool with_jacobians) {
    const int nb = static_cast<int>(slot->blocks.size());
    const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
    if (slot->Holds(slot->blocks, sizes, [&](int b) { return with_jacobians && slot->wanted[b]; }))
      return;
    slot->point.resize(nb);
    slot->jacobians.resize(nb);
    std::vector<const double*> params(nb);
    std::vector<double*> jac(nb, nullptr);
    for (int b = 0; b < nb; ++b) {
      slot->point[b] = Eigen::Map<const VectorXd>(slot->blocks[b], sizes[b]);
      params[b] = slot->point[b].data();
      if (with_jacobians && slot->wanted[b]) {
        slot->jacobians[b].resize(cost.num_residuals(), sizes[b]);
        jac[b] = slot->jacobians[b].data();
      } else {
        slot->jacobians[b].resize(0, 0);
      }
    }
    slot->residuals.resize(cost.num_residuals());
    slot->ok =
        cost.Evaluate(params.data(), slot->residuals.data(), with_jacobians ? jac.data() : nullptr);
    slot->valid = true;
  }

  int threads_;
  JacobianStats* stats_;
  OrderedLog* failures_;
  std::vector<const SegmentCost*> costs_;
  std::vector<SegmentSlot*> slots_;
};

// The cost function Ceres sees: the slot's values when it holds the requested point and
// Jacobians (always, during a solve), else a direct evaluation.
class SegmentCeresCost : public ceres::CostFunction {
 public:
  SegmentCeresCost(const SegmentCost* cost, const SegmentSlot* slot) : cost_(cost), slot_(slot) {
    set_num_residuals(cost->num_residuals());
    *mutable_parameter_block_sizes() = cost->parameter_block_sizes();
  }
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const int nb = static_cast<int>(parameter_block_sizes().size());
    if (!slot_->Holds(parameters, parameter_block_sizes(),
                      [&](int b) { return jacobians && jacobians[b]; }))
      return cost_->Evaluate(parameters, residuals, jacobians);
    if (!slot_->ok) return false;
    Eigen::Map<VectorXd>(residuals, num_residuals()) = slot_->residuals;
    for (int b = 0; b < nb && jacobians; ++b)
      if (jacobians[b])
        Eigen::Map<RowMajor>(jacobians[b], num_residuals(), parameter_block_sizes()[b]) =
            slot_->jacobians[b];
    return true;
  }

 private:
  const SegmentCost* cost_;
  const SegmentSlot* slot_;
};

// Forwards Ceres' iteration summaries to LeastSquaresOptions::progress.
class ProgressCallback : public ceres::IterationCallback {
 public:
  ProgressCallback(const std::function<void(int, double, const VectorXd&)>& f,
                   const VectorXd& theta)
      : f_(f), theta_(theta) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    try {
      if (f_) f_(s.iteration, s.cost, theta_);
    } catch (...) {
      // progress reporting must not end the solve
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(int, double, const VectorXd&)>& f_;
  const VectorXd& theta_;
};

// First samples of the shooting segments of an episode with n samples: every
// `segment_samples`, the last segment merged into the one before if it would have fewer than
// half as many samples. Single shooting: {0}.
std::vector<int> SegmentStarts(int n, const LeastSquaresOptions& o) {
  std::vector<int> starts = {0};
  if (o.shooting != Shooting::kMultiple) return starts;
  for (int b = o.segment_samples; b < n - 1; b += o.segment_samples) starts.push_back(b);
  if (starts.size() > 1 && (n - 1) - starts.back() < o.segment_samples / 2) starts.pop_back();
  return starts;
}

// Scale of the continuity residuals: positions 1, angles orientation_length, velocities the
// segment's duration (so every entry is in metres).
VectorXd ContinuityScale(bool planar, int bodies, double duration, const LeastSquaresOptions& o) {
  const int nb = StateBlockSize(planar);
  VectorXd c(bodies * nb);
  for (int b = 0; b < bodies; ++b) {
    if (planar)
      c.segment(b * nb, nb) << 1, 1, o.orientation_length, duration, duration,
          o.orientation_length * duration;
    else
      c.segment(b * nb, nb) << 1, 1, 1, VectorXd::Constant(3, o.orientation_length),
          VectorXd::Constant(3, duration), VectorXd::Constant(3, o.orientation_length * duration);
  }
  return c;
}

}  // namespace

const char* ToString(Shooting s) { return s == Shooting::kMultiple ? "multiple" : "single"; }

const char* ToString(LeastSquaresJacobian j) {
  return j == LeastSquaresJacobian::kFiniteDifference ? "fd" : "sensitivity";
}

const char* ToString(LeastSquaresStdErrors s) {
  return s == LeastSquaresStdErrors::kProfile ? "profile" : "linearized";
}

LeastSquaresStdErrors ParseLeastSquaresStdErrors(const std::string& name) {
  if (name == "linearized") return LeastSquaresStdErrors::kLinearized;
  if (name == "profile") return LeastSquaresStdErrors::kProfile;
  throw std::invalid_argument("--lsq-std-errors " + name + ": expected linearized or profile");
}

LeastSquaresJacobian ParseLeastSquaresJacobian(const std::string& name) {
  if (name == "sensitivity") return LeastSquaresJacobian::kSensitivity;
  if (name == "fd") return LeastSquaresJacobian::kFiniteDifference;
  throw std::invalid_argument("--jacobian " + name + ": expected sensitivity or fd");
}

bool SegmentJacobian(const sim::Simulator& simulator, const Log& log, int episode, int first,
                     int last, const VectorXd& theta, const LeastSquaresOptions& options,
                     VectorXd* s, VectorXd* residuals, sim::MatrixXd* jacobian, std::string* note) {
  options.Validate();
  CheckDifferentiable(simulator.scene(), options.params);
  if (episode < 0 || episode >= static_cast<int>(log.episodes.size()))
    throw std::invalid_argument("SegmentJacobian: episode out of range");
  const Episode& ep = log.episodes[episode];
  if (first < 0 || last <= first || last >= ep.num_samples())
    throw std::invalid_argument("SegmentJacobian: expected 0 ≤ first < last < samples");
  const sim::ParamSelection sel(simulator.scene().param_table(), options.params);
  if (theta.size() != sel.size()) throw std::invalid_argument("SegmentJacobian: theta size");
  const bool multiple = options.shooting == Shooting::kMultiple;
  const Episode tail = Slice(ep, first, ep.num_samples() - 1);
  VectorXd se;
  const State ref = GuessInitialState(simulator, tail, &se, multiple);
  if (s->size() == 0) *s = VectorFromState(simulator, tail, ref);
  const bool has_next = last < ep.num_samples() - 1;
  std::unique_ptr<Episode> next;
  VectorXd s_next;
  if (has_next) {
    next = std::make_unique<Episode>(Slice(ep, last, ep.num_samples() - 1));
    VectorXd se_next;
    s_next =
        VectorFromState(simulator, *next, GuessInitialState(simulator, *next, &se_next, multiple));
  }
  const int measured = has_next ? last - first : last - first + 1;
  const VectorXd scale =
      ContinuityScale(Planar(simulator), ObservedDynamic(ep), ep.t[last] - ep.t[first], options);
  const double weight = 1.0;
  OrderedLog failures;
  JacobianStats stats(options.jacobian == LeastSquaresJacobian::kSensitivity);
  if (stats.sensitivity &&
      dynamic_cast<const sim::GeometricallyImplicit*>(&simulator.formulation()) != nullptr)
    stats.Unsupported(0, "the geometrically implicit stepper");
  const Params base = simulator.DefaultParams();
  const SegmentCost cost(simulator, sel, base, Slice(ep, first, last), measured, ref, true, *s,
                         std::move(next), scale, &weight, options, 0, &failures, &stats);
  SegmentDerivatives sj;
  const bool ok = cost.Jacobians(theta, *s, has_next ? s_next.data() : nullptr, &sj, residuals);
  EstimateResult r;
  stats.Report(&r);
  *note = r.jacobian + (r.jacobian_note.empty() ? "" : ": " + r.jacobian_note);
  if (!ok) {
    *note += "; " + failures.Summary();
    return false;
  }
  const int np = sel.size(), ns = static_cast<int>(s->size());
  const int rows = static_cast<int>(sj.measured_theta.rows() + sj.end_theta.rows());
  jacobian->resize(rows, np + ns);
  jacobian->topLeftCorner(sj.measured_theta.rows(), np) = sj.measured_theta;
  jacobian->topRightCorner(sj.measured_theta.rows(), ns) = sj.measured_state;
  if (has_next) {
    jacobian->bottomLeftCorner(sj.end_theta.rows(), np) = scale.asDiagonal() * sj.end_theta;
    jacobian->bottomRightCorner(sj.end_theta.rows(), ns) = scale.asDiagonal() * sj.end_state;
  }
  return true;
}

namespace internal {

void CheckEnoughSamplesForFit(const sim::Simulator& simulator, const Log& log,
                              const LeastSquaresOptions& options, int num_params) {
  const int block = StateBlockSize(Planar(simulator));
  std::vector<int> own;
  for (const Episode& ep : log.episodes)
    own.push_back(options.estimate_initial_state ? ObservedDynamic(ep) * block : 0);
  // Multiple shooting adds as many continuity residuals as segment-state unknowns: the same
  // count suffices.
  CheckEnoughSamples(log, simulator.scene().dim, num_params, own);
}

EstimateResult Fit(const sim::Simulator& simulator, const Log& log,
                   const LeastSquaresOptions& options, const VectorXd& theta_start,
                   std::vector<VectorXd>* first_states, const std::vector<int>& held) {
  const auto start = std::chrono::steady_clock::now();
  const sim::Scene& scene = simulator.scene();
  const sim::ParamTable& table = scene.param_table();
  CheckDifferentiable(scene, options.params);
  if (log.episodes.empty()) throw std::invalid_argument("no log episode");
  const sim::ParamSelection sel(table, options.params);
  const bool planar = Planar(simulator);
  CheckEnoughSamplesForFit(simulator, log, options, sel.size());

  const Params base = simulator.DefaultParams();
  EstimateResult result;
  result.method = "lsq";
  result.names = options.params;
  result.initial_values = sel.Get(base);
  VectorXd theta = theta_start.size() > 0 ? theta_start : result.initial_values;
  const bool warm = !first_states->empty();
  if (warm && first_states->size() != log.episodes.size())
    throw std::logic_error("least squares: one warm start state per episode expected");

  // Segments, their starting guesses (the log's pose and quadratic-fit velocity at the
  // segment's first sample) and the velocity standard errors of those guesses.
  struct Segment {
    int episode = 0, first = 0, last = 0;  // samples first..last of the rollout
    State ref;
    VectorXd se;
  };
  std::vector<Segment> segments;
  std::vector<std::vector<int>> episode_segments(log.episodes.size());
  std::vector<VectorXd> states;  // one per segment; stable addresses after this loop
  for (size_t e = 0; e < log.episodes.size(); ++e) {
    const Episode& ep = log.episodes[e];
    const std::vector<int> starts = SegmentStarts(ep.num_samples(), options);
    for (size_t j = 0; j < starts.size(); ++j) {
      Segment s;
      s.episode = static_cast<int>(e);
      s.first = starts[j];
      s.last = j + 1 < starts.size() ? starts[j + 1] : ep.num_samples() - 1;
      const Episode slice = Slice(ep, s.first, ep.num_samples() - 1);
      s.ref = GuessInitialState(simulator, slice, &s.se, options.shooting == Shooting::kMultiple);
      states.push_back(VectorFromState(simulator, slice, s.ref));
      episode_segments[e].push_back(static_cast<int>(segments.size()));
      segments.push_back(std::move(s));
    }
  }
  result.num_segments = static_cast<int>(segments.size());
  // Later segments: velocity components the samples do not distinguish from zero start at zero
  // (see below for the first segment).
  for (size_t k = 0; k < segments.size(); ++k) {
    if (segments[k].first == 0) continue;
    for (Eigen::Index j = 0; j < states[k].size(); ++j)
      if (segments[k].se[j] > 0 && std::abs(states[k][j]) <= 3.0 * segments[k].se[j])
        states[k][j] = 0.0;
  }
  if (warm) {
    for (size_t e = 0; e < log.episodes.size(); ++e) {
      VectorXd& state = states[episode_segments[e].front()];
      if ((*first_states)[e].size() != state.size())
        throw std::logic_error("least squares: warm start state of the wrong size");
      state = (*first_states)[e];
    }
  }

  OrderedLog failures;
  JacobianStats jacobian_stats(options.jacobian == LeastSquaresJacobian::kSensitivity);
  if (jacobian_stats.sensitivity &&
      dynamic_cast<const sim::GeometricallyImplicit*>(&simulator.formulation()) != nullptr)
    jacobian_stats.Unsupported(0, "the geometrically implicit stepper");
  // Segment evaluations: in parallel, before Ceres asks for them (ParallelEvaluation).
  std::vector<std::unique_ptr<SegmentCost>> owned_costs;
  std::vector<SegmentSlot> slots(segments.size());
  ParallelEvaluation parallel(options.threads, &jacobian_stats, &failures);
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  po.evaluation_callback = &parallel;
  ceres::Problem problem(po);
  problem.AddParameterBlock(theta.data(), sel.size());
  for (int i = 0; i < sel.size(); ++i) {
    if (sel.lower()[i] > -1e299) problem.SetParameterLowerBound(theta.data(), i, sel.lower()[i]);
    if (sel.upper()[i] < 1e299) problem.SetParameterUpperBound(theta.data(), i, sel.upper()[i]);
  }
  if (static_cast<int>(held.size()) == sel.size())
    problem.SetParameterBlockConstant(theta.data());
  else if (!held.empty())
    problem.SetManifold(theta.data(), new ceres::SubsetManifold(sel.size(), held));
  std::vector<const SegmentCost*> costs;
  int continuity_rows = 0;
  // Continuity weight: a homotopy from min(10, w) up to w by factors of 10, each stage warm
  // started (a stiff penalty from the start makes Levenberg–Marquardt crawl along the
  // constraint manifold).
  double weight = std::min(10.0, options.continuity_weight);
  for (size_t k = 0; k < segments.size(); ++k) {
    const Segment& s = segments[k];
    const Episode& ep = log.episodes[s.episode];
    const bool has_next = s.last < ep.num_samples() - 1;
    std::unique_ptr<Episode> next;
    if (has_next) next = std::make_unique<Episode>(Slice(ep, s.last, ep.num_samples() - 1));
    const int measured = has_next ? s.last - s.first : s.last - s.first + 1;
    const VectorXd scale =
        ContinuityScale(planar, ObservedDynamic(ep), ep.t[s.last] - ep.t[s.first], options);
    owned_costs.push_back(std::make_unique<SegmentCost>(
        simulator, sel, base, Slice(ep, s.first, s.last), measured, s.ref,
        options.estimate_initial_state, states[k], std::move(next), scale, &weight, options,
        static_cast<int>(k), &failures, &jacobian_stats));
    const SegmentCost* cost = owned_costs.back().get();
    result.num_residuals += cost->measured_rows();
    continuity_rows += cost->continuity_rows();
    costs.push_back(cost);
    std::vector<double*> blocks = {theta.data()};
    if (options.estimate_initial_state) blocks.push_back(states[k].data());
    if (has_next) blocks.push_back(states[k + 1].data());
    slots[k].blocks = blocks;
    parallel.Add(cost, &slots[k]);
    problem.AddResidualBlock(new SegmentCeresCost(cost, &slots[k]), nullptr, blocks);
  }
  result.num_continuity_residuals = continuity_rows;
  // Threads left over by the segments go to each segment's finite-difference columns.
  for (const std::unique_ptr<SegmentCost>& c : owned_costs)
    c->set_column_threads(options.threads / static_cast<int>(owned_costs.size()));

  // Initial-state components the residuals do not see at the start have a zero Jacobian column
  // and are held fixed, so that the problem stays well-posed. The typical case is a velocity
  // into a resting contact, which the contact removes in the first step: its guess from noisy
  // samples is small but not zero, and can even lift the body off. So velocity components that
  // the samples do not distinguish from zero (|v| ≤ 3 standard errors of the fit) are tested at
  // zero, start there, and are held there if the rollout does not depend on them. (Later
  // segments' start states are tied by the continuity residuals of the segment before.)
  std::vector<std::vector<int>> frozen_components(log.episodes.size());
  if (options.estimate_initial_state) {
    for (size_t e = 0; e < log.episodes.size(); ++e) {
      const int k = episode_segments[e].front();
      VectorXd& state = states[k];
      const int ns = static_cast<int>(state.size());
      VectorXd s0 = state;
      std::vector<bool> candidate(ns, false);
      for (int j = 0; j < ns && !warm; ++j) {
        candidate[j] = segments[k].se[j] > 0 && std::abs(s0[j]) <= 3.0 * segments[k].se[j];
        if (candidate[j]) s0[j] = 0.0;
      }
      const SegmentCost* cost = costs[k];
      const int has_next = cost->continuity_rows() > 0;
      VectorXd r(cost->num_residuals());
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(
          cost->num_residuals(), ns);
      const double* params[3] = {theta.data(), s0.data(),
                                 has_next ? states[k + 1].data() : nullptr};
      double* jac[3] = {nullptr, J.data(), nullptr};
      if (!cost->Evaluate(params, r.data(), jac)) continue;  // the solver will report it
      const double tol = 1e-9 * std::sqrt(static_cast<double>(std::max<Eigen::Index>(1, J.rows())));
      // Candidates start at zero whether or not they are held: a noisy upward vy guess left
      // free (its column at zero is not exactly zero: the first step's normal impulse, and so
      // friction, depends on it) lifted the block into a hop that single shooting then fitted
      // as a local minimum (one of 20 seeded noisy fits: μ̂ = 0.356 ± 0.006 for 0.3, σ̂ 4×σ).
      for (int j = 0; j < ns; ++j)
        if (candidate[j]) state[j] = 0.0;
      std::vector<int> frozen;
      for (int j = 0; j < ns; ++j)
        if (!(J.col(j).norm() > tol)) frozen.push_back(j);
      result.frozen_state_components += static_cast<int>(frozen.size());
      frozen_components[e] = frozen;
      if (static_cast<int>(frozen.size()) == ns)
        problem.SetParameterBlockConstant(state.data());
      else if (!frozen.empty())
        problem.SetManifold(state.data(), new ceres::SubsetManifold(ns, frozen));
    }
  }
  result.num_unknowns = problem.NumParameters() - result.frozen_state_components;
  for (SegmentSlot& slot : slots) {
    slot.wanted.clear();
    for (double* block : slot.blocks)
      slot.wanted.push_back(!problem.IsParameterBlockConstant(block));
  }

  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  // With bounds on θ, Ceres scales every trust-region step by a projected Armijo line search.
  // Its default cubic interpolation asks for the gradient (all the Jacobians: finite-difference
  // rollouts) at every trial point, many of which a contraction or the trust region rejects; the
  // quadratic one reads the values only (bench/README.md, session 41).
  so.line_search_interpolation_type = ceres::QUADRATIC;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  if (options.estimate_initial_state && segments.size() > 1) {
    so.linear_solver_type = ceres::DENSE_SCHUR;
    if (result.num_unknowns > 600 &&
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
      so.linear_solver_type = ceres::SPARSE_SCHUR;
      so.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
    }
  }
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = options.gradient_tolerance;
  so.num_threads = 1;  // determinism: options.threads go to ParallelEvaluation
  so.update_state_every_iteration = static_cast<bool>(options.progress);
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ProgressCallback callback(options.progress, theta);
  if (options.progress) so.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.initial_cost = summary.initial_cost;
  while (continuity_rows > 0 && weight < options.continuity_weight && summary.IsSolutionUsable()) {
    weight = std::min(10.0 * weight, options.continuity_weight);
    parallel.Invalidate();
    ceres::Solve(so, &problem, &summary);
    result.iterations += summary.num_successful_steps + summary.num_unsuccessful_steps;
  }

  jacobian_stats.Sync();
  result.estimates = theta;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.reason = summary.message;

  // Measured residuals per episode (and the continuity defect) at the solution.
  std::vector<double> episode_ss(log.episodes.size(), 0.0);
  std::vector<int> episode_rows(log.episodes.size(), 0);
  bool all_evaluated = true;
  for (size_t k = 0; k < segments.size(); ++k) {
    const SegmentCost* cost = costs[k];
    VectorXd r(cost->num_residuals());
    const double* params[3] = {theta.data(), states[k].data(),
                               cost->continuity_rows() > 0 ? states[k + 1].data() : nullptr};
    if (!options.estimate_initial_state) params[1] = params[2];
    if (!cost->Evaluate(params, r.data(), nullptr)) {
      all_evaluated = false;
      continue;
    }
    const int e = segments[k].episode;
    episode_ss[e] += r.head(cost->measured_rows()).squaredNorm();
    episode_rows[e] += cost->measured_rows();
    if (cost->continuity_rows() > 0) {
      const VectorXd defect = r.tail(cost->continuity_rows()) / weight;
      result.continuity_defect =
          std::max(result.continuity_defect, defect.lpNorm<Eigen::Infinity>());
    }
  }
  const std::string fail = failures.Summary();
  if (!fail.empty()) result.reason += "; " + fail;

  // Standard errors: σ² times the parameter block of the constrained Gauss–Newton covariance
  // (ParameterCovariance), σ the larger of the stated noise and the residual estimate.
  double measured_ss = 0.0;
  for (double ss : episode_ss) measured_ss += ss;
  int free_state = 0;
  for (size_t e = 0; e < log.episodes.size(); ++e)
    if (options.estimate_initial_state)
      free_state += static_cast<int>(states[episode_segments[e].front()].size() -
                                     frozen_components[e].size());
  const int dof = result.num_residuals - sel.size() - free_state;
  result.sigma_residual = dof > 0 && all_evaluated ? std::sqrt(measured_ss / dof)
                                                   : std::numeric_limits<double>::quiet_NaN();
  result.sigma = options.noise_sigma > 0 && !(result.sigma_residual > options.noise_sigma)
                     ? options.noise_sigma
                     : result.sigma_residual;
  // A stated σ the residuals contradict (Σ r² / σ² beyond its χ²_dof mean by 4 standard
  // deviations, p < 1e-4): the fit stalled in a local minimum (another stick–slip pattern that
  // fits almost as well) or the model does not match; the standard errors cannot cover that.
  if (options.noise_sigma > 0 && all_evaluated &&
      internal::ResidualsContradictNoise(measured_ss, dof, options.noise_sigma)) {
    result.converged = false;
    std::ostringstream m;
    m << "; the residuals contradict the stated noise (σ̂ = " << result.sigma_residual
      << " m for --noise " << options.noise_sigma
      << " m): a local minimum or a model mismatch; the standard errors use σ̂";
    if (options.shooting == Shooting::kSingle && options.horizon_samples == 0)
      m << " (a growing horizon, --lsq-horizon, avoids local minima of long rollouts)";
    result.reason += m.str();
  }
  result.std_errors = VectorXd::Constant(sel.size(), std::numeric_limits<double>::quiet_NaN());
  if (summary.IsSolutionUsable() && all_evaluated) {
    sim::MatrixXd information = sim::MatrixXd::Zero(sel.size(), sel.size());
    bool ok = true;
    for (size_t e = 0; e < log.episodes.size() && ok; ++e) {
      std::vector<SegmentDerivatives> chain;
      for (int k : episode_segments[e]) {
        SegmentDerivatives sj;
        const double* next = costs[k]->continuity_rows() > 0 ? states[k + 1].data() : nullptr;
        ok = ok && costs[k]->Jacobians(theta, states[k], next, &sj);
        chain.push_back(std::move(sj));
      }
      if (!ok) break;
      std::vector<bool> is_free(states[episode_segments[e].front()].size(),
                                options.estimate_initial_state);
      for (int j : frozen_components[e]) is_free[j] = false;
      information += EpisodeInformation(chain, is_free);
    }
    VectorXd variances;
    if (!ok) {
      result.reason += "; standard errors not computed (a rollout failed)";
    } else if (!ParameterVariances(information, &variances)) {
      result.reason +=
          "; standard errors not computed (the parameters are not determined by the "
          "data: singular information matrix)";
    } else {
      for (int i = 0; i < sel.size(); ++i)
        result.std_errors[i] = result.sigma * std::sqrt(variances[i]);
    }
  }

  for (size_t e = 0; e < log.episodes.size(); ++e) {
    const int k = episode_segments[e].front();
    EpisodeEstimate ee;
    ee.file = log.episodes[e].file;
    ee.x0 = StateFromVector(simulator, log.episodes[e], segments[k].ref, states[k].data());
    ee.rms_residual = episode_rows[e] > 0 && all_evaluated
                          ? std::sqrt(episode_ss[e] / episode_rows[e])
                          : std::numeric_limits<double>::quiet_NaN();
    ee.num_residuals = episode_rows[e];
    if (options.estimate_initial_state)
      ee.num_state_unknowns = static_cast<int>(states[k].size() - frozen_components[e].size());
    result.episodes.push_back(ee);
  }
  first_states->clear();
  for (size_t e = 0; e < log.episodes.size(); ++e)
    first_states->push_back(states[episode_segments[e].front()]);
  jacobian_stats.Report(&result);
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace internal

EstimateResult EstimateLeastSquares(const sim::Simulator& simulator, const Log& log,
                                    const LeastSquaresOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const sim::ParamSelection sel(simulator.scene().param_table(), options.params);
  std::vector<VectorXd> states;  // the solution's initial states
  EstimateResult result = options.horizon_samples == 0
                              ? Fit(simulator, log, options, VectorXd(), &states)
                              : FitGrowingHorizon(simulator, log, options, sel, &states);
  RestartStrayEpisodes(simulator, log, options, sel, &states, &result);
  if (options.std_errors == LeastSquaresStdErrors::kProfile)
    ProfileStdErrors(simulator, log, options, sel, states, &result);
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace vinci::estimation
