// Shared helpers for the sim tests: loading the bundled example scenes, energies, rollouts.
#pragma once

#include <cmath>
#include <cstring>
#include <random>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim::testing {

/// Loads examples/scenes/<name>.
inline Scene LoadExample(const std::string& name) {
  return LoadSceneFile(std::string(VINCI_SOURCE_DIR) + "/examples/scenes/" + name);
}

/// True if a and b have the same size and the same bits (an empty vector's data() may be null,
/// which memcmp must not see).
inline bool SameBits(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  if (a.size() != b.size()) return false;
  return a.size() == 0 ||
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

/// A banded P-matrix LCP of size n: M = AᵀA + S + 0.1 I with A banded (half-width 2) and S
/// skew (positive definite symmetric part, so the solution is unique), q ~ N(0, 1).
inline LcpProblem RandomBandedPLcp(int n, std::mt19937* rng) {
  std::normal_distribution<double> g;
  MatrixXd A = MatrixXd::Zero(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (std::abs(i - j) <= 2) A(i, j) = g(*rng);
  MatrixXd S = MatrixXd::Zero(n, n);
  for (int i = 0; i + 1 < n; ++i) {
    const double s = g(*rng);
    S(i, i + 1) = s;
    S(i + 1, i) = -s;
  }
  LcpProblem p;
  p.M = A.transpose() * A + S + 0.1 * MatrixXd::Identity(n, n);
  p.q = VectorXd::NullaryExpr(n, [&]() { return g(*rng); });
  return p;
}

/// Params with the named entries overwritten.
inline Params WithParams(const Simulator& sim,
                         const std::vector<std::pair<std::string, double>>& values) {
  Params p = sim.DefaultParams();
  for (const auto& [name, v] : values) p.values[sim.scene().param_table().Index(name)] = v;
  return p;
}

/// Kinetic + gravitational potential energy of the dynamic bodies (J).
inline double Energy(const Scene& s, const State& x) {
  double e = 0.0;
  for (int bi : s.dynamic_bodies()) {
    const Body& b = s.bodies[bi];
    const BodyIndex& idx = s.index(bi);
    if (s.dim == Dim::kPlanar) {
      const Eigen::Vector3d v = x.v.segment<3>(idx.v);
      e += 0.5 * b.mass * v.head<2>().squaredNorm() + 0.5 * b.inertia(2, 2) * v[2] * v[2];
      e -= b.mass * s.gravity_W.head<2>().dot(x.q.segment<2>(idx.q));
    } else {
      const Eigen::Matrix<double, 6, 1> v = x.v.segment<6>(idx.v);
      e +=
          0.5 * b.mass * v.head<3>().squaredNorm() + 0.5 * v.tail<3>().dot(b.inertia * v.tail<3>());
      e -= b.mass * s.gravity_W.dot(x.q.segment<3>(idx.q));
    }
  }
  return e;
}

}  // namespace vinci::sim::testing
