#include "vinci/sim/model/kinematics.h"

#include <cmath>

namespace vinci::sim {

PointVelocityRowType PointVelocityRow(Dim dim, const Isometry3d& X_WB, const Vector3d& p_W,
                                      const Vector3d& d_W) {
  const Vector3d r = p_W - X_WB.translation();
  if (dim == Dim::kPlanar) {
    PointVelocityRowType row(3);
    row << d_W.x(), d_W.y(), r.x() * d_W.y() - r.y() * d_W.x();
    return row;
  }
  PointVelocityRowType row(6);
  row.head<3>() = d_W.transpose();
  row.tail<3>() = (X_WB.linear().transpose() * r.cross(d_W)).transpose();
  return row;
}

VectorXd BodyVelocity(Dim dim, const BodyKinematics& k) {
  VectorXd v(VelocitySize(dim));
  VelocityToV(dim, k.X_WB, k.v_WB, k.w_WB, v.data());
  return v;
}

namespace {

// PoseFromQ into *X (every entry written).
void PoseInto(Dim dim, const double* q, Isometry3d* X) {
  if (dim == Dim::kPlanar) {
    *X = PlanarPose(q[0], q[1], q[2]);
    return;
  }
  X->makeAffine();  // the bottom row of Identity()
  X->translation() = Vector3d(q[0], q[1], q[2]);
  X->linear() = Quaterniond(q[3], q[4], q[5], q[6]).normalized().toRotationMatrix();
}

}  // namespace

Isometry3d PoseFromQ(Dim dim, const double* q) {
  Isometry3d X;
  PoseInto(dim, q, &X);
  return X;
}

void KinematicsFromQV(Dim dim, const double* q, const double* v, BodyKinematics* k) {
  PoseInto(dim, q, &k->X_WB);
  if (dim == Dim::kPlanar) {
    k->v_WB = Vector3d(v[0], v[1], 0.0);
    k->w_WB = Vector3d(0.0, 0.0, v[2]);
  } else {
    k->v_WB = Vector3d(v[0], v[1], v[2]);
    k->w_WB = k->X_WB.linear() * Vector3d(v[3], v[4], v[5]);
  }
}

BodyKinematics KinematicsFromQV(Dim dim, const double* q, const double* v) {
  BodyKinematics k;
  KinematicsFromQV(dim, q, v, &k);
  return k;
}

void PoseToQ(Dim dim, const Isometry3d& X_WB, double* q) {
  const Vector3d p = X_WB.translation();
  if (dim == Dim::kPlanar) {
    q[0] = p.x();
    q[1] = p.y();
    q[2] = std::atan2(X_WB.linear()(1, 0), X_WB.linear()(0, 0));
    return;
  }
  const Quaterniond Q = Quaterniond(X_WB.linear()).normalized();
  q[0] = p.x();
  q[1] = p.y();
  q[2] = p.z();
  q[3] = Q.w();
  q[4] = Q.x();
  q[5] = Q.y();
  q[6] = Q.z();
}

void VelocityToV(Dim dim, const Isometry3d& X_WB, const Vector3d& v_W, const Vector3d& w_W,
                 double* v) {
  if (dim == Dim::kPlanar) {
    v[0] = v_W.x();
    v[1] = v_W.y();
    v[2] = w_W.z();
    return;
  }
  const Vector3d w_B = X_WB.linear().transpose() * w_W;
  for (int i = 0; i < 3; ++i) {
    v[i] = v_W[i];
    v[3 + i] = w_B[i];
  }
}

void IntegratePosition(Dim dim, const double* q, const double* v, double h, double* q_next) {
  if (dim == Dim::kPlanar) {
    for (int i = 0; i < 3; ++i) q_next[i] = q[i] + h * v[i];
    return;
  }
  for (int i = 0; i < 3; ++i) q_next[i] = q[i] + h * v[i];
  const Vector3d w_B(v[3], v[4], v[5]);
  const double w_norm = w_B.norm();
  Quaterniond dq = Quaterniond::Identity();
  if (w_norm > 0.0) dq = Quaterniond(Eigen::AngleAxisd(h * w_norm, w_B / w_norm));
  Quaterniond Q = (Quaterniond(q[3], q[4], q[5], q[6]) * dq).normalized();
  q_next[3] = Q.w();
  q_next[4] = Q.x();
  q_next[5] = Q.y();
  q_next[6] = Q.z();
}

}  // namespace vinci::sim
