// One contact detection per step: the kept end-of-step detection (end_detection.h).
#include "end_detection.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <utility>

#include "vinci/sim/formulations/step_skeleton.h"
#include "vinci/sim/model/motion.h"

namespace vinci::sim::internal {
namespace {

// The end-of-step detection kept for the next step's assembly, with its key.
struct EndDetection {
  bool valid = false;
  std::weak_ptr<const Scene> owner;
  const Scene* model = nullptr;
  double t = 0.0, h = 0.0, envelope = 0.0;
  VectorXd q, v;
  std::vector<BodyKinematics> kin;
  std::vector<Contact> contacts;
};

// What the step's assembly detected with (DetectAtStart), so what the end detection makes.
struct Wanted {
  bool valid = false;
  std::weak_ptr<const Scene> owner;
  const Scene* model = nullptr;
  double h = 0.0, envelope = 0.0;
};

// Per thread: no detection is shared between threads, and a kept one is only ever a value that
// the taking thread would compute itself.
thread_local const std::shared_ptr<const Scene>* t_scene = nullptr;
thread_local EndDetection t_end;
thread_local Wanted t_wanted;
thread_local std::vector<Contact> t_check;  // the check's contacts (storage reuse only)

// StaticShapes of the owner's scene (computed as FindContacts computes them).
struct KeptStatics {
  std::weak_ptr<const Scene> owner;
  const Scene* model = nullptr;
  StaticShapes shapes;
};
thread_local KeptStatics t_statics;

bool SameOwner(const std::weak_ptr<const Scene>& kept, const std::shared_ptr<const Scene>& scene) {
  return !kept.expired() && !kept.owner_before(scene) && !scene.owner_before(kept);
}

void KeepOwner(std::weak_ptr<const Scene>* kept, const std::shared_ptr<const Scene>& scene) {
  if (!SameOwner(*kept, scene)) *kept = scene;
}

// Bitwise equality (−0 and +0 differ, as they may in what is computed from them).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool SameBits(const VectorXd& a, const VectorXd& b) {
  return a.size() == b.size() &&
         std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}

// The step scene if `model` is it, else null.
const std::shared_ptr<const Scene>* ScopeOf(const Scene& model) {
  return t_scene != nullptr && t_scene->get() == &model ? t_scene : nullptr;
}

// ComputeBodyKinematics(model, x) with the integrated prescribed poses at (x.t, h), as the
// assembly poses them (EvaluateMotion with step h).
void StartKinematics(const Scene& model, const State& x, double h,
                     std::vector<BodyKinematics>* kin) {
  ComputeBodyKinematics(model, x, kin);
  for (std::size_t i = 0; i < kin->size(); ++i) {
    const Body& b = model.bodies[i];
    if (b.kind == BodyKind::kPrescribed && b.motion.pose == PoseRule::kIntegrated)
      (*kin)[i] = EvaluateMotion(b.motion, b.X_WB0, model.dim == Dim::kPlanar, x.t, h);
  }
}

// The StaticShapes of *scene (kept per owner).
const StaticShapes& StaticsOf(const std::shared_ptr<const Scene>& scene) {
  KeptStatics& k = t_statics;
  if (k.model == scene.get() && SameOwner(k.owner, scene)) return k.shapes;
  k.owner = scene;
  k.model = scene.get();
  std::vector<Isometry3d>& poses = k.shapes.poses;
  std::vector<Aabb>& boxes = k.shapes.boxes;
  poses.clear();
  boxes.clear();
  for (const Body& b : scene->bodies) {
    for (const Shape& s : b.shapes) {
      if (b.kind == BodyKind::kStatic) {
        poses.push_back(b.X_WB0 * s.X_BS);  // ComputeBodyKinematics: X_WB = X_WB0
        boxes.push_back(ComputeAabb(s, poses.back()));
      } else {
        poses.emplace_back();
        boxes.emplace_back();
      }
    }
  }
  return k.shapes;
}

}  // namespace

StepSceneScope::StepSceneScope(std::shared_ptr<const Scene> scene)
    : scene_(std::move(scene)), previous_(t_scene) {
  t_scene = &scene_;
}

StepSceneScope::~StepSceneScope() { t_scene = previous_; }

void DetectAtStart(const Scene& model, const State& x, double h, double envelope,
                   std::vector<BodyKinematics>* kin, std::vector<Contact>* contacts) {
  const std::shared_ptr<const Scene>* scene = ScopeOf(model);
  if (scene != nullptr) {
    Wanted& w = t_wanted;
    KeepOwner(&w.owner, *scene);
    w.model = &model;
    w.h = h;
    w.envelope = envelope;
    w.valid = true;
    EndDetection& e = t_end;
    if (e.valid && e.model == &model && SameOwner(e.owner, *scene) && SameBits(e.t, x.t) &&
        SameBits(e.h, h) && SameBits(e.envelope, envelope) && SameBits(e.q, x.q) &&
        SameBits(e.v, x.v)) {
      e.valid = false;  // taken: its buffers now hold the caller's old storage
      kin->swap(e.kin);
      contacts->swap(e.contacts);
      return;
    }
  }
  StartKinematics(model, x, h, kin);
  FindContacts(model, *kin, envelope, contacts);
}

double EndOfStepMinGap(const Scene& model, const State& x, double h, double check_envelope) {
  const std::shared_ptr<const Scene>* scene = ScopeOf(model);
  const Wanted& w = t_wanted;
  if (scene == nullptr || !w.valid || w.model != &model || !SameOwner(w.owner, *scene) ||
      !SameBits(w.h, h))
    return MinGapAt(model, x, h, check_envelope, nullptr);
  EndDetection& e = t_end;
  e.valid = false;
  StartKinematics(model, x, h, &e.kin);
  FindContactsAt(model, e.kin, w.envelope, &e.contacts, check_envelope, &t_check,
                 &StaticsOf(*scene));
  KeepOwner(&e.owner, *scene);
  e.model = &model;
  e.t = x.t;
  e.h = h;
  e.envelope = w.envelope;
  e.q = x.q;
  e.v = x.v;
  e.valid = true;
  return MinGapOf(t_check, nullptr);
}

const std::vector<Contact>* KeptEndContacts(const Scene& model, const State& x, double h,
                                            double envelope) {
  const EndDetection& e = t_end;
  if (!e.valid || e.model != &model) return nullptr;
  const std::shared_ptr<const Scene> owner = e.owner.lock();
  if (owner.get() != &model || !SameBits(e.t, x.t) || !SameBits(e.h, h) ||
      !SameBits(e.envelope, envelope) || !SameBits(e.q, x.q) || !SameBits(e.v, x.v))
    return nullptr;
  return &e.contacts;
}

double MinGapOf(const std::vector<Contact>& contacts, const Contact** where) {
  double min_gap = std::numeric_limits<double>::infinity();
  const Contact* min_contact = nullptr;
  for (const Contact& c : contacts) {
    const double gap = c.point.corner ? std::max(c.point.gap, c.point.gap2) : c.point.gap;
    if (gap < min_gap) {
      min_gap = gap;
      min_contact = &c;
    }
  }
  if (where) *where = min_contact;
  return min_gap;
}

bool HoldsEndDetection() { return t_end.valid; }

}  // namespace vinci::sim::internal
