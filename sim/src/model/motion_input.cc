#include "vinci/sim/model/motion_input.h"

#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

namespace vinci::sim {
namespace {

constexpr double kRotationTol = 1e-9;  // orthonormality of a reference pose's rotation
constexpr long long kMaxSegmentSteps = 10000000;

bool Same(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool Same(const DofMotion& a, const DofMotion& b) {
  if (!Same(a.velocity, b.velocity) || a.harmonics.size() != b.harmonics.size() ||
      a.keyframes.size() != b.keyframes.size())
    return false;
  for (std::size_t i = 0; i < a.harmonics.size(); ++i)
    if (!Same(a.harmonics[i].amplitude, b.harmonics[i].amplitude) ||
        !Same(a.harmonics[i].frequency, b.harmonics[i].frequency) ||
        !Same(a.harmonics[i].phase, b.harmonics[i].phase))
      return false;
  for (std::size_t i = 0; i < a.keyframes.size(); ++i)
    if (!Same(a.keyframes[i].t, b.keyframes[i].t) ||
        !Same(a.keyframes[i].value, b.keyframes[i].value))
      return false;
  return true;
}

bool Same(const PrescribedMotion& a, const PrescribedMotion& b) {
  if (a.dofs.size() != b.dofs.size() || a.pose != b.pose ||
      !Same(a.base_frequency, b.base_frequency) || !Same(a.time_origin, b.time_origin))
    return false;
  for (std::size_t i = 0; i < a.dofs.size(); ++i)
    if (!Same(a.dofs[i], b.dofs[i])) return false;
  const TiltMotion& s = a.tilt;
  const TiltMotion& t = b.tilt;
  return Same(s.amplitude, t.amplitude) && Same(s.frequency, t.frequency) &&
         Same(s.phase, t.phase) && Same(s.depth, t.depth) && Same(s.axis_B.x(), t.axis_B.x()) &&
         Same(s.axis_B.y(), t.axis_B.y()) && Same(s.axis_B.z(), t.axis_B.z());
}

bool Finite(double x) { return std::isfinite(x); }

void CheckMotion(const Scene& model, const MotionInput& in, const std::string& where) {
  const bool planar = model.dim == Dim::kPlanar;
  const PrescribedMotion& m = in.motion;
  const auto fail = [&](const std::string& what) {
    throw std::invalid_argument(where + ": " + what);
  };
  const std::size_t n = planar ? 3 : 6;
  if (!m.dofs.empty() && m.dofs.size() != n)
    fail("motion.dofs: expected " + std::to_string(n) + " dofs (or none), got " +
         std::to_string(m.dofs.size()));
  for (std::size_t d = 0; d < m.dofs.size(); ++d) {
    const DofMotion& dof = m.dofs[d];
    const std::string key = "motion.dofs[" + std::to_string(d) + "]";
    if (!Finite(dof.velocity)) fail(key + ".velocity: expected a finite number");
    for (const Harmonic& h : dof.harmonics)
      if (!Finite(h.amplitude) || !Finite(h.frequency) || !Finite(h.phase))
        fail(key + ".harmonics: expected finite amplitude, frequency and phase");
    for (std::size_t k = 0; k < dof.keyframes.size(); ++k) {
      if (!Finite(dof.keyframes[k].t) || !Finite(dof.keyframes[k].value))
        fail(key + ".keyframes: expected finite times and values");
      if (k > 0 && !(dof.keyframes[k].t > dof.keyframes[k - 1].t))
        fail(key + ".keyframes: expected strictly increasing times");
    }
  }
  if (!m.tilt.IsZero()) {
    const TiltMotion& t = m.tilt;
    if (!Finite(t.amplitude) || !(t.frequency > 0.0) || !Finite(t.frequency) || !Finite(t.phase) ||
        !Finite(t.depth))
      fail("motion.tilt: expected finite amplitude, phase, depth and frequency > 0");
    if (!planar && (std::abs(t.axis_B.norm() - 1.0) > 1e-9 || std::abs(t.axis_B.z()) > 1e-9))
      fail("motion.tilt.axis_B: expected a unit vector in the body's x-y plane");
  }
  if (!Finite(m.time_origin)) fail("motion.time_origin: expected a finite time (s)");
  const Matrix3d& R = in.X_WB0.linear();
  if (!in.X_WB0.matrix().allFinite() ||
      (R.transpose() * R - Matrix3d::Identity()).cwiseAbs().maxCoeff() > kRotationTol ||
      R.determinant() < 0.0)
    fail("X_WB0: expected a finite pose with an orthonormal, proper rotation");
  if (planar && (std::abs(R(2, 2) - 1.0) > kRotationTol || in.X_WB0.translation().z() != 0.0))
    fail("X_WB0: expected a planar pose (rotation about z, z = 0)");
}

}  // namespace

void ValidateMotionInputs(const Scene& model, const std::vector<MotionInput>& motions) {
  const int nb = static_cast<int>(model.bodies.size());
  for (std::size_t i = 0; i < motions.size(); ++i) {
    const MotionInput& in = motions[i];
    std::string where = "StepInput::motions[" + std::to_string(i) + "]";
    if (in.body < 0 || in.body >= nb)
      throw std::invalid_argument(where + ".body: expected a body index in [0, " +
                                  std::to_string(nb) + "), got " + std::to_string(in.body));
    const Body& b = model.bodies[in.body];
    where += " (body '" + b.name + "')";
    if (b.kind != BodyKind::kPrescribed)
      throw std::invalid_argument(where + ".body: expected a prescribed body");
    for (std::size_t j = 0; j < i; ++j)
      if (motions[j].body == in.body)
        throw std::invalid_argument(where +
                                    ".body: expected one motion per body, the body is "
                                    "also in motions[" +
                                    std::to_string(j) + "]");
    CheckMotion(model, in, where);
  }
}

Scene ApplyMotionInputs(const Scene& model, const std::vector<MotionInput>& motions) {
  ValidateMotionInputs(model, motions);
  Scene s = model;
  for (const MotionInput& in : motions) {
    Body& b = s.bodies[static_cast<std::size_t>(in.body)];
    b.motion = in.motion;
    b.X_WB0 = in.X_WB0;
  }
  return s;
}

bool SameMotionInputs(const std::vector<MotionInput>& a, const std::vector<MotionInput>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].body != b[i].body || !Same(a[i].motion, b[i].motion)) return false;
    const auto& ma = a[i].X_WB0.matrix();
    const auto& mb = b[i].X_WB0.matrix();
    if (std::memcmp(ma.data(), mb.data(), sizeof(double) * 16) != 0) return false;
  }
  return true;
}

Isometry3d ReferencePose(const PrescribedMotion& motion, bool planar, const Isometry3d& X_start) {
  // The offset at τ = 0 applied to the identity: rotation R_off; with X_ref = (p, R) the pose
  // at τ = 0 is (p + R·dp_tilt + Δ, R·R_off) (motion.h), so R = R_start R_offᵀ and
  // p = p_start − (R·dp_tilt + Δ), the latter read off a pose with p = 0.
  const double t0 = motion.time_origin;
  const BodyKinematics off = EvaluateMotion(motion, Isometry3d::Identity(), planar, t0);
  if (off.X_WB.matrix() == Isometry3d::Identity().matrix()) return X_start;
  Isometry3d X_ref = Isometry3d::Identity();
  X_ref.linear() = X_start.linear() * off.X_WB.linear().transpose();
  const BodyKinematics shift = EvaluateMotion(motion, X_ref, planar, t0);
  X_ref.translation() = X_start.translation() - shift.X_WB.translation();
  return X_ref;
}

BodyKinematics PrescribedKinematicsAt(const Scene& scene, int body, const StepInput& u, double t,
                                      double h) {
  if (body < 0 || body >= static_cast<int>(scene.bodies.size()) ||
      scene.bodies[body].kind == BodyKind::kDynamic)
    throw std::invalid_argument("PrescribedKinematicsAt: body " + std::to_string(body) +
                                " is not a prescribed or static body");
  const bool planar = scene.dim == Dim::kPlanar;
  for (const MotionInput& in : u.motions)
    if (in.body == body) return EvaluateMotion(in.motion, in.X_WB0, planar, t, h);
  const Body& b = scene.bodies[body];
  if (b.kind == BodyKind::kStatic) {
    BodyKinematics k;
    k.X_WB = b.X_WB0;
    return k;
  }
  return EvaluateMotion(b.motion, b.X_WB0, planar, t, h);
}

MotionSegment PhaseLockedSegment(const Scene& scene, int body, const PrescribedMotion& motion,
                                 double t0, const Isometry3d& X_start, int cycles, double h,
                                 double frequency) {
  const std::string where = "PhaseLockedSegment";
  if (cycles < 0)
    throw std::invalid_argument(where + ": cycles: expected an integer >= 0, got " +
                                std::to_string(cycles));
  if (!(h > 0.0) || !std::isfinite(h))
    throw std::invalid_argument(where + ": h: expected a finite step > 0 (s)");
  if (!std::isfinite(t0)) throw std::invalid_argument(where + ": t0: expected a finite time (s)");
  double f = frequency;
  if (!(f > 0.0)) f = motion.base_frequency;
  if (!(f > 0.0)) f = motion.tilt.frequency;
  if (!(f > 0.0) || !std::isfinite(f))
    throw std::invalid_argument(where +
                                ": frequency: expected a finite frequency > 0 (Hz), given or "
                                "as the motion's base_frequency or tilt frequency");
  MotionInput in;
  in.body = body;
  in.motion = motion;
  in.motion.time_origin = t0;
  const bool planar = scene.dim == Dim::kPlanar;
  in.X_WB0 = ReferencePose(in.motion, planar, X_start);
  ValidateMotionInputs(scene, {in});
  const double per_cycle_real = std::round(1.0 / (f * h));
  const double total_real = static_cast<double>(cycles) * std::max(1.0, per_cycle_real);
  if (!(total_real <= static_cast<double>(kMaxSegmentSteps)))
    throw std::invalid_argument(where + ": expected at most " + std::to_string(kMaxSegmentSteps) +
                                " steps (cycles / (frequency · h)), got " +
                                std::to_string(total_real));
  const auto steps = static_cast<std::size_t>(total_real);
  MotionSegment seg;
  StepInput u;
  u.motions.push_back(in);
  seg.inputs.assign(steps, u);
  double t = t0;
  for (std::size_t k = 0; k < steps; ++k) t = t + h;
  seg.t_end = t;
  seg.X_end = steps == 0 ? X_start : PrescribedKinematicsAt(scene, body, u, t, h).X_WB;
  return seg;
}

}  // namespace vinci::sim
