#include "vinci/sim/plate/plate_theory.h"

#include <Eigen/Dense>
#include <cmath>
#include <stdexcept>

namespace vinci::sim {
namespace {

// The plate point's in-plane velocity, normal force per unit mass and in-plane gravity per unit
// mass at one quadrature time, in the plate's instantaneous tangent basis (t1, t2).
struct Sample {
  Vector2d u;      // plate velocity (m/s)
  double n = 0.0;  // N/m (m/s²), clipped at 0
  Vector2d f;      // F_t/m (m/s²)
};

// World velocity of the plate's material point r_P at t (exact kinematics of the prescription).
Vector3d PointVelocityAt(const PlateTheoryInput& in, const Vector3d& r_P, double t) {
  const BodyKinematics k = EvaluateMotion(in.motion, in.X_WP0, in.planar, t);
  const Vector3d p = k.X_WB * r_P;
  return k.v_WB + k.w_WB.cross(p - k.X_WB.translation());
}

std::vector<Sample> SampleCycle(const PlateTheoryInput& in, const Vector3d& r_P) {
  const int m = in.samples;
  std::vector<Sample> s(m);
  // Acceleration by a central difference of the exact velocity: δ = 1e-5 T keeps the truncation
  // error ~(2π·1e-5)²/6 ≈ 7e-10 relative and the rounding ~1e-16 |v|/δ negligible.
  const double dt = 1e-5 * in.period;
  const Vector3d n_B = in.planar ? Vector3d(Vector3d::UnitY()) : Vector3d(Vector3d::UnitZ());
  const Vector3d t1_B = Vector3d::UnitX();
  const Vector3d t2_B = in.planar ? Vector3d(Vector3d::Zero()) : Vector3d(Vector3d::UnitY());
  for (int i = 0; i < m; ++i) {
    const double t = (i + 0.5) * in.period / m;
    const BodyKinematics k = EvaluateMotion(in.motion, in.X_WP0, in.planar, t);
    const Matrix3d& R = k.X_WB.linear();
    const Vector3d n = R * n_B, t1 = R * t1_B, t2 = R * t2_B;
    const Vector3d p = k.X_WB * r_P;
    const Vector3d v = k.v_WB + k.w_WB.cross(p - k.X_WB.translation());
    const Vector3d a =
        (PointVelocityAt(in, r_P, t + dt) - PointVelocityAt(in, r_P, t - dt)) / (2.0 * dt);
    s[i].u = Vector2d(v.dot(t1), v.dot(t2));
    s[i].n = std::max(0.0, (a - in.gravity_W).dot(n));
    s[i].f = Vector2d(in.gravity_W.dot(t1), in.gravity_W.dot(t2));
  }
  return s;
}

}  // namespace

PointTheoryResult SolvePointVelocity(const PlateTheoryInput& in, const Vector2d& r_xy) {
  if (!(in.period > 0.0) || !std::isfinite(in.period))
    throw std::invalid_argument("plate theory: period must be > 0 (s), got " +
                                std::to_string(in.period));
  if (in.samples < 8)
    throw std::invalid_argument("plate theory: samples must be >= 8, got " +
                                std::to_string(in.samples));
  if (!(in.mu >= 0.0)) throw std::invalid_argument("plate theory: mu must be >= 0");
  const Vector3d r_P = in.planar ? Vector3d(r_xy.x(), 0.0, 0.0) : Vector3d(r_xy.x(), r_xy.y(), 0.0);
  const std::vector<Sample> s = SampleCycle(in, r_P);
  const int m = static_cast<int>(s.size());
  const bool planar = in.planar;

  PointTheoryResult res;
  double sum_mun = 0.0, speed = 0.0;
  Vector2d f_mean = Vector2d::Zero(), u_mean = Vector2d::Zero();
  int in_contact = 0;
  for (const Sample& x : s) {
    sum_mun += in.mu * x.n / m;
    f_mean += x.f / m;
    u_mean += x.u / m;
    speed = std::max(speed, x.u.norm());
    if (x.n > 0.0) ++in_contact;
  }
  res.contact_fraction = static_cast<double>(in_contact) / m;
  if (!(sum_mun > 0.0)) {
    res.failure = "no friction over the cycle (mu = 0 or the part never touches the plate)";
    return res;
  }
  if (f_mean.norm() >= sum_mun) {
    res.failure =
        "the in-plane force exceeds the cycle-averaged friction bound: the part slides "
        "away without a steady velocity";
    return res;
  }
  const double scale = std::max(speed, 1e-12);
  // Φ_ε(v) = Σ w μN √(|v − u|² + ε²) − v·F̄ and its gradient and Hessian.
  const auto phi = [&](const Vector2d& v, double eps) {
    double f = -v.dot(f_mean);
    for (const Sample& x : s) f += in.mu * x.n / m * std::sqrt((v - x.u).squaredNorm() + eps * eps);
    return f;
  };
  Vector2d v = u_mean;
  for (double rel = 1e-3; rel >= 1e-12; rel *= 1e-3) {
    const double eps = rel * scale;
    for (int it = 0; it < 100; ++it) {
      Vector2d g = -f_mean;
      Eigen::Matrix2d H = Eigen::Matrix2d::Zero();
      for (const Sample& x : s) {
        const double w = in.mu * x.n / m;
        if (w == 0.0) continue;
        const Vector2d d = v - x.u;
        const double r = std::sqrt(d.squaredNorm() + eps * eps);
        g += w * d / r;
        H += w * (Eigen::Matrix2d::Identity() / r - d * d.transpose() / (r * r * r));
      }
      if (planar) {
        g.y() = 0.0;
        H(0, 1) = H(1, 0) = 0.0;
        H(1, 1) = 1.0;
      }
      ++res.iterations;
      if (g.norm() <= 1e-13 * sum_mun) break;
      Vector2d step = -H.ldlt().solve(g);
      if (!step.allFinite()) step = -g;
      const double f0 = phi(v, eps);
      double alpha = 1.0;
      while (alpha > 1e-20 && phi(v + alpha * step, eps) > f0 + 1e-4 * alpha * g.dot(step))
        alpha *= 0.5;
      if (alpha <= 1e-20) break;
      v += alpha * step;
      if ((alpha * step).norm() <= 1e-15 * scale) break;
    }
  }
  // Residual of the unsmoothed balance: the subgradient of minimum norm (ties v = u_i take
  // whatever part of the static friction ball the balance needs).
  Vector2d g = -f_mean;
  double tied = 0.0;
  for (const Sample& x : s) {
    const double w = in.mu * x.n / m;
    const Vector2d d = v - x.u;
    const double r = d.norm();
    if (r > 1e-9 * scale)
      g += w * d / r;
    else
      tied += w;
  }
  if (planar) g.y() = 0.0;
  res.residual = std::max(0.0, g.norm() - tied) / sum_mun;
  res.v = planar ? Vector2d(v.x(), 0.0) : v;
  res.ok = res.residual < 1e-6 && v.allFinite();
  if (!res.ok)
    res.failure =
        "Newton did not reach the balance (residual " + std::to_string(res.residual) + ")";
  return res;
}

PlateTheoryInput PlateTheoryFromScene(const Scene& scene, int plate, int part, double frequency) {
  const int n = static_cast<int>(scene.bodies.size());
  if (plate < 0 || plate >= n || part < 0 || part >= n)
    throw std::invalid_argument("plate theory: plate or part index out of range");
  if (!(frequency > 0.0)) throw std::invalid_argument("plate theory: frequency must be > 0 (Hz)");
  const Body& p = scene.bodies[plate];
  const Body& q = scene.bodies[part];
  PlateTheoryInput in;
  in.motion = p.motion;
  in.X_WP0 = p.X_WB0;
  in.planar = scene.dim == Dim::kPlanar;
  in.gravity_W = scene.gravity_W;
  in.period = 1.0 / frequency;
  in.mu = scene.default_mu;
  if (!p.shapes.empty() && !q.shapes.empty())
    in.mu = scene.Mu(p.shapes.front().material, q.shapes.front().material);
  return in;
}

}  // namespace vinci::sim
