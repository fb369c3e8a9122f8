#include "vinci/sim/motion.h"

#include <cmath>
#include <stdexcept>

namespace vinci::sim {
namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;

// Index of the keyframe segment containing t, or −1 before / size−1 after the track.
int Segment(const std::vector<Keyframe>& k, double t) {
  if (t <= k.front().t) return -1;
  if (t >= k.back().t) return static_cast<int>(k.size()) - 1;
  int lo = 0, hi = static_cast<int>(k.size()) - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    (k[mid].t <= t ? lo : hi) = mid;
  }
  return lo;
}
}  // namespace

double DofMotion::Value(double t) const {
  if (!keyframes.empty()) {
    const int s = Segment(keyframes, t);
    if (s < 0) return keyframes.front().value;
    if (s == static_cast<int>(keyframes.size()) - 1) return keyframes.back().value;
    const Keyframe& a = keyframes[s];
    const Keyframe& b = keyframes[s + 1];
    return a.value + (b.value - a.value) * (t - a.t) / (b.t - a.t);
  }
  double x = velocity * t;
  for (const Harmonic& h : harmonics)
    x += h.amplitude * (std::sin(kTwoPi * h.frequency * t + h.phase) - std::sin(h.phase));
  return x;
}

double DofMotion::Rate(double t) const {
  if (!keyframes.empty()) {
    const int s = Segment(keyframes, t);
    if (s < 0 || s == static_cast<int>(keyframes.size()) - 1) return 0.0;
    const Keyframe& a = keyframes[s];
    const Keyframe& b = keyframes[s + 1];
    return (b.value - a.value) / (b.t - a.t);
  }
  double r = velocity;
  for (const Harmonic& h : harmonics)
    r += h.amplitude * kTwoPi * h.frequency * std::cos(kTwoPi * h.frequency * t + h.phase);
  return r;
}

BodyKinematics EvaluateMotion(const PrescribedMotion& motion, const Isometry3d& X_WB0, bool planar,
                              double t) {
  BodyKinematics k;
  k.X_WB = X_WB0;
  if (motion.dofs.empty()) return k;
  const std::size_t n = planar ? 3 : 6;
  if (motion.dofs.size() != n)
    throw std::invalid_argument("prescribed motion needs " + std::to_string(n) + " dofs, got " +
                                std::to_string(motion.dofs.size()));
  double x[6] = {0, 0, 0, 0, 0, 0}, xd[6] = {0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = motion.dofs[i].Value(t);
    xd[i] = motion.dofs[i].Rate(t);
  }
  if (planar) {
    const double th0 = std::atan2(X_WB0.linear()(1, 0), X_WB0.linear()(0, 0));
    k.X_WB = PlanarPose(X_WB0.translation().x() + x[0], X_WB0.translation().y() + x[1], th0 + x[2]);
    k.v_WB = Vector3d(xd[0], xd[1], 0.0);
    k.w_WB = Vector3d(0.0, 0.0, xd[2]);
    return k;
  }
  // R = R0 · Rz(yaw) · Ry(pitch) · Rx(roll); body-fixed ZYX Euler angles after R0.
  const double roll = x[3], pitch = x[4], yaw = x[5];
  const Matrix3d Rz = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  const Matrix3d Ry = Eigen::AngleAxisd(pitch, Vector3d::UnitY()).toRotationMatrix();
  const Matrix3d Rx = Eigen::AngleAxisd(roll, Vector3d::UnitX()).toRotationMatrix();
  const Matrix3d& R0 = X_WB0.linear();
  k.X_WB.linear() = R0 * Rz * Ry * Rx;
  k.X_WB.translation() = X_WB0.translation() + Vector3d(x[0], x[1], x[2]);
  k.v_WB = Vector3d(xd[0], xd[1], xd[2]);
  // ω in R0's frame: yaw_rate ẑ + Rz (pitch_rate ŷ) + Rz Ry (roll_rate x̂).
  const Vector3d w0 = Vector3d::UnitZ() * xd[5] + Rz * (Vector3d::UnitY() * xd[4]) +
                      Rz * Ry * (Vector3d::UnitX() * xd[3]);
  k.w_WB = R0 * w0;
  return k;
}

}  // namespace vinci::sim
