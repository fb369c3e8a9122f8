#include "segment_sensitivity.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "estimation_internal.h"
#include "vinci/sim/simulator/sensitivity.h"

namespace vinci::estimation::internal {

using sim::MatrixXd;
using sim::State;
using sim::VectorXd;

namespace {

// Relative size of the central-difference perturbations of the (smooth, simulation-free)
// observation maps: the largest entry of h·d is this.
constexpr double kObservationStep = 1e-6;

VectorXd Raw(const State& x) {
  VectorXd r(x.q.size() + x.v.size());
  r << x.q, x.v;
  return r;
}

// Quaternion offsets (into q) of the episode's observed dynamic bodies; empty if planar.
std::vector<int> QuaternionOffsets(const sim::Simulator& sim, const Episode& ep) {
  std::vector<int> out;
  if (Planar(sim)) return out;
  for (const BodyTrack& b : ep.bodies)
    if (b.dynamic) out.push_back(sim.scene().index(b.body_index).q + 3);
  return out;
}

// x + h d (d over [q; ν]), with the observed bodies' quaternions renormalized.
State Perturb(const State& x, const Eigen::Ref<const VectorXd>& d, double h,
              const std::vector<int>& quaternions) {
  State y = x;
  const Eigen::Index nq = x.q.size();
  y.q += h * d.head(nq);
  y.v += h * d.tail(x.v.size());
  for (int o : quaternions) {
    const double n = y.q.segment<4>(o).norm();
    if (n > 0) y.q.segment<4>(o) /= n;
  }
  return y;
}

// The derivative along column c of (Sa, Sb) of f(a, b), a smooth function of two states, by a
// central difference scaled to the column.
using PairFunction = std::function<VectorXd(const State&, const State&)>;
void PairDerivative(const PairFunction& f, const State& a, const State& b, const MatrixXd& Sa,
                    const MatrixXd& Sb, const std::vector<int>& quaternions, MatrixXd* out) {
  for (Eigen::Index c = 0; c < Sa.cols(); ++c) {
    const double m =
        std::max(Sa.col(c).lpNorm<Eigen::Infinity>(), Sb.col(c).lpNorm<Eigen::Infinity>());
    if (!(m > 0)) {
      out->col(c).setZero();
      continue;
    }
    // Along the unit column: kObservationStep / m overflows for a column that decayed to
    // denormals (~1e-310 after a few sticking steps), and ∞ · 0 poisoned the Jacobian with NaN.
    const VectorXd ua = Sa.col(c) / m, ub = Sb.col(c) / m;
    const double h = kObservationStep;
    const VectorXd fp = f(Perturb(a, ua, h, quaternions), Perturb(b, ub, h, quaternions));
    const VectorXd fm = f(Perturb(a, ua, -h, quaternions), Perturb(b, ub, -h, quaternions));
    out->col(c) = (fp - fm) * (m / (2 * h));
  }
}

}  // namespace

SegmentSensitivityResult SegmentSensitivity(const sim::Simulator& sim,
                                            const sim::ParamSelection& selection,
                                            const sim::Params& params, const Episode& ep,
                                            const State& ref, const VectorXd& s, bool with_state,
                                            int measured_rows, const Episode* next,
                                            double orientation_length) {
  SegmentSensitivityResult out;
  const int np = selection.size();
  const int ns = with_state ? static_cast<int>(s.size()) : 0;
  const std::vector<int> quats = QuaternionOffsets(sim, ep);
  const State x0 = StateFromVector(sim, ep, ref, s.data());
  const VectorXd raw0 = Raw(x0);
  const Eigen::Index nx = raw0.size();

  // S_0 = [0 | ∂X/∂s], by central differences of the coordinate map (quaternion signs aligned
  // with x_0's: the matrix-to-quaternion conversion may pick either).
  MatrixXd S = MatrixXd::Zero(nx, np + ns);
  for (int j = 0; j < ns; ++j) {
    const double h = 1e-6 * std::max(1.0, std::abs(s[j]));
    VectorXd sp = s, sm = s;
    sp[j] += h;
    sm[j] -= h;
    VectorXd rp = Raw(StateFromVector(sim, ep, ref, sp.data()));
    VectorXd rm = Raw(StateFromVector(sim, ep, ref, sm.data()));
    for (int o : quats) {
      if (rp.segment<4>(o).dot(raw0.segment<4>(o)) < 0) rp.segment<4>(o) *= -1.0;
      if (rm.segment<4>(o).dot(raw0.segment<4>(o)) < 0) rm.segment<4>(o) *= -1.0;
    }
    S.col(np + j) = (rp - rm) / (2 * h);
  }

  // RolloutResiduals' rollout (its first step cold, each next one from the last one's
  // solution) with S_ℓ propagated.
  const int steps = StepsTo(sim, ep.t.front(), ep.t.back());
  std::vector<State> states;
  std::vector<MatrixXd> sens;
  states.reserve(steps + 1);
  sens.reserve(steps + 1);
  State x = ColdStart(x0), nx_state;
  states.push_back(x);
  sens.push_back(S);
  sim::Workspace ws;
  const sim::StepInput u{};
  bool sens_ok = true;
  MatrixXd S1;
  for (int k = 0; k < steps; ++k) {
    const sim::StepInfo info = sim.Step(params, x, u, &ws, &nx_state);
    if (!info.ok) {
      out.status = SegmentSensitivityStatus::kRolloutFailed;
      out.failure = "rollout failed: step " + std::to_string(k) + " (t = " + std::to_string(x.t) +
                    " s): " + info.failure;
      return out;
    }
    if (sens_ok) {
      const sim::StepSensitivity st =
          sim::PropagateStep(sim, params, selection, x, u, nx_state, S, &S1);
      if (st.status == sim::SensitivityStatus::kFailed || !S1.allFinite()) {
        sens_ok = false;
        out.failure = "step sensitivity failed at step " + std::to_string(k) +
                      " (t = " + std::to_string(x.t) + " s): " + st.message;
      } else {
        out.mode_change_steps += st.status == sim::SensitivityStatus::kModeChange;
        out.degenerate_steps += st.status == sim::SensitivityStatus::kDegenerate;
        S = S1;
      }
    }
    x = std::move(nx_state);
    states.push_back(x);
    sens.push_back(sens_ok ? S : MatrixXd());
  }

  // Measured residuals and their derivatives.
  const int per = ResidualsPerSample(ep, sim.scene().dim);
  const int samples = per > 0 ? measured_rows / per : 0;
  out.measured.resize(measured_rows);
  if (sens_ok) out.d_measured.resize(measured_rows, np + ns);
  for (int i = 0; i < samples; ++i) {
    int k = 0;
    double al = 0.0;
    Bracket(states, ep.t[i], &k, &al);
    const int kb = std::min(k + 1, steps);
    const PairFunction f = [&](const State& a, const State& b) {
      VectorXd r(per);
      SampleResiduals(sim, ep, i, a, b, al, orientation_length, r.data());
      return r;
    };
    out.measured.segment(static_cast<Eigen::Index>(i) * per, per) = f(states[k], states[kb]);
    if (!sens_ok) continue;
    MatrixXd d(per, np + ns);
    PairDerivative(f, states[k], states[kb], sens[k], sens[kb], quats, &d);
    out.d_measured.middleRows(static_cast<Eigen::Index>(i) * per, per) = d;
  }

  // The next segment's start-state unknowns at its first time.
  if (next) {
    int k = 0;
    double al = 0.0;
    if (steps > 0) Bracket(states, next->t.front(), &k, &al);
    const int kb = std::min(k + 1, steps);
    const PairFunction f = [&](const State& a, const State& b) -> VectorXd {
      return (1 - al) * VectorFromState(sim, *next, a) + al * VectorFromState(sim, *next, b);
    };
    out.end = f(states[k], states[kb]);
    if (sens_ok) {
      out.d_end.resize(out.end.size(), np + ns);
      PairDerivative(f, states[k], states[kb], sens[k], sens[kb], quats, &out.d_end);
    }
  }
  out.status =
      sens_ok ? SegmentSensitivityStatus::kOk : SegmentSensitivityStatus::kSensitivityFailed;
  return out;
}

}  // namespace vinci::estimation::internal
