#include "vinci/estimation/holdout.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "estimation_internal.h"
#include "vinci/estimation/least_squares.h"
#include "vinci/sim/geometry/shape.h"

namespace vinci::estimation {

using sim::State;
using namespace internal;  // NOLINT(google-build-using-namespace): this layer's own helpers

void SplitHoldout(const Log& log, int k, Log* fit, Log* held_out) {
  const int n = static_cast<int>(log.episodes.size());
  if (k < 2)
    throw std::invalid_argument("--holdout " + std::to_string(k) +
                                ": expected K ≥ 2 (every K-th episode is held out)");
  if (n < k)
    throw std::invalid_argument("--holdout " + std::to_string(k) + ": needs at least " +
                                std::to_string(k) + " episodes (log files), got " +
                                std::to_string(n));
  fit->episodes.clear();
  held_out->episodes.clear();
  for (int e = 0; e < n; ++e)
    ((e + 1) % k == 0 ? held_out : fit)->episodes.push_back(log.episodes[e]);
}

double BodySize(const sim::Scene& scene, int body_index) {
  const sim::Body& body = scene.bodies[body_index];
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const sim::Shape& s : body.shapes) {
    const sim::Aabb box = sim::ComputeAabb(s, s.X_BS);
    if (!box.lo.allFinite() || !box.hi.allFinite()) continue;
    lo = lo.cwiseMin(box.lo);
    hi = hi.cwiseMax(box.hi);
  }
  if (!lo.allFinite()) return 0.0;
  return (hi - lo).norm();
}

namespace {

struct Accumulator {
  double position = 0.0, percent = 0.0, angle = 0.0;
  int samples = 0, angle_samples = 0, failed = 0;
  void Add(double dp, double size, bool has_angle, double angle_rad) {
    position += dp;
    percent += size > 0 ? 100.0 * dp / size : std::numeric_limits<double>::quiet_NaN();
    ++samples;
    if (has_angle) {
      angle += angle_rad * 180.0 / M_PI;
      ++angle_samples;
    }
  }
  RolloutError Mean() const {
    RolloutError r;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    r.samples = samples;
    r.failed_rollouts = failed;
    r.position_m = samples > 0 ? position / samples : nan;
    r.position_percent = samples > 0 ? percent / samples : nan;
    r.orientation_deg = angle_samples > 0 ? angle / angle_samples : nan;
    return r;
  }
};

// Position error and rotation angle of body track b at sample i against a simulated pose q
// (planar x, y, θ; spatial x, y, z, qw..qz).
void Compare(bool planar, const BodyTrack& b, int i, const Eigen::VectorXd& q, double size,
             Accumulator* acc) {
  const int np = planar ? 2 : 3;
  const double dp = (b.pose.row(i).head(np).transpose() - q.head(np)).norm();
  double angle = 0.0;
  if (b.has_orientation) {
    if (planar) {
      angle = std::abs(std::remainder(b.pose(i, 2) - q[2], 2 * M_PI));
    } else {
      const Eigen::Quaterniond qs(q[3], q[4], q[5], q[6]);
      angle = RotationLog(LoggedQuaternion(b, i) * qs.normalized().conjugate()).norm();
    }
  }
  acc->Add(dp, size, b.has_orientation, angle);
}

}  // namespace

RolloutError EvaluateRollouts(const sim::Simulator& simulator, const sim::Params& params,
                              const Log& log, RolloutError* stationary) {
  const sim::Scene& scene = simulator.scene();
  const bool planar = Planar(simulator);
  Accumulator fit, still;
  for (const Episode& ep : log.episodes) {
    const State x0 = InitialStateFromLog(simulator, ep);
    const int steps = StepsTo(simulator, ep.t.front(), ep.t.back());
    const sim::Trajectory tr =
        simulator.Rollout(params, ColdStart(x0), std::vector<sim::StepInput>(steps));
    const bool ok = tr.ok && static_cast<int>(tr.states.size()) == steps + 1;
    if (!ok) ++fit.failed;
    for (const BodyTrack& b : ep.bodies) {
      if (!b.dynamic) continue;
      const double size = BodySize(scene, b.body_index);
      const int qo = scene.index(b.body_index).q;
      const int nq = planar ? 3 : 7;
      for (int i = 0; i < ep.num_samples(); ++i) {
        Compare(planar, b, i, b.pose.row(0).transpose(), size, &still);
        if (!ok) continue;
        int k = 0;
        double al = 0.0;
        if (steps > 0) Bracket(tr.states, ep.t[i], &k, &al);
        const State& xa = tr.states[k];
        const State& xb = tr.states[std::min(k + 1, steps)];
        Eigen::VectorXd q = (1 - al) * xa.q.segment(qo, nq) + al * xb.q.segment(qo, nq);
        if (!planar) {
          const Eigen::Quaterniond qa(xa.q[qo + 3], xa.q[qo + 4], xa.q[qo + 5], xa.q[qo + 6]);
          const Eigen::Quaterniond qb(xb.q[qo + 3], xb.q[qo + 4], xb.q[qo + 5], xb.q[qo + 6]);
          const Eigen::Quaterniond qi = qa.slerp(al, qb);
          q.tail(4) << qi.w(), qi.x(), qi.y(), qi.z();
        }
        Compare(planar, b, i, q, size, &fit);
      }
    }
  }
  if (stationary) *stationary = still.Mean();
  return fit.Mean();
}

HoldoutResult EvaluateHoldout(const sim::Simulator& simulator, const sim::Params& fitted,
                              const Log& held_out) {
  HoldoutResult r;
  for (const Episode& ep : held_out.episodes) r.files.push_back(ep.file);
  r.fitted = EvaluateRollouts(simulator, fitted, held_out, &r.stationary);
  r.initial_guess = EvaluateRollouts(simulator, simulator.DefaultParams(), held_out, nullptr);
  return r;
}

}  // namespace vinci::estimation
