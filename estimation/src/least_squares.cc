#include "vinci/estimation/least_squares.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/state_util.h"

namespace vinci::estimation {
namespace {

using sim::Dim;
using sim::Params;
using sim::State;
using sim::VectorXd;

// Samples of the quadratic fit that gives a log's initial velocity.
constexpr int kVelocityFitSamples = 8;

bool Planar(const sim::Simulator& s) { return s.scene().dim == Dim::kPlanar; }
int StateBlockSize(bool planar) { return planar ? 6 : 12; }

int ObservedDynamic(const Episode& ep) {
  int n = 0;
  for (const BodyTrack& b : ep.bodies) n += b.dynamic;
  return n;
}

Eigen::Quaterniond LoggedQuaternion(const BodyTrack& b, int i) {
  return Eigen::Quaterniond(b.pose(i, 3), b.pose(i, 4), b.pose(i, 5), b.pose(i, 6)).normalized();
}

Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double a = w.norm();
  if (a < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, w / a).toRotationMatrix();
}

Eigen::Vector3d RotationLog(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const double s = q.vec().norm();
  if (s < 1e-300) return Eigen::Vector3d::Zero();
  return 2.0 * std::atan2(s, q.w()) * q.vec() / s;
}

// The state with the observed dynamic bodies set from the unknown vector s (blocks of
// StateBlockSize per observed dynamic body, in track order).
State StateFromVector(const sim::Simulator& sim, const Episode& ep, const State& ref,
                      const double* s) {
  const sim::Scene& scene = sim.scene();
  const bool planar = Planar(sim);
  State x = ref;
  int o = 0;
  for (const BodyTrack& b : ep.bodies) {
    if (!b.dynamic) continue;
    if (planar) {
      sim::SetPlanarBodyPose(scene, b.body, s[o], s[o + 1], s[o + 2], &x);
      sim::SetBodyVelocity(scene, b.body, Eigen::Vector3d(s[o + 3], s[o + 4], 0),
                           Eigen::Vector3d(0, 0, s[o + 5]), &x);
    } else {
      const Eigen::Matrix3d R_ref = b.has_orientation
                                        ? LoggedQuaternion(b, 0).toRotationMatrix()
                                        : sim::GetBodyKinematics(scene, ref, b.body).X_WB.linear();
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.translation() = Eigen::Vector3d(s[o], s[o + 1], s[o + 2]);
      X.linear() = Exp(Eigen::Vector3d(s[o + 3], s[o + 4], s[o + 5])) * R_ref;
      sim::SetBodyPose(scene, b.body, X, &x);
      sim::SetBodyVelocity(scene, b.body, Eigen::Vector3d(s[o + 6], s[o + 7], s[o + 8]),
                           Eigen::Vector3d(s[o + 9], s[o + 10], s[o + 11]), &x);
    }
    o += StateBlockSize(planar);
  }
  return x;
}

// The unknown vector of a state (inverse of StateFromVector, rotation relative to the first
// logged orientation).
VectorXd VectorFromState(const sim::Simulator& sim, const Episode& ep, const State& x) {
  const sim::Scene& scene = sim.scene();
  const bool planar = Planar(sim);
  VectorXd s(ObservedDynamic(ep) * StateBlockSize(planar));
  int o = 0;
  for (const BodyTrack& b : ep.bodies) {
    if (!b.dynamic) continue;
    const sim::BodyKinematics k = sim::GetBodyKinematics(scene, x, b.body);
    if (planar) {
      const int qo = scene.index(b.body_index).q;
      s.segment(o, 6) << x.q[qo], x.q[qo + 1], x.q[qo + 2], k.v_WB.x(), k.v_WB.y(), k.w_WB.z();
    } else {
      const Eigen::Quaterniond q(k.X_WB.linear());
      const Eigen::Quaterniond q_ref =
          b.has_orientation ? LoggedQuaternion(b, 0) : Eigen::Quaterniond(k.X_WB.linear());
      s.segment(o, 3) = k.X_WB.translation();
      s.segment(o + 3, 3) = RotationLog(q * q_ref.conjugate());
      s.segment(o + 6, 3) = k.v_WB;
      s.segment(o + 9, 3) = k.w_WB;
    }
    o += StateBlockSize(planar);
  }
  return s;
}

}  // namespace

void LeastSquaresOptions::Validate() const {
  auto fail = [](const std::string& field, double v, const std::string& expected) {
    std::ostringstream m;
    m << "least squares: " << field << " = " << v << ", expected " << expected;
    throw std::invalid_argument(m.str());
  };
  if (params.empty()) throw std::invalid_argument("least squares: no parameter to estimate");
  if (!(noise_sigma >= 0) || !std::isfinite(noise_sigma)) fail("noise", noise_sigma, "finite ≥ 0");
  if (!(orientation_length > 0) || !std::isfinite(orientation_length))
    fail("orientation_length", orientation_length, "finite > 0");
  if (threads < 1) fail("threads", threads, "≥ 1");
  if (max_iterations < 1) fail("max_iterations", max_iterations, "≥ 1");
  if (!(fd_relative_step > 0) || !(fd_relative_step < 1e-2))
    fail("fd_relative_step", fd_relative_step, "in (0, 1e-2)");
}

namespace {

// The log's initial state (InitialStateFromLog) and, in the layout of the state unknowns
// (StateFromVector), the standard error of each velocity component estimated from the samples
// (0 for poses and for logged velocities or when the fit has no spare samples).
State GuessInitialState(const sim::Simulator& simulator, const Episode& ep, VectorXd* velocity_se) {
  const sim::Scene& scene = simulator.scene();
  const bool planar = Planar(simulator);
  State x = simulator.InitialState();
  x.t = ep.t.front();
  x.warm_start.resize(0);
  velocity_se->setZero(ObservedDynamic(ep) * StateBlockSize(planar));
  const int n = ep.num_samples();
  const int k = std::min(n - 1, kVelocityFitSamples - 1);
  // Velocity of a logged series at the first sample: the slope at t0 of a least-squares
  // quadratic through the first samples (a line through two if there are only two), and its
  // standard error from the fit's residuals.
  auto slope = [&](const std::vector<double>& y, double* se) {
    *se = 0.0;
    if (k == 0) return 0.0;
    const int m = k + 1;
    Eigen::MatrixXd A(m, m >= 3 ? 3 : 2);
    VectorXd yv(m);
    for (int i = 0; i < m; ++i) {
      const double tau = ep.t[i] - ep.t[0];
      A(i, 0) = 1.0;
      A(i, 1) = tau;
      if (A.cols() == 3) A(i, 2) = tau * tau;
      yv[i] = y[i];
    }
    const VectorXd c = A.colPivHouseholderQr().solve(yv);
    if (m > A.cols()) {
      const double s2 = (A * c - yv).squaredNorm() / (m - A.cols());
      const Eigen::MatrixXd cov = (A.transpose() * A).inverse() * s2;
      *se = std::sqrt(std::max(0.0, cov(1, 1)));
    }
    return c[1];
  };
  auto column = [&](const BodyTrack& b, int col) {
    std::vector<double> y(k + 1);
    for (int i = 0; i <= k; ++i) y[i] = b.pose(i, col);
    return y;
  };
  int o = 0;
  for (const BodyTrack& b : ep.bodies) {
    if (!b.dynamic) continue;
    Eigen::Vector3d v = Eigen::Vector3d::Zero(), w = Eigen::Vector3d::Zero();
    double* se = velocity_se->data() + o;
    if (planar) {
      const Eigen::Matrix3d R = sim::GetBodyKinematics(scene, x, b.body).X_WB.linear();
      const double th = b.has_orientation ? b.pose(0, 2) : std::atan2(R(1, 0), R(0, 0));
      sim::SetPlanarBodyPose(scene, b.body, b.pose(0, 0), b.pose(0, 1), th, &x);
      if (b.velocity.rows() > 0) {
        v << b.velocity(0, 0), b.velocity(0, 1), 0;
        w << 0, 0, b.velocity(0, 2);
      } else {
        v << slope(column(b, 0), se + 3), slope(column(b, 1), se + 4), 0;
        if (b.has_orientation) w.z() = slope(column(b, 2), se + 5);
      }
    } else {
      Eigen::Isometry3d X = sim::GetBodyKinematics(scene, x, b.body).X_WB;
      X.translation() = b.pose.row(0).head<3>().transpose();
      if (b.has_orientation) X.linear() = LoggedQuaternion(b, 0).toRotationMatrix();
      sim::SetBodyPose(scene, b.body, X, &x);
      if (b.velocity.rows() > 0) {
        v = b.velocity.row(0).head<3>().transpose();
        w = b.velocity.row(0).tail<3>().transpose();
      } else {
        for (int j = 0; j < 3; ++j) v[j] = slope(column(b, j), se + 6 + j);
        if (b.has_orientation) {
          // World-frame rotation vectors from the first orientation: their slope is w_W.
          std::vector<std::vector<double>> rv(3, std::vector<double>(k + 1));
          for (int i = 0; i <= k; ++i) {
            const Eigen::Vector3d r =
                RotationLog(LoggedQuaternion(b, i) * LoggedQuaternion(b, 0).conjugate());
            for (int j = 0; j < 3; ++j) rv[j][i] = r[j];
          }
          for (int j = 0; j < 3; ++j) w[j] = slope(rv[j], se + 9 + j);
        }
      }
    }
    sim::SetBodyVelocity(scene, b.body, v, w, &x);
    o += StateBlockSize(planar);
  }
  return x;
}

}  // namespace

State InitialStateFromLog(const sim::Simulator& simulator, const Episode& ep) {
  VectorXd se;
  return GuessInitialState(simulator, ep, &se);
}

bool EpisodeResiduals(const sim::Simulator& simulator, const Params& params, const Episode& ep,
                      const State& x0, double orientation_length, VectorXd* residuals,
                      std::string* failure) {
  const sim::Scene& scene = simulator.scene();
  const bool planar = Planar(simulator);
  const double dt = scene.options.dt;
  const double t0 = ep.t.front();
  const int steps = std::max(0, static_cast<int>(std::ceil((ep.t.back() - t0) / dt - 1e-9)));
  sim::RolloutOptions ro;
  ro.warm_start = sim::WarmStartPolicy::kCold;  // a function of (params, t, q, v) only
  std::vector<sim::StepInput> inputs(steps);
  const sim::Trajectory tr = simulator.Rollout(params, x0, inputs, ro);
  if (!tr.ok || static_cast<int>(tr.states.size()) != steps + 1) {
    if (failure) *failure = "rollout failed: " + tr.failure;
    return false;
  }
  const int per = ResidualsPerSample(ep, scene.dim);
  residuals->resize(static_cast<Eigen::Index>(ep.num_samples()) * per);
  for (int i = 0; i < ep.num_samples(); ++i) {
    const double ti = ep.t[i];
    int k = steps == 0 ? 0 : std::min(steps - 1, static_cast<int>(std::floor((ti - t0) / dt)));
    k = std::max(k, 0);
    const State& a = tr.states[k];
    const State& b = tr.states[std::min(k + 1, steps)];
    const double span = b.t - a.t;
    const double al = span > 0 ? std::clamp((ti - a.t) / span, 0.0, 1.0) : 0.0;
    int r = i * per;
    for (const BodyTrack& tb : ep.bodies) {
      if (!tb.dynamic) continue;
      const int qo = scene.index(tb.body_index).q;
      const int np = planar ? 2 : 3;
      for (int j = 0; j < np; ++j)
        (*residuals)[r++] = tb.pose(i, j) - ((1 - al) * a.q[qo + j] + al * b.q[qo + j]);
      if (!tb.has_orientation) continue;
      if (planar) {
        const double th = (1 - al) * a.q[qo + 2] + al * b.q[qo + 2];
        (*residuals)[r++] = orientation_length * (tb.pose(i, 2) - th);
      } else {
        Eigen::Quaterniond qa(a.q[qo + 3], a.q[qo + 4], a.q[qo + 5], a.q[qo + 6]);
        Eigen::Quaterniond qb(b.q[qo + 3], b.q[qo + 4], b.q[qo + 5], b.q[qo + 6]);
        const Eigen::Quaterniond q = qa.slerp(al, qb);
        const Eigen::Vector3d e = RotationLog(LoggedQuaternion(tb, i) * q.conjugate());
        for (int j = 0; j < 3; ++j) (*residuals)[r++] = orientation_length * e[j];
      }
    }
  }
  return true;
}

namespace {

// Records the first failure seen inside a Ceres callback (thread-safe).
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

// One episode's residuals; parameter blocks: the selected parameters and (optionally) the
// episode's initial-state vector. Jacobians by central differences of rollouts.
class EpisodeCost : public ceres::CostFunction {
 public:
  EpisodeCost(const sim::Simulator& sim, const sim::ParamSelection& sel, const Params& base,
              const Episode& ep, const State& ref, bool with_state, const VectorXd& fixed_state,
              const LeastSquaresOptions& opt, FailureLog* failures)
      : sim_(sim),
        sel_(sel),
        base_(base),
        ep_(ep),
        ref_(ref),
        with_state_(with_state),
        fixed_state_(fixed_state),
        opt_(opt),
        failures_(failures) {
    set_num_residuals(ep.num_samples() * ResidualsPerSample(ep, sim.scene().dim));
    mutable_parameter_block_sizes()->push_back(sel.size());
    if (with_state)
      mutable_parameter_block_sizes()->push_back(static_cast<int>(fixed_state.size()));
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    try {
      return EvaluateOrThrow(parameters, residuals, jacobians);
    } catch (const std::exception& e) {
      failures_->Record(ep_.file + ": " + e.what());
      return false;
    }
  }

 private:
  bool Residuals(const VectorXd& theta, const VectorXd& s, VectorXd* r) const {
    const Params p = sel_.Set(base_, theta);
    const State x0 = StateFromVector(sim_, ep_, ref_, s.data());
    std::string failure;
    if (!EpisodeResiduals(sim_, p, ep_, x0, opt_.orientation_length, r, &failure)) {
      failures_->Record(ep_.file + ": " + failure);
      return false;
    }
    return true;
  }

  bool EvaluateOrThrow(double const* const* parameters, double* residuals,
                       double** jacobians) const {
    const int np = sel_.size();
    VectorXd theta = Eigen::Map<const VectorXd>(parameters[0], np);
    VectorXd s = with_state_
                     ? VectorXd(Eigen::Map<const VectorXd>(parameters[1], fixed_state_.size()))
                     : fixed_state_;
    VectorXd r;
    if (!Residuals(theta, s, &r)) return false;
    const int m = num_residuals();
    Eigen::Map<VectorXd>(residuals, m) = r;
    if (!jacobians) return true;
    const VectorXd lo = sel_.lower(), hi = sel_.upper();
    for (int block = 0; block < (with_state_ ? 2 : 1); ++block) {
      if (!jacobians[block]) continue;
      VectorXd& x = block == 0 ? theta : s;
      const int n = static_cast<int>(x.size());
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
          jacobians[block], m, n);
      for (int j = 0; j < n; ++j) {
        const double xj = x[j];
        const double h = opt_.fd_relative_step * std::max(1.0, std::abs(xj));
        const bool down_ok = block != 0 || xj - h >= lo[j];
        const bool up_ok = block != 0 || xj + h <= hi[j];
        VectorXd rp, rm;
        double width = 0.0;
        if (up_ok) {
          x[j] = xj + h;
          if (!Residuals(theta, s, &rp)) return false;
          width += h;
        } else {
          rp = r;
        }
        if (down_ok) {
          x[j] = xj - h;
          if (!Residuals(theta, s, &rm)) return false;
          width += h;
        } else {
          rm = r;
        }
        x[j] = xj;
        if (width == 0.0) return false;
        J.col(j) = (rp - rm) / width;
      }
    }
    return true;
  }

  const sim::Simulator& sim_;
  const sim::ParamSelection& sel_;
  const Params& base_;
  const Episode& ep_;
  const State ref_;
  const bool with_state_;
  const VectorXd fixed_state_;
  const LeastSquaresOptions& opt_;
  FailureLog* failures_;
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

}  // namespace

EstimateResult EstimateLeastSquares(const sim::Simulator& simulator, const Log& log,
                                    const LeastSquaresOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  const sim::Scene& scene = simulator.scene();
  const sim::ParamTable& table = scene.param_table();
  for (const std::string& name : options.params) {
    const sim::ParamInfo& info = table.info(table.Index(name));
    if (!info.differentiable) {
      std::string names;
      for (const std::string& d : table.DifferentiableNames())
        names += (names.empty() ? "" : ", ") + d;
      throw std::invalid_argument("--param " + name +
                                  ": not a differentiable parameter; estimable here: " + names);
    }
  }
  if (log.episodes.empty()) throw std::invalid_argument("no log episode");
  const sim::ParamSelection sel(table, options.params);
  const bool planar = Planar(simulator);
  std::vector<int> own;
  for (const Episode& ep : log.episodes)
    own.push_back(options.estimate_initial_state ? ObservedDynamic(ep) * StateBlockSize(planar)
                                                 : 0);
  CheckEnoughSamples(log, scene.dim, sel.size(), own);

  const Params base = simulator.DefaultParams();
  EstimateResult result;
  result.names = options.params;
  result.initial_values = sel.Get(base);
  VectorXd theta = result.initial_values;
  std::vector<State> refs;
  std::vector<VectorXd> states, velocity_se;
  for (const Episode& ep : log.episodes) {
    velocity_se.emplace_back();
    refs.push_back(GuessInitialState(simulator, ep, &velocity_se.back()));
    states.push_back(VectorFromState(simulator, ep, refs.back()));
  }

  FailureLog failures;
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddParameterBlock(theta.data(), sel.size());
  for (int i = 0; i < sel.size(); ++i) {
    if (sel.lower()[i] > -1e299) problem.SetParameterLowerBound(theta.data(), i, sel.lower()[i]);
    if (sel.upper()[i] < 1e299) problem.SetParameterUpperBound(theta.data(), i, sel.upper()[i]);
  }
  int m = 0;
  std::vector<const EpisodeCost*> costs;
  for (size_t e = 0; e < log.episodes.size(); ++e) {
    auto* cost = new EpisodeCost(simulator, sel, base, log.episodes[e], refs[e],
                                 options.estimate_initial_state, states[e], options, &failures);
    m += cost->num_residuals();
    costs.push_back(cost);
    if (options.estimate_initial_state)
      problem.AddResidualBlock(cost, nullptr, theta.data(), states[e].data());
    else
      problem.AddResidualBlock(cost, nullptr, theta.data());
  }
  result.num_residuals = m;

  // Initial-state components the residuals do not see at the start have a zero Jacobian column
  // and are held fixed, so that the problem stays well-posed. The typical case is a velocity
  // into a resting contact, which the contact removes in the first step: its guess from noisy
  // samples is small but not zero, and can even lift the body off. So velocity components that
  // the samples do not distinguish from zero (|v| ≤ 3 standard errors of the fit) are tested at
  // zero, and held at zero if the rollout does not depend on them there.
  if (options.estimate_initial_state) {
    for (size_t e = 0; e < log.episodes.size(); ++e) {
      const int ns = static_cast<int>(states[e].size());
      VectorXd s0 = states[e];
      std::vector<bool> candidate(ns, false);
      for (int j = 0; j < ns; ++j) {
        candidate[j] = velocity_se[e][j] > 0 && std::abs(s0[j]) <= 3.0 * velocity_se[e][j];
        if (candidate[j]) s0[j] = 0.0;
      }
      const ceres::CostFunction* cost = costs[e];
      VectorXd r(cost->num_residuals());
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(
          cost->num_residuals(), ns);
      const double* params[2] = {theta.data(), s0.data()};
      double* jac[2] = {nullptr, J.data()};
      if (!cost->Evaluate(params, r.data(), jac)) continue;  // the solver will report it
      const double tol = 1e-9 * std::sqrt(static_cast<double>(std::max<Eigen::Index>(1, J.rows())));
      std::vector<int> frozen;
      for (int j = 0; j < ns; ++j) {
        if (J.col(j).norm() > tol) continue;
        frozen.push_back(j);
        if (candidate[j]) states[e][j] = 0.0;
      }
      result.frozen_state_components += static_cast<int>(frozen.size());
      if (static_cast<int>(frozen.size()) == ns)
        problem.SetParameterBlockConstant(states[e].data());
      else if (!frozen.empty())
        problem.SetManifold(states[e].data(), new ceres::SubsetManifold(ns, frozen));
    }
  }
  result.num_unknowns = problem.NumParameters() - result.frozen_state_components;

  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = (options.estimate_initial_state && log.episodes.size() > 1)
                              ? ceres::DENSE_SCHUR
                              : ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = options.gradient_tolerance;
  so.num_threads = options.threads;
  so.update_state_every_iteration = static_cast<bool>(options.progress);
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ProgressCallback callback(options.progress, theta);
  if (options.progress) so.callbacks.push_back(&callback);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);

  result.estimates = theta;
  result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
  result.initial_cost = summary.initial_cost;
  result.final_cost = summary.final_cost;
  result.converged = summary.termination_type == ceres::CONVERGENCE;
  result.reason = summary.message;
  const std::string fail = failures.Summary();
  if (!fail.empty()) result.reason += "; " + fail;

  // Standard errors.
  const int dof = result.num_residuals - result.num_unknowns;
  result.sigma = options.noise_sigma > 0 ? options.noise_sigma
                                         : (dof > 0 ? std::sqrt(2.0 * summary.final_cost / dof)
                                                    : std::numeric_limits<double>::quiet_NaN());
  result.std_errors = VectorXd::Constant(sel.size(), std::numeric_limits<double>::quiet_NaN());
  if (summary.IsSolutionUsable()) {
    ceres::Covariance::Options co;
    co.algorithm_type = result.num_unknowns <= 1000 ? ceres::DENSE_SVD : ceres::SPARSE_QR;
    co.num_threads = options.threads;
    co.null_space_rank = -1;  // pseudo-inverse: directions the data do not determine are dropped
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks = {{theta.data(), theta.data()}};
    if (cov.Compute(blocks, &problem)) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> C(sel.size(),
                                                                               sel.size());
      if (cov.GetCovarianceBlock(theta.data(), theta.data(), C.data())) {
        for (int i = 0; i < sel.size(); ++i)
          result.std_errors[i] = result.sigma * std::sqrt(std::max(0.0, C(i, i)));
      }
    } else {
      result.reason += "; covariance not computed (rank-deficient Jacobian?)";
    }
  }

  const Params fitted = sel.Set(base, theta);
  for (size_t e = 0; e < log.episodes.size(); ++e) {
    EpisodeEstimate ee;
    ee.file = log.episodes[e].file;
    ee.x0 = StateFromVector(simulator, log.episodes[e], refs[e], states[e].data());
    VectorXd r;
    if (EpisodeResiduals(simulator, fitted, log.episodes[e], ee.x0, options.orientation_length, &r,
                         nullptr) &&
        r.size() > 0)
      ee.rms_residual = std::sqrt(r.squaredNorm() / r.size());
    else
      ee.rms_residual = std::numeric_limits<double>::quiet_NaN();
    result.episodes.push_back(ee);
  }
  result.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace vinci::estimation
