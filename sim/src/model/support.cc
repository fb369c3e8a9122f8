#include "vinci/sim/model/support.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Relative singular-value cut-off for the rank of the 3×n moment-balance matrix (collinear
// points make it rank 2).
constexpr double kRankTolerance = 1e-10;
// A static distribution must balance force and moment to this (relative to the load 1 and the
// support extent): the solver's tolerance with a wide margin.
constexpr double kBalanceTolerance = 1e-8;
// The dual Newton iteration of ComputeSupportFractions: stop at ‖g‖∞ below this (the load is 1),
// after at most this many steps; the Hessian's relative diagonal shift keeps a step defined when
// fewer than `rank` points are active.
constexpr double kNewtonTolerance = 1e-14;
constexpr int kMaxNewtonSteps = 100;
constexpr double kNewtonRegularization = 1e-12;

}  // namespace

std::vector<double> ComputeSupportFractions(const std::vector<Vector3d>& points_B,
                                            const std::string& context) {
  const int n = static_cast<int>(points_B.size());
  if (n == 0) throw std::invalid_argument(context + ": no support points");
  double extent = 0.0;
  for (const Vector3d& p : points_B) extent = std::max(extent, p.head<2>().norm());
  const double scale = std::max(extent, 1e-12);
  // A f = b: Σ f = 1, Σ f x/scale = 0, Σ f y/scale = 0.
  MatrixXd A(3, n);
  for (int k = 0; k < n; ++k) A.col(k) << 1.0, points_B[k].x() / scale, points_B[k].y() / scale;
  Eigen::Vector3d b(1.0, 0.0, 0.0);
  // Keep the independent combinations of the rows (collinear points drop one).
  Eigen::JacobiSVD<MatrixXd> svd(A, Eigen::ComputeFullU);
  const VectorXd sv = svd.singularValues();
  int rank = 0;
  for (int i = 0; i < sv.size(); ++i)
    if (sv[i] > kRankTolerance * sv[0]) ++rank;
  const MatrixXd U = svd.matrixU().leftCols(rank);
  const MatrixXd Ar = U.transpose() * A;
  const VectorXd br = U.transpose() * b;
  const auto fail = [&]() {
    std::ostringstream msg;
    msg << context
        << ": no static distribution of the load over the support points: the centre of mass "
           "(the body origin) is outside their convex hull";
    throw std::invalid_argument(msg.str());
  };
  if ((U * br - b).norm() > kBalanceTolerance) fail();

  // min ½‖f‖² s.t. A_r f = b_r, f ≥ 0. Its KKT conditions give f = (A_rᵀ λ)₊ for the λ that
  // solves g(λ) = A_r (A_rᵀ λ)₊ − b_r = 0, the gradient of the convex, piecewise-quadratic dual
  // φ(λ) = ½‖(A_rᵀ λ)₊‖² − b_rᵀ λ (rank ≤ 3 unknowns). Newton on g with the active set
  // F = {k : (A_rᵀ λ)_k > 0} (Hessian A_F A_Fᵀ) and a backtracking line search on φ; it ends in
  // finitely many steps on a piecewise-quadratic φ. No feasible f (the centre of mass outside
  // the hull) makes φ unbounded below: the iteration cap and the balance check below catch it.
  const auto phi = [&](const VectorXd& l) {
    return 0.5 * (Ar.transpose() * l).cwiseMax(0.0).squaredNorm() - br.dot(l);
  };
  // Start from the multiplier of the minimum-norm solution without the sign constraints.
  VectorXd lambda = (Ar * Ar.transpose()).ldlt().solve(br);
  for (int iter = 0; iter < kMaxNewtonSteps; ++iter) {
    const VectorXd u = Ar.transpose() * lambda;
    const VectorXd g = Ar * u.cwiseMax(0.0) - br;
    if (g.lpNorm<Eigen::Infinity>() <= kNewtonTolerance) break;
    MatrixXd H = MatrixXd::Zero(rank, rank);
    for (int c = 0; c < n; ++c)
      if (u[c] > 0.0) H += Ar.col(c) * Ar.col(c).transpose();
    H.diagonal().array() += kNewtonRegularization * std::max(1.0, H.trace());
    const VectorXd d = -H.ldlt().solve(g);
    double t = 1.0;
    const double phi0 = phi(lambda), slope = g.dot(d);
    while (t > 1e-12 && phi(lambda + t * d) > phi0 + 1e-4 * t * slope) t *= 0.5;
    lambda += t * d;
  }
  VectorXd f = (Ar.transpose() * lambda).cwiseMax(0.0);
  if ((A * f - b).lpNorm<Eigen::Infinity>() > kBalanceTolerance) fail();
  f /= f.sum();
  return std::vector<double>(f.data(), f.data() + n);
}

void FinalizeSupports(Scene* scene) {
  const FormulationType type = scene->options.formulation;
  if (scene->dim != Dim::kPlanar &&
      (type == FormulationType::kQuasistaticDlc || type == FormulationType::kQuasistaticDqc ||
       type == FormulationType::kDynamicDqc))
    throw std::invalid_argument(
        "stepper formulation quasistatic-dlc, quasistatic-dqc and dynamic-dqc need a planar "
        "scene (dimension 2)");
  bool any = false;
  for (const Body& b : scene->bodies) any = any || !b.support.empty();
  if (!any) return;
  const SupportPlane& plane = scene->plane;
  if (!(plane.g > 0.0) || !std::isfinite(plane.g))
    throw std::invalid_argument("support plane: g must be a finite number > 0");
  if (!(plane.tilt >= 0.0 && plane.tilt <= kPi / 2))
    throw std::invalid_argument("support plane: tilt must be in [0, pi/2] rad");
  for (Body& b : scene->bodies) {
    Support& s = b.support;
    if (s.empty()) continue;
    const std::string context = "body '" + b.name + "': support";
    if (scene->dim != Dim::kPlanar)
      throw std::invalid_argument(context + ": support points need a planar scene");
    if (b.kind != BodyKind::kDynamic)
      throw std::invalid_argument(context + ": support points need a dynamic body");
    if (!(s.mu >= 0.0) || !std::isfinite(s.mu))
      throw std::invalid_argument(context + ": mu must be a finite number >= 0");
    if (s.directions < 3)
      throw std::invalid_argument(context + ": directions must be an integer >= 3");
    for (const Vector3d& p : s.points_B)
      if (!p.allFinite()) throw std::invalid_argument(context + ": non-finite support point");
    if (s.static_distribution) {
      if (!s.normal_forces.empty())
        throw std::invalid_argument(context +
                                    ": give either normal forces or a static distribution");
      s.load_fractions = ComputeSupportFractions(s.points_B, context);
    } else {
      if (s.normal_forces.size() != s.points_B.size())
        throw std::invalid_argument(context + ": " + std::to_string(s.normal_forces.size()) +
                                    " normal forces for " + std::to_string(s.points_B.size()) +
                                    " points");
      for (double N : s.normal_forces)
        if (!(N >= 0.0) || !std::isfinite(N))
          throw std::invalid_argument(context + ": normal forces must be finite numbers >= 0");
    }
  }
}

std::vector<double> SupportNormalForces(const Scene& scene, const Body& body) {
  std::vector<double> N;
  SupportNormalForcesInto(scene, body, &N);
  return N;
}

void SupportNormalForcesInto(const Scene& scene, const Body& body, std::vector<double>* N) {
  const Support& s = body.support;
  if (!s.static_distribution) {
    N->assign(s.normal_forces.begin(), s.normal_forces.end());
    return;
  }
  const double load = body.mass * scene.plane.g * std::cos(scene.plane.tilt);
  N->resize(s.load_fractions.size());
  for (std::size_t k = 0; k < N->size(); ++k) (*N)[k] = s.load_fractions[k] * load;
}

bool HasSupports(const Scene& scene) {
  for (int bi : scene.dynamic_bodies())
    if (!scene.bodies[bi].support.empty()) return true;
  return false;
}

}  // namespace vinci::sim
