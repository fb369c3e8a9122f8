// Common numeric types and small helpers shared by the whole sim layer.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace vinci::sim {

using Eigen::Isometry3d;
using Eigen::MatrixXd;
using Eigen::Quaterniond;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using Matrix3d = Eigen::Matrix3d;

/// Dimension of a scene: every body of a scene is planar (x, y, θ) or spatial
/// (position + unit quaternion).
enum class Dim { kPlanar = 2, kSpatial = 3 };

/// Generalized coordinate / velocity sizes of one body.
constexpr int PositionSize(Dim d) { return d == Dim::kPlanar ? 3 : 7; }
constexpr int VelocitySize(Dim d) { return d == Dim::kPlanar ? 3 : 6; }

/// 2D cross product z-component.
inline double Cross2(const Vector2d& a, const Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

/// Pose of a planar body (x, y, θ) as a spatial transform (rotation about +z).
inline Isometry3d PlanarPose(double x, double y, double theta) {
  Isometry3d X = Isometry3d::Identity();
  X.linear() = Eigen::AngleAxisd(theta, Vector3d::UnitZ()).toRotationMatrix();
  X.translation() = Vector3d(x, y, 0.0);
  return X;
}

}  // namespace vinci::sim
