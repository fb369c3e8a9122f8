#include "estimation_internal.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vinci/estimation/least_squares.h"
#include "vinci/sim/model/state_util.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation::internal {

using sim::Dim;
using sim::Params;
using sim::State;
using sim::VectorXd;

namespace {
// Samples of the quadratic fit that gives a log's initial velocity.
constexpr int kVelocityFitSamples = 8;
}  // namespace

using sim::VectorXd;

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

// The log's initial state (InitialStateFromLog) and, in the layout of the state unknowns
// (StateFromVector), the standard error of each velocity component estimated from the samples
// (0 for poses and for logged velocities or when the fit has no spare samples).
State GuessInitialState(const sim::Simulator& simulator, const Episode& ep, VectorXd* velocity_se,
                        bool follow_quadratic) {
  const sim::Scene& scene = simulator.scene();
  const bool planar = Planar(simulator);
  State x = simulator.InitialState();
  x.t = ep.t.front();
  x.warm_start.resize(0);
  velocity_se->setZero(ObservedDynamic(ep) * StateBlockSize(planar));
  const int n = ep.num_samples();
  const int k = std::min(n - 1, kVelocityFitSamples - 1);
  // Velocity of a logged series at the first sample: the slope c1 at t0 of a least-squares
  // quadratic c0 + c1 τ + c2 τ² through the first samples (a line through two if there are
  // only two), and its standard error from the fit's residuals. The simulator's steps update
  // positions with the new velocity, so under a constant acceleration its rollout from c1 lags
  // the quadratic by c2 dt τ; with `follow_quadratic` the guess is c1 − c2 dt, which follows it
  // exactly (multiple shooting uses it; for single shooting it made one of 20 seeded noisy fits
  // stall, so the slope stays there).
  const double dt = scene.options.dt;
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
    return follow_quadratic && A.cols() == 3 ? c[1] - c[2] * dt : c[1];
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

Episode Slice(const Episode& ep, int first, int last) {
  Episode s;
  s.file = ep.file;
  s.t.assign(ep.t.begin() + first, ep.t.begin() + last + 1);
  s.lines.assign(ep.lines.begin() + first, ep.lines.begin() + last + 1);
  const int n = last - first + 1;
  for (const BodyTrack& b : ep.bodies) {
    BodyTrack c = b;
    c.pose = b.pose.middleRows(first, n);
    if (b.velocity.rows() > 0) c.velocity = b.velocity.middleRows(first, n);
    s.bodies.push_back(std::move(c));
  }
  return s;
}

void SampleResiduals(const sim::Simulator& simulator, const Episode& ep, int i, const State& a,
                     const State& b, double al, double orientation_length, double* out) {
  const sim::Scene& scene = simulator.scene();
  const bool planar = Planar(simulator);
  int r = 0;
  for (const BodyTrack& tb : ep.bodies) {
    if (!tb.dynamic) continue;
    const int qo = scene.index(tb.body_index).q;
    const int np = planar ? 2 : 3;
    for (int j = 0; j < np; ++j)
      out[r++] = tb.pose(i, j) - ((1 - al) * a.q[qo + j] + al * b.q[qo + j]);
    if (!tb.has_orientation) continue;
    if (planar) {
      const double th = (1 - al) * a.q[qo + 2] + al * b.q[qo + 2];
      out[r++] = orientation_length * (tb.pose(i, 2) - th);
    } else {
      Eigen::Quaterniond qa(a.q[qo + 3], a.q[qo + 4], a.q[qo + 5], a.q[qo + 6]);
      Eigen::Quaterniond qb(b.q[qo + 3], b.q[qo + 4], b.q[qo + 5], b.q[qo + 6]);
      const Eigen::Quaterniond q = qa.slerp(al, qb);
      const Eigen::Vector3d e = RotationLog(LoggedQuaternion(tb, i) * q.conjugate());
      for (int j = 0; j < 3; ++j) out[r++] = orientation_length * e[j];
    }
  }
}

int StepsTo(const sim::Simulator& simulator, double t0, double t) {
  return std::max(0, static_cast<int>(std::ceil((t - t0) / simulator.scene().options.dt - 1e-9)));
}

void Bracket(const std::vector<State>& states, double t, int* k, double* al) {
  const int steps = static_cast<int>(states.size()) - 1;
  if (steps <= 0) {
    *k = 0;
    *al = 0.0;
    return;
  }
  const double t0 = states.front().t;
  const double dt = states[1].t - t0;
  *k = std::clamp(static_cast<int>(std::floor((t - t0) / dt)), 0, steps - 1);
  const double span = states[*k + 1].t - states[*k].t;
  *al = span > 0 ? std::clamp((t - states[*k].t) / span, 0.0, 1.0) : 0.0;
}

State ColdStart(State x) {
  x.warm_start.resize(0);
  return x;
}

bool RolloutResiduals(const sim::Simulator& simulator, const Params& params, const Episode& ep,
                      const State& x0, double orientation_length, VectorXd* residuals,
                      std::string* failure, sim::Trajectory* tr_out) {
  const int steps = StepsTo(simulator, ep.t.front(), ep.t.back());
  std::vector<sim::StepInput> inputs(steps);
  sim::Trajectory tr = simulator.Rollout(params, ColdStart(x0), inputs);
  if (!tr.ok || static_cast<int>(tr.states.size()) != steps + 1) {
    if (failure) *failure = "rollout failed: " + tr.failure;
    return false;
  }
  const int per = ResidualsPerSample(ep, simulator.scene().dim);
  residuals->resize(static_cast<Eigen::Index>(ep.num_samples()) * per);
  for (int i = 0; i < ep.num_samples(); ++i) {
    int k = 0;
    double al = 0.0;
    Bracket(tr.states, ep.t[i], &k, &al);
    const State& b = tr.states[std::min(k + 1, steps)];
    SampleResiduals(simulator, ep, i, tr.states[k], b, al, orientation_length,
                    residuals->data() + static_cast<Eigen::Index>(i) * per);
  }
  if (tr_out) *tr_out = std::move(tr);
  return true;
}

VectorXd VectorAt(const sim::Simulator& sim, const Episode& ep, const sim::Trajectory& tr,
                  double t) {
  if (tr.states.size() < 2) return VectorFromState(sim, ep, tr.states.front());
  int k = 0;
  double al = 0.0;
  Bracket(tr.states, t, &k, &al);
  return (1 - al) * VectorFromState(sim, ep, tr.states[k]) +
         al * VectorFromState(sim, ep, tr.states[k + 1]);
}

void FailOption(const std::string& method, const std::string& field, double value,
                const std::string& expected) {
  std::ostringstream m;
  m << method << ": " << field << " = " << value << ", expected " << expected;
  throw std::invalid_argument(m.str());
}

bool ResidualsContradictNoise(double ss, int dof, double sigma) {
  return dof > 0 && ss / (sigma * sigma) > dof + 4.0 * std::sqrt(2.0 * dof);
}

void CheckDifferentiable(const sim::Scene& scene, const std::vector<std::string>& params) {
  const sim::ParamTable& table = scene.param_table();
  for (const std::string& name : params) {
    const sim::ParamInfo& info = table.info(table.Index(name));
    if (!info.differentiable) {
      std::string names;
      for (const std::string& d : table.DifferentiableNames())
        names += (names.empty() ? "" : ", ") + d;
      throw std::invalid_argument("--param " + name +
                                  ": not a differentiable parameter; estimable here: " + names);
    }
  }
}

}  // namespace vinci::estimation::internal

namespace vinci::estimation {

// Below 1 nm no residual is "far worse" (noise-free logs fit to rounding).
constexpr double kMinPoorResidual = 1e-9;

bool EpisodeContradictsNoise(const EpisodeEstimate& episode, double sigma) {
  if (!(sigma > 0) || !std::isfinite(episode.rms_residual)) return false;
  const double ss = episode.rms_residual * episode.rms_residual * episode.num_residuals;
  return internal::ResidualsContradictNoise(ss, episode.num_residuals - episode.num_state_unknowns,
                                            sigma);
}

std::vector<int> PoorlyFittingEpisodes(const std::vector<EpisodeEstimate>& episodes, double factor,
                                       double* median) {
  if (!(factor > 1.0)) throw std::invalid_argument("PoorlyFittingEpisodes: factor must be > 1");
  double m = std::numeric_limits<double>::quiet_NaN();
  if (median) *median = m;
  std::vector<double> rms;
  for (const EpisodeEstimate& e : episodes) {
    if (!std::isfinite(e.rms_residual)) return {};
    rms.push_back(e.rms_residual);
  }
  if (rms.size() < 3) return {};
  std::vector<double> sorted = rms;
  const std::size_t mid = sorted.size() / 2;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid), sorted.end());
  m = sorted[mid];
  if (sorted.size() % 2 == 0) {
    m = 0.5 *
        (m + *std::max_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  if (median) *median = m;
  std::vector<int> poor;
  for (std::size_t e = 0; e < rms.size(); ++e)
    if (rms[e] > std::max(factor * m, kMinPoorResidual)) poor.push_back(static_cast<int>(e));
  return poor;
}

}  // namespace vinci::estimation
