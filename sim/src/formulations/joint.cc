// Bilateral joint constraints ψ_b(q) = 0 and their exact Jacobians.
//
// Notation: J_a and J_b are the two copies of the joint frame, carried by bodies A and B:
// X_WJa = X_WA X_AJ, X_WJb = X_WB X_BJ; p_a, p_b their origins, c_A, c_B the body origins.
// Rows per (type, dim):
//   planar revolute   [p_a − p_b]_xy                                     (2)
//   planar prismatic  (p_b − p_a)·ŷ_Ja, wrap(θ_Ja − θ_Jb)                (2)
//   planar weld       [p_a − p_b]_xy, wrap(θ_Ja − θ_Jb)                  (3)
//   spatial spherical p_a − p_b                                          (3)
//   spatial fixed     p_a − p_b, e = vee(log(R_WJa R_WJbᵀ))              (6)
//   spatial revolute  p_a − p_b, ẑ_Ja·x̂_Jb, ẑ_Ja·ŷ_Jb                    (5)
//   spatial prismatic (p_b − p_a)·x̂_Ja, (p_b − p_a)·ŷ_Ja, e              (5)
// Every Jacobian is the exact derivative of its row, including the orientation error e, whose
// rows use the inverse SO(3) Jacobians of log (well defined for |e| < π; at |e| = π the log,
// and hence ψ itself, is discontinuous).
#include "vinci/sim/formulations/joint.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

const char* TypeName(JointType type) {
  switch (type) {
    case JointType::kRevolute:
      return "revolute (kRevolute)";
    case JointType::kPrismatic:
      return "prismatic (kPrismatic)";
    case JointType::kWeld:
      return "weld (kWeld)";
    case JointType::kSpherical:
      return "spherical (kSpherical)";
    case JointType::kFixed:
      return "fixed (kFixed)";
  }
  return "unknown";
}

// Row count, or 0 if the type does not exist in that dimension.
int RowCountOrZero(JointType type, Dim dim) {
  if (dim == Dim::kPlanar) {
    switch (type) {
      case JointType::kRevolute:
        return 2;
      case JointType::kPrismatic:
        return 2;
      case JointType::kWeld:
        return 3;
      default:
        return 0;
    }
  }
  switch (type) {
    case JointType::kRevolute:
      return 5;
    case JointType::kPrismatic:
      return 5;
    case JointType::kSpherical:
      return 3;
    case JointType::kFixed:
      return 6;
    default:
      return 0;
  }
}

std::string InvalidTypeMessage(JointType type, Dim dim) {
  const bool planar = dim == Dim::kPlanar;
  return std::string("joint type ") + TypeName(type) + " does not exist in a " +
         (planar ? "planar" : "spatial") + " scene; expected one of " +
         (planar ? "revolute, prismatic, weld" : "revolute, prismatic, spherical, fixed");
}

Matrix3d Skew(const Vector3d& v) {
  Matrix3d S;
  S << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return S;
}

// Orientation error e = vee(log(R)) with |e| ∈ [0, π], and the matrices D_l = J_l(e)⁻¹,
// D_r = J_r(e)⁻¹ of SO(3) (left/right Jacobians), so that Ṙ = [ω_s]× R gives ė = D_l ω_s and
// Ṙ = R [ω_b]× gives ė = D_r ω_b. With Φ = [e]× and θ = |e|:
//   D_l = I − Φ/2 + c Φ²,  D_r = I + Φ/2 + c Φ²,  c = (1 − (θ/2) cot(θ/2)) / θ².
void LogSO3WithJacobians(const Matrix3d& R, Vector3d* e, Matrix3d* D_l, Matrix3d* D_r) {
  Quaterniond q(R);
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const double n = q.vec().norm();  // sin(θ/2)
  const double half = std::atan2(n, q.w());
  const double theta = 2.0 * half;
  *e = n > 0.0 ? Vector3d((theta / n) * q.vec()) : Vector3d::Zero();
  double c;
  if (theta < 1e-3) {
    // Series of (1 − x cot x)/(4x²), x = θ/2; the next term (θ⁶/1209600) is below 1e-24.
    const double t2 = theta * theta;
    c = 1.0 / 12.0 + t2 / 720.0 + t2 * t2 / 30240.0;
  } else {
    // cot(θ/2) = w / sin(θ/2); finite up to θ = π, where c = 1/π².
    c = (1.0 - half * q.w() / n) / (theta * theta);
  }
  const Matrix3d Phi = Skew(*e);
  const Matrix3d sym = Matrix3d::Identity() + c * Phi * Phi;
  *D_l = sym - 0.5 * Phi;
  *D_r = sym + 0.5 * Phi;
}

// Planar helpers: a body's Jacobian of the velocity of its material point at r = p − c_B,
// projected on n: [n_x, n_y, r × n].
void PlanarPointRow(const Vector3d& r, const Vector3d& n, double sign, MatrixXd* J, int row) {
  (*J)(row, 0) = sign * n.x();
  (*J)(row, 1) = sign * n.y();
  (*J)(row, 2) = sign * (r.x() * n.y() - r.y() * n.x());
}

// Spatial: row of d/dt (n · p) for the material point at r = p − c_B of a body with rotation
// R_WB, in ν = (v_W, ω_B): [nᵀ, (R_WBᵀ (r × n))ᵀ].
void SpatialPointRow(const Matrix3d& R_WB, const Vector3d& r, const Vector3d& n, double sign,
                     MatrixXd* J, int row) {
  J->block<1, 3>(row, 0) = sign * n.transpose();
  J->block<1, 3>(row, 3) = sign * (R_WB.transpose() * r.cross(n)).transpose();
}

// Rows [row, row+3) of d/dt (p_a − p_b): J_a = [I, −[r_a]× R_WA], J_b = −[I, −[r_b]× R_WB].
void SpatialCoincidentPoints(const Matrix3d& R_WA, const Vector3d& r_a, const Matrix3d& R_WB,
                             const Vector3d& r_b, int row, JointRows* out) {
  out->J_a.block<3, 3>(row, 0).setIdentity();
  out->J_a.block<3, 3>(row, 3) = -Skew(r_a) * R_WA;
  out->J_b.block<3, 3>(row, 0) = -Matrix3d::Identity();
  out->J_b.block<3, 3>(row, 3) = Skew(r_b) * R_WB;
}

// Rows [row, row+3) for e = vee(log(R_WJa R_WJbᵀ)): with R = R_WJa R_WJbᵀ,
// Ṙ = [ω_A − R ω_B]× R (world angular velocities), so ė = D_l (ω_A − R ω_B)
// = D_l R_WA ω_A,body − D_r R_WB ω_B,body (using D_l R = D_r).
void SpatialOrientationError(const Matrix3d& R_WA, const Matrix3d& R_WJa, const Matrix3d& R_WB,
                             const Matrix3d& R_WJb, int row, JointRows* out) {
  Vector3d e;
  Matrix3d D_l, D_r;
  LogSO3WithJacobians(R_WJa * R_WJb.transpose(), &e, &D_l, &D_r);
  out->psi.segment<3>(row) = e;
  out->J_a.block<3, 3>(row, 3) = D_l * R_WA;
  out->J_b.block<3, 3>(row, 3) = -D_r * R_WB;
}

}  // namespace

int JointRowCount(JointType type, Dim dim) {
  const int m = RowCountOrZero(type, dim);
  if (m == 0) throw std::invalid_argument("JointRowCount: " + InvalidTypeMessage(type, dim));
  return m;
}

void EvaluateJoint(const Joint& joint, Dim dim, const BodyKinematics& A, const BodyKinematics& B,
                   JointRows* rows) {
  const int m = RowCountOrZero(joint.type, dim);
  if (m == 0) {
    throw std::invalid_argument("EvaluateJoint: joint '" + joint.name +
                                "': " + InvalidTypeMessage(joint.type, dim));
  }
  const int nv = VelocitySize(dim);
  // Eigen's resize keeps the buffer when the size is unchanged, so reused rows do not allocate.
  rows->psi.resize(m);
  rows->J_a.resize(m, nv);
  rows->J_b.resize(m, nv);
  rows->psi.setZero();
  rows->J_a.setZero();
  rows->J_b.setZero();

  const Matrix3d R_WA = A.X_WB.linear();
  const Matrix3d R_WB = B.X_WB.linear();
  const Vector3d c_A = A.X_WB.translation();
  const Vector3d c_B = B.X_WB.translation();
  const Matrix3d R_WJa = R_WA * joint.X_AJ.linear();
  const Matrix3d R_WJb = R_WB * joint.X_BJ.linear();
  const Vector3d p_a = A.X_WB * joint.X_AJ.translation();
  const Vector3d p_b = B.X_WB * joint.X_BJ.translation();
  const Vector3d r_a = p_a - c_A;  // J origin relative to body origins
  const Vector3d r_b = p_b - c_B;

  if (dim == Dim::kPlanar) {
    int row = 0;
    if (joint.type == JointType::kPrismatic) {
      // (p_b − p_a)·ŷ_Ja with ŷ_Ja fixed in A: its rate is the velocity of B's material point at
      // p_b minus that of A's material point at p_b (the latter includes ŷ's rotation), on ŷ.
      const Vector3d y = R_WJa.col(1);
      rows->psi(row) = (p_b - p_a).head<2>().dot(y.head<2>());
      PlanarPointRow(p_b - c_A, y, -1.0, &rows->J_a, row);
      PlanarPointRow(r_b, y, 1.0, &rows->J_b, row);
      ++row;
    } else {
      // Revolute and weld: p_a − p_b in x, y.
      const Vector3d d = p_a - p_b;
      rows->psi.head<2>() = d.head<2>();
      rows->J_a(0, 0) = 1.0;
      rows->J_a(1, 1) = 1.0;
      rows->J_a(0, 2) = -r_a.y();
      rows->J_a(1, 2) = r_a.x();
      rows->J_b(0, 0) = -1.0;
      rows->J_b(1, 1) = -1.0;
      rows->J_b(0, 2) = r_b.y();
      rows->J_b(1, 2) = -r_b.x();
      row = 2;
    }
    if (joint.type != JointType::kRevolute) {
      // θ_Ja − θ_Jb wrapped to (−π, π], from the relative planar rotation.
      const double ca = R_WJa(0, 0), sa = R_WJa(1, 0);
      const double cb = R_WJb(0, 0), sb = R_WJb(1, 0);
      double angle = std::atan2(sa * cb - ca * sb, ca * cb + sa * sb);
      if (angle <= -kPi) angle = kPi;
      rows->psi(row) = angle;
      rows->J_a(row, 2) = 1.0;
      rows->J_b(row, 2) = -1.0;
    }
    return;
  }

  switch (joint.type) {
    case JointType::kSpherical:
      rows->psi.head<3>() = p_a - p_b;
      SpatialCoincidentPoints(R_WA, r_a, R_WB, r_b, 0, rows);
      break;
    case JointType::kFixed:
      rows->psi.head<3>() = p_a - p_b;
      SpatialCoincidentPoints(R_WA, r_a, R_WB, r_b, 0, rows);
      SpatialOrientationError(R_WA, R_WJa, R_WB, R_WJb, 3, rows);
      break;
    case JointType::kRevolute: {
      rows->psi.head<3>() = p_a - p_b;
      SpatialCoincidentPoints(R_WA, r_a, R_WB, r_b, 0, rows);
      // d/dt (a·b) = (ω_A − ω_B)·(a × b) for a = ẑ_Ja fixed in A and b fixed in B (world ω).
      const Vector3d z_a = R_WJa.col(2);
      for (int k = 0; k < 2; ++k) {
        const Vector3d b = R_WJb.col(k);
        const Vector3d axb = z_a.cross(b);
        rows->psi(3 + k) = z_a.dot(b);
        rows->J_a.block<1, 3>(3 + k, 3) = (R_WA.transpose() * axb).transpose();
        rows->J_b.block<1, 3>(3 + k, 3) = -(R_WB.transpose() * axb).transpose();
      }
      break;
    }
    case JointType::kPrismatic: {
      // (p_b − p_a)·n for n = x̂_Ja, ŷ_Ja fixed in A: as in the planar case, A's row is its
      // material point at p_b.
      const Vector3d d = p_b - p_a;
      const Vector3d r_ab = p_b - c_A;
      for (int k = 0; k < 2; ++k) {
        const Vector3d n = R_WJa.col(k);
        rows->psi(k) = d.dot(n);
        SpatialPointRow(R_WA, r_ab, n, -1.0, &rows->J_a, k);
        SpatialPointRow(R_WB, r_b, n, 1.0, &rows->J_b, k);
      }
      SpatialOrientationError(R_WA, R_WJa, R_WB, R_WJb, 2, rows);
      break;
    }
    case JointType::kWeld:
      break;  // rejected above
  }
}

}  // namespace vinci::sim
