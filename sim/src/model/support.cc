#include "vinci/sim/model/support.h"

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/solvers/mcp.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Relative singular-value cut-off for the rank of the 3×n moment-balance matrix (collinear
// points make it rank 2).
constexpr double kRankTolerance = 1e-10;
// A static distribution must balance force and moment to this (relative to the load 1 and the
// support extent): the solver's tolerance with a wide margin.
constexpr double kBalanceTolerance = 1e-8;

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

  // min ½‖f‖² s.t. A_r f = b_r, f ≥ 0, as the mixed LCP of its KKT conditions in (f ≥ 0, λ):
  //   0 ≤ f ⊥ f − A_rᵀ λ ≥ 0,   A_r f − b_r = 0.
  McpProblem mcp;
  const double inf = std::numeric_limits<double>::infinity();
  mcp.lower = VectorXd::Zero(n + rank);
  mcp.upper = VectorXd::Constant(n + rank, inf);
  mcp.lower.tail(rank).setConstant(-inf);
  MatrixXd J = MatrixXd::Zero(n + rank, n + rank);
  J.topLeftCorner(n, n).setIdentity();
  J.topRightCorner(n, rank) = -Ar.transpose();
  J.bottomLeftCorner(rank, n) = Ar;
  VectorXd c = VectorXd::Zero(n + rank);
  c.tail(rank) = -br;
  mcp.evaluate = [J, c](const VectorXd& z, VectorXd* F, MatrixXd* Jz) {
    *F = J * z + c;
    if (Jz) *Jz = J;
  };
  VectorXd z = VectorXd::Zero(n + rank);
  z.head(n).setConstant(1.0 / n);
  McpOptions options;
  options.tolerance = 1e-13;
  const SolverReport report = McpSolver(options).Solve(mcp, &z);
  VectorXd f = z.head(n).cwiseMax(0.0);
  if (!report.ok() || (A * f - b).lpNorm<Eigen::Infinity>() > kBalanceTolerance) fail();
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
  const Support& s = body.support;
  if (!s.static_distribution) return s.normal_forces;
  const double load = body.mass * scene.plane.g * std::cos(scene.plane.tilt);
  std::vector<double> N(s.load_fractions.size());
  for (std::size_t k = 0; k < N.size(); ++k) N[k] = s.load_fractions[k] * load;
  return N;
}

bool HasSupports(const Scene& scene) {
  for (int bi : scene.dynamic_bodies())
    if (!scene.bodies[bi].support.empty()) return true;
  return false;
}

}  // namespace vinci::sim
