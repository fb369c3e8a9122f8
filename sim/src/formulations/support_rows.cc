#include "vinci/sim/formulations/support_rows.h"

#include <cmath>

#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

}  // namespace

SupportRows AssembleSupport(const Scene& model, const State& x, double h, bool quadratic) {
  SupportRows r;
  AssembleSupportInto(model, x, h, quadratic, &r);
  return r;
}

void AssembleSupportInto(const Scene& model, const State& x, double h, bool quadratic,
                         SupportRows* out) {
  SupportRows& r = *out;
  r.body.clear();
  r.first.clear();
  r.count.clear();
  int ns = 0, ncol = 0;
  for (int bi : model.dynamic_bodies()) {
    const Support& s = model.bodies[bi].support;
    ns += static_cast<int>(s.points_B.size());
    ncol += static_cast<int>(s.points_B.size()) * (quadratic ? 2 : s.directions);
  }
  r.limit.resize(ns);
  r.hN.resize(ns);
  if (ns == 0) {  // no support points: G_s is nv × 0 (setZero's result, storage kept)
    if (r.G_s.rows() != model.num_velocities() || r.G_s.cols() != 0)
      r.G_s.resize(model.num_velocities(), 0);
    return;
  }
  r.G_s.setZero(model.num_velocities(), ncol);
  int k = 0, col = 0;
  for (int bi : model.dynamic_bodies()) {
    const Body& b = model.bodies[bi];
    const Support& s = b.support;
    if (s.empty()) continue;
    const BodyIndex& idx = model.index(bi);
    const Isometry3d X_WB = PoseFromQ(model.dim, x.q.data() + idx.q);
    thread_local std::vector<double> N;  // storage reuse
    SupportNormalForcesInto(model, b, &N);
    const int nd = quadratic ? 2 : s.directions;
    for (std::size_t p = 0; p < s.points_B.size(); ++p, ++k) {
      const Vector3d p_W = X_WB * Vector3d(s.points_B[p].x(), s.points_B[p].y(), 0.0);
      r.limit[k] = h * s.mu * N[p];
      r.hN[k] = h * N[p];
      r.body.push_back(bi);
      r.first.push_back(col);
      r.count.push_back(nd);
      for (int j = 0; j < nd; ++j, ++col) {
        const double phi = 2.0 * kPi * j / nd;
        const Vector3d d = quadratic ? Vector3d(j == 0 ? 1.0 : 0.0, j == 1 ? 1.0 : 0.0, 0.0)
                                     : Vector3d(std::cos(phi), std::sin(phi), 0.0);
        r.G_s.block(idx.v, col, 3, 1) = PointVelocityRow(model.dim, X_WB, p_W, d).transpose();
      }
    }
  }
}

}  // namespace vinci::sim
