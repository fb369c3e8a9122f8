// Contact-like LCPs for the solver tests: a box on a plane and random multi-body contact
// configurations, assembled as the Stewart–Trinkle velocity-level LCP.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "vinci/sim/solvers/lcp.h"

namespace vinci::sim::testing {

using Eigen::Matrix3d;
using Eigen::Vector3d;

constexpr double kContactGravity = 9.81;  // m/s²

/// Uniform random matrix with entries in [lo, hi).
inline MatrixXd Uniform(int rows, int cols, std::mt19937* rng, double lo = -1.0, double hi = 1.0) {
  std::uniform_real_distribution<double> u(lo, hi);
  MatrixXd A(rows, cols);
  for (int j = 0; j < cols; ++j) {
    for (int i = 0; i < rows; ++i) A(i, j) = u(*rng);
  }
  return A;
}

inline Vector3d Cross(const Vector3d& a, const Vector3d& b) { return a.cross(b); }

// Stewart–Trinkle velocity-level LCP in (p_n, p_f, λ):
//   w_n = Gnᵀ v⁺ ⟂ p_n,  w_f = Gfᵀ v⁺ + E λ ⟂ p_f,  w_λ = μ p_n − Eᵀ p_f ⟂ λ,
//   v⁺ = v + M⁻¹(h f_ext + Gn p_n + Gf p_f),
// for spatial bodies with generalized velocity (v_WB, ω_W) each.
struct ContactLcp {
  LcpProblem lcp;
  MatrixXd m_inv, g_n, g_f;
  VectorXd v_free;  // v + h M⁻¹ f_ext
  int num_contacts = 0;
  int num_directions = 0;
  VectorXd VelocityAfter(const VectorXd& z) const {
    const int nc = num_contacts, nf = num_contacts * num_directions;
    return v_free + m_inv * (g_n * z.head(nc) + g_f * z.segment(nc, nf));
  }
};

inline ContactLcp AssembleContactLcp(const MatrixXd& m_inv, const MatrixXd& g_n,
                                     const MatrixXd& g_f, const VectorXd& v_free, double mu,
                                     int nd) {
  ContactLcp c;
  const int nc = static_cast<int>(g_n.cols());
  const int nf = nc * nd;
  const int n = 2 * nc + nf;
  c.m_inv = m_inv;
  c.g_n = g_n;
  c.g_f = g_f;
  c.v_free = v_free;
  c.num_contacts = nc;
  c.num_directions = nd;
  MatrixXd E = MatrixXd::Zero(nf, nc);
  for (int i = 0; i < nc; ++i) E.block(i * nd, i, nd, 1).setOnes();
  MatrixXd M = MatrixXd::Zero(n, n);
  M.block(0, 0, nc, nc) = g_n.transpose() * m_inv * g_n;
  M.block(0, nc, nc, nf) = g_n.transpose() * m_inv * g_f;
  M.block(nc, 0, nf, nc) = g_f.transpose() * m_inv * g_n;
  M.block(nc, nc, nf, nf) = g_f.transpose() * m_inv * g_f;
  M.block(nc, nc + nf, nf, nc) = E;
  M.block(nc + nf, 0, nc, nc) = mu * MatrixXd::Identity(nc, nc);
  M.block(nc + nf, nc, nc, nf) = -E.transpose();
  VectorXd q = VectorXd::Zero(n);
  q.head(nc) = g_n.transpose() * v_free;
  q.segment(nc, nf) = g_f.transpose() * v_free;
  c.lcp = LcpProblem{M, q, {}};
  return c;
}

// Jacobian columns of one contact on body `b` (6 generalized velocities per body) at offset
// r_W from its center of mass: [dir; r × dir].
inline void AddContactColumns(int body, const Vector3d& r_W, const Vector3d& normal, int nd,
                              int contact, MatrixXd* g_n, MatrixXd* g_f, double sign = 1.0) {
  Vector3d t1 = normal.unitOrthogonal();
  Vector3d t2 = normal.cross(t1);
  g_n->block<3, 1>(6 * body, contact) += sign * normal;
  g_n->block<3, 1>(6 * body + 3, contact) += sign * Cross(r_W, normal);
  for (int j = 0; j < nd; ++j) {
    const double a = 2.0 * M_PI * j / nd;
    const Vector3d d = std::cos(a) * t1 + std::sin(a) * t2;
    g_f->block<3, 1>(6 * body, contact * nd + j) += sign * d;
    g_f->block<3, 1>(6 * body + 3, contact * nd + j) += sign * Cross(r_W, d);
  }
}

// A box (half extents `half`, mass `mass`, yaw `yaw`) resting on the plane z = 0 with its 4
// bottom corners in contact, generalized velocity v = (v_WB, ω_W), friction μ, step h.
inline ContactLcp BoxOnPlane(double mass, const Vector3d& half, double yaw, const VectorXd& v,
                             double mu, double h, int nd) {
  const Matrix3d R = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d inertia_B(mass / 3.0 * (half.y() * half.y() + half.z() * half.z()),
                           mass / 3.0 * (half.x() * half.x() + half.z() * half.z()),
                           mass / 3.0 * (half.x() * half.x() + half.y() * half.y()));
  MatrixXd m_inv = MatrixXd::Zero(6, 6);
  m_inv.topLeftCorner(3, 3) = Matrix3d::Identity() / mass;
  m_inv.bottomRightCorner(3, 3) = R * inertia_B.cwiseInverse().asDiagonal() * R.transpose();
  const int nc = 4;
  MatrixXd g_n = MatrixXd::Zero(6, nc), g_f = MatrixXd::Zero(6, nc * nd);
  int k = 0;
  for (double sx : {-1.0, 1.0}) {
    for (double sy : {-1.0, 1.0}) {
      const Vector3d r_W = R * Vector3d(sx * half.x(), sy * half.y(), -half.z());
      AddContactColumns(0, r_W, Vector3d::UnitZ(), nd, k++, &g_n, &g_f);
    }
  }
  VectorXd f_ext = VectorXd::Zero(6);
  f_ext(2) = -mass * kContactGravity;
  return AssembleContactLcp(m_inv, g_n, g_f, v + h * m_inv * f_ext, mu, nd);
}

// Random contact-like LCP: `num_bodies` spatial bodies with random SPD inertia, contacts
// with the ground or between random pairs at random points and normals, random velocities.
inline ContactLcp RandomContactLcp(int num_bodies, int num_contacts, int nd, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> pick(0, num_bodies - 1);
  const int ndof = 6 * num_bodies;
  MatrixXd m_inv = MatrixXd::Zero(ndof, ndof);
  for (int b = 0; b < num_bodies; ++b) {
    const double mass = 1.0 + 0.5 * (u(*rng) + 1.0);
    const MatrixXd A = Uniform(3, 3, rng);
    const Matrix3d inertia = 0.05 * (A * A.transpose() + 0.5 * Matrix3d::Identity());
    m_inv.block(6 * b, 6 * b, 3, 3) = Matrix3d::Identity() / mass;
    m_inv.block(6 * b + 3, 6 * b + 3, 3, 3) = inertia.inverse();
  }
  MatrixXd g_n = MatrixXd::Zero(ndof, num_contacts);
  MatrixXd g_f = MatrixXd::Zero(ndof, num_contacts * nd);
  for (int c = 0; c < num_contacts; ++c) {
    const int a = pick(*rng);
    const Vector3d normal = Vector3d(0.3 * u(*rng), 0.3 * u(*rng), 1.0).normalized();
    const Vector3d r_a(0.2 * u(*rng), 0.2 * u(*rng), -0.1);
    AddContactColumns(a, r_a, normal, nd, c, &g_n, &g_f);
    if (u(*rng) > 0.0) {  // contact with another body (b above a), else with the ground
      const int b = pick(*rng);
      if (b != a) {
        const Vector3d r_b(0.2 * u(*rng), 0.2 * u(*rng), 0.1);
        AddContactColumns(b, r_b, normal, nd, c, &g_n, &g_f, -1.0);
      }
    }
  }
  VectorXd v = 0.5 * Uniform(ndof, 1, rng);
  for (int b = 0; b < num_bodies; ++b) v(6 * b + 2) -= kContactGravity * 0.01;  // falling one step
  return AssembleContactLcp(m_inv, g_n, g_f, v, 0.5, nd);
}

}  // namespace vinci::sim::testing
