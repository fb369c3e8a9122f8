#include "vinci/sim/model/state_util.h"

#include <cstring>
#include <stdexcept>

#include "vinci/sim/model/kinematics.h"

namespace vinci::sim {
namespace {

void CheckSize(const Scene& scene, const State& x, const char* who) {
  if (x.q.size() != scene.num_positions() || x.v.size() != scene.num_velocities())
    throw std::invalid_argument(
        std::string(who) + ": state has " + std::to_string(x.q.size()) + " positions / " +
        std::to_string(x.v.size()) + " velocities; the scene needs " +
        std::to_string(scene.num_positions()) + " / " + std::to_string(scene.num_velocities()));
}

// The dynamic body named `body`, after the checks every setter needs.
int DynamicBody(const Scene& scene, const std::string& body, const State* x, const char* who) {
  if (!x) throw std::invalid_argument(std::string(who) + ": null state");
  const int i = BodyIndexByName(scene, body);
  if (scene.bodies[i].kind != BodyKind::kDynamic)
    throw std::invalid_argument(std::string(who) + ": body '" + body +
                                "' is not dynamic (its pose is not part of the state)");
  CheckSize(scene, *x, who);
  return i;
}

constexpr std::uint64_t kFnvOffset = 14695981039346656037ull;
constexpr std::uint64_t kFnvPrime = 1099511628211ull;

void HashWord(std::uint64_t word, std::uint64_t* h) {
  for (int k = 0; k < 8; ++k) {  // little-endian byte order whatever the platform's
    *h ^= (word >> (8 * k)) & 0xffu;
    *h *= kFnvPrime;
  }
}

void HashDouble(double d, std::uint64_t* h) {
  std::uint64_t bits = 0;
  static_assert(sizeof bits == sizeof d);
  std::memcpy(&bits, &d, sizeof d);
  HashWord(bits, h);
}

void HashVector(const VectorXd& v, std::uint64_t* h) {
  HashWord(static_cast<std::uint64_t>(v.size()), h);
  for (Eigen::Index i = 0; i < v.size(); ++i) HashDouble(v[i], h);
}

}  // namespace

int BodyIndexByName(const Scene& scene, const std::string& body) {
  const int i = scene.FindBody(body);
  if (i >= 0) return i;
  std::string names;
  for (const Body& b : scene.bodies) names += (names.empty() ? "" : ", ") + b.name;
  throw std::invalid_argument("unknown body '" + body + "'; the scene has: " + names);
}

BodyKinematics GetBodyKinematics(const Scene& scene, const State& x, const std::string& body) {
  const int i = BodyIndexByName(scene, body);
  const Body& b = scene.bodies[i];
  switch (b.kind) {
    case BodyKind::kDynamic: {
      CheckSize(scene, x, "GetBodyKinematics");
      const BodyIndex& idx = scene.index(i);
      return KinematicsFromQV(scene.dim, x.q.data() + idx.q, x.v.data() + idx.v);
    }
    case BodyKind::kPrescribed:
      return EvaluateMotion(b.motion, b.X_WB0, scene.dim == Dim::kPlanar, x.t, scene.options.dt);
    case BodyKind::kStatic:
      break;
  }
  BodyKinematics k;
  k.X_WB = b.X_WB0;
  return k;
}

void SetBodyPose(const Scene& scene, const std::string& body, const Isometry3d& X_WB, State* x) {
  const int i = DynamicBody(scene, body, x, "SetBodyPose");
  if (!X_WB.matrix().allFinite())
    throw std::invalid_argument("SetBodyPose: body '" + body + "': non-finite pose");
  PoseToQ(scene.dim, X_WB, x->q.data() + scene.index(i).q);
}

void SetPlanarBodyPose(const Scene& scene, const std::string& body, double x, double y,
                       double theta, State* state) {
  const int i = DynamicBody(scene, body, state, "SetPlanarBodyPose");
  if (scene.dim != Dim::kPlanar)
    throw std::invalid_argument("SetPlanarBodyPose: body '" + body +
                                "' is in a spatial scene; use SetBodyPose");
  double* q = state->q.data() + scene.index(i).q;
  q[0] = x;
  q[1] = y;
  q[2] = theta;
}

void SetBodyVelocity(const Scene& scene, const std::string& body, const Vector3d& v_W,
                     const Vector3d& w_W, State* x) {
  const int i = DynamicBody(scene, body, x, "SetBodyVelocity");
  if (!v_W.allFinite() || !w_W.allFinite())
    throw std::invalid_argument("SetBodyVelocity: body '" + body + "': non-finite velocity");
  const BodyIndex& idx = scene.index(i);
  const Isometry3d X_WB = PoseFromQ(scene.dim, x->q.data() + idx.q);
  VelocityToV(scene.dim, X_WB, v_W, w_W, x->v.data() + idx.v);
}

std::uint64_t StateHash(const State& x) {
  std::uint64_t h = kFnvOffset;
  HashDouble(x.t, &h);
  HashVector(x.q, &h);
  HashVector(x.v, &h);
  HashVector(x.warm_start, &h);
  return h;
}

}  // namespace vinci::sim
