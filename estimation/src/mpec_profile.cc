// Standard errors at a relaxed (unpolished) MPEC solution from the curvature of the relaxed
// problem's profile over θ (mpec_internal::ProfileCovariance, mpec_problem.h).
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "mpec_problem.h"

namespace vinci::estimation::mpec_internal {

using sim::MatrixXd;
using sim::VectorXd;

namespace {

// Ipopt iterations of one profile point at most.
constexpr int kProfileIterations = 500;
// First step: this fraction of max(|θ_i|, kStepFloor).
constexpr double kRelativeStep = 1e-2;
constexpr double kStepFloor = 1e-2;
// The step is rescaled once so that f rises by about kTargetRise (χ²: (δ / s.e.)² = 4, two
// standard errors) unless the first rise is within [kMinRise, kMaxRise].
constexpr double kTargetRise = 4.0;
constexpr double kMinRise = 0.25;
constexpr double kMaxRise = 25.0;

// f and ∂f/∂θ at θ with the other unknowns re-optimized (the relaxed NLP at fixed θ).
struct ProfilePoint {
  bool ok = false;
  double f = 0.0;
  VectorXd gradient;
};

ProfilePoint SolveAt(const MpecEstimationProblem& p, const MpecSolution& sol,
                     const MpecSolverOptions& so, const VectorXd& theta, int* iterations,
                     int* stages, std::string* why) {
  const FixedThetaProblem fixed(p, theta, sol.x);
  const MpecSolution s = SolveMpec(fixed, so, &sol.relaxed);
  *iterations += s.iterations;
  *stages += s.stages;
  ProfilePoint point;
  if (!s.solved || !s.x.allFinite() || !p.Objective(s.x, &point.f)) {
    std::ostringstream w;
    w << "the relaxed NLP at θ = " << theta.transpose() << ": " << s.reason;
    *why = w.str();
    return point;
  }
  point.gradient = EnvelopeGradient(p, static_cast<int>(theta.size()), s.x, s.lambda);
  point.ok = point.gradient.allFinite();
  if (!point.ok) *why = "the envelope gradient is not finite";
  return point;
}

}  // namespace

bool ProfileCovariance(const MpecEstimationProblem& p, const MpecSolution& sol,
                       const MpecSolverOptions& options, MatrixXd* covariance, int* iterations,
                       int* stages, std::string* why) {
  const VectorXd theta = p.Parameters(sol.x);
  const int nt = static_cast<int>(theta.size());
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  covariance->setConstant(nt, nt, kNaN);
  if (sol.relaxed.lambda.size() == 0 || !(sol.final_epsilon > 0)) {
    *why = "not a relaxed Scholtes solution";
    return false;
  }
  VectorXd xl, xu, gl, gu;
  p.Bounds(&xl, &xu, &gl, &gu);
  MpecSolverOptions so = options;
  so.method = ComplementarityMethod::kScholtes;
  so.epsilon_start = so.epsilon_end = std::max(sol.final_epsilon, kProfileEpsilon);
  so.polish = false;
  so.early_polish_tolerance = -1.0;
  so.epsilon_floor = 0.0;
  so.max_iterations = std::min(so.max_iterations, kProfileIterations);
  so.progress = nullptr;
  // f(θ̂) the same way as the other points (same ε, same start).
  const ProfilePoint center = SolveAt(p, sol, so, theta, iterations, stages, why);
  if (!center.ok) return false;
  const double f0 = center.f;

  MatrixXd hessian = MatrixXd::Zero(nt, nt);
  MatrixXd grad_diff =
      MatrixXd::Zero(nt, nt);  // column i: (∇f(θ̂ + δ_i e_i) − ∇f(θ̂ − δ_i e_i)) / 2δ_i
  std::vector<int> free;
  for (int i = 0; i < nt; ++i) {
    const double room = std::min(theta[i] - xl[i], xu[i] - theta[i]);
    double delta = std::min(kRelativeStep * std::max(std::abs(theta[i]), kStepFloor), 0.5 * room);
    if (!(delta > 0)) continue;  // at a bound: held
    ProfilePoint plus, minus;
    for (int round = 0; round < 2; ++round) {
      VectorXd tp = theta, tm = theta;
      tp[i] += delta;
      tm[i] -= delta;
      plus = SolveAt(p, sol, so, tp, iterations, stages, why);
      if (!plus.ok) return false;
      minus = SolveAt(p, sol, so, tm, iterations, stages, why);
      if (!minus.ok) return false;
      const double rise = 0.5 * (plus.f + minus.f) - f0;
      if (round == 1 || (rise >= kMinRise && rise <= kMaxRise)) break;
      const double scaled = delta * std::sqrt(kTargetRise / std::max(rise, 1e-4));
      const double next = std::min(std::min(scaled, 10 * delta), 0.5 * room);
      if (next == delta) break;
      delta = next;
    }
    hessian(i, i) = (plus.f + minus.f - 2 * f0) / (delta * delta);
    grad_diff.col(i) = (plus.gradient - minus.gradient) / (2 * delta);
    free.push_back(i);
  }
  for (std::size_t a = 0; a < free.size(); ++a)
    for (std::size_t b = 0; b < a; ++b) {
      const int i = free[a], j = free[b];
      hessian(i, j) = hessian(j, i) = 0.5 * (grad_diff(i, j) + grad_diff(j, i));
    }
  const int nf = static_cast<int>(free.size());
  if (nf == 0) return true;
  MatrixXd h(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) h(a, b) = hessian(free[a], free[b]);
  const Eigen::LDLT<MatrixXd> ldlt(h);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() || !(ldlt.vectorD().minCoeff() > 0)) {
    std::ostringstream w;
    w << "the profile's curvature is not positive definite (diagonal " << h.diagonal().transpose()
      << ")";
    *why = w.str();
    return false;
  }
  const MatrixXd c = 2.0 * ldlt.solve(MatrixXd::Identity(nf, nf));
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) (*covariance)(free[a], free[b]) = c(a, b);
  return true;
}

}  // namespace vinci::estimation::mpec_internal
