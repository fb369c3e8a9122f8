// One contact detection per step (sim/src/formulations/end_detection.h): the end-of-step check
// keeps its detection for the next step's assembly, which takes it only at exactly its key
// (scene owner, t, q, ν, h, envelope), so a taken detection equals a fresh one bit for bit.
#include "../../sim/src/formulations/end_detection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "test_util.h"
#include "vinci/sim/formulations/step_skeleton.h"
#include "vinci/sim/model/motion.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

using testing::LoadExample;
using testing::SameBits;

bool Same(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool Same(const Vector3d& a, const Vector3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0;
}

bool SameContacts(const std::vector<Contact>& a, const std::vector<Contact>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Contact& x = a[i];
    const Contact& y = b[i];
    const ContactPoint& p = x.point;
    const ContactPoint& q = y.point;
    if (x.body_a != y.body_a || x.body_b != y.body_b || x.shape_a != y.shape_a ||
        x.shape_b != y.shape_b || !Same(x.mu, y.mu) || x.mu_param != y.mu_param ||
        !Same(p.p_A_W, q.p_A_W) || !Same(p.p_B_W, q.p_B_W) || !Same(p.n_W, q.n_W) ||
        !Same(p.gap, q.gap) || p.corner != q.corner || !Same(p.p2_A_W, q.p2_A_W) ||
        !Same(p.p2_B_W, q.p2_B_W) || !Same(p.n2_W, q.n2_W) || !Same(p.gap2, q.gap2))
      return false;
  }
  return true;
}

bool SameKinematics(const std::vector<BodyKinematics>& a, const std::vector<BodyKinematics>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(a[i].X_WB.data(), b[i].X_WB.data(), sizeof(double) * 16) != 0 ||
        !Same(a[i].v_WB, b[i].v_WB) || !Same(a[i].w_WB, b[i].w_WB))
      return false;
  return true;
}

// A fresh detection at x, as the assembly makes it: kinematics with the integrated prescribed
// poses at (x.t, h), then FindContacts.
std::vector<Contact> Fresh(const Scene& m, const State& x, std::vector<BodyKinematics>* kin) {
  *kin = ComputeBodyKinematics(m, x);
  for (std::size_t i = 0; i < kin->size(); ++i) {
    const Body& b = m.bodies[i];
    if (b.kind == BodyKind::kPrescribed && b.motion.pose == PoseRule::kIntegrated)
      (*kin)[i] = EvaluateMotion(b.motion, b.X_WB0, m.dim == Dim::kPlanar, x.t, m.options.dt);
  }
  std::vector<Contact> contacts;
  FindContacts(m, *kin, m.options.envelope, &contacts);
  return contacts;
}

// The assembly's detection at x in a step scope on `scene`; `taken`: the kept one was used.
struct Detection {
  bool taken = false;
  std::vector<BodyKinematics> kin;
  std::vector<Contact> contacts;
};
Detection Detect(const std::shared_ptr<const Scene>& scene, const State& x) {
  Detection d;
  const internal::StepSceneScope scope(scene);
  const bool held = internal::HoldsEndDetection();
  internal::DetectAtStart(*scene, x, scene->options.dt, scene->options.envelope, &d.kin,
                          &d.contacts);
  d.taken = held && !internal::HoldsEndDetection();
  return d;
}

// The plate-box scene with the plate posed by its integrated rule (poses at (t, h)).
Scene IntegratedPlateBox() {
  Scene s = LoadExample("plate_box.yaml");
  s.bodies[static_cast<std::size_t>(s.FindBody("plate"))].motion.pose = PoseRule::kIntegrated;
  return s;
}

struct Case {
  std::string name;
  Scene scene;
  std::string param;  // a parameter set to `value` (empty: the defaults)
  double value = 0.0;
};

std::vector<Case> Cases() {
  std::vector<Case> cases;
  cases.push_back({"box_on_plane", LoadExample("box_on_plane.yaml"), "", 0.0});
  cases.push_back({"box_stack", LoadExample("box_stack.yaml"), "", 0.0});
  cases.push_back({"sticking incline", LoadExample("block_on_incline.yaml"), "mu.default", 0.3248});
  cases.push_back({"integrated plate", IntegratedPlateBox(), "", 0.0});
  cases.push_back({"concave trench", LoadExample("concave_trench.yaml"), "", 0.0});
  cases.push_back({"pendulum pusher", LoadExample("pendulum_pusher.yaml"), "", 0.0});
  cases.push_back({"first-order push", LoadExample("first_order_push.yaml"), "", 0.0});
  cases.push_back({"quasistatic pushing", LoadExample("planar_pushing.yaml"), "", 0.0});
  return cases;
}

Params ParamsOf(const Simulator& sim, const Case& c) {
  Params p = sim.DefaultParams();
  if (!c.param.empty()) p.values[sim.scene().param_table().Index(c.param)] = c.value;
  return p;
}

// Every step of a run keeps its end detection, and the next step's (taken) detection equals a
// fresh detection at its start state, kinematics and contacts bit for bit.
TEST(EndDetection, TakenDetectionEqualsAFreshOne) {
  for (const Case& c : Cases()) {
    SCOPED_TRACE(c.name);
    const Simulator sim(c.scene);
    const Params params = ParamsOf(sim, c);
    Workspace ws;
    State x = sim.InitialState(), next;
    int taken = 0, with_contacts = 0;
    for (int k = 0; k < 150; ++k) {
      ASSERT_TRUE(sim.Step(params, x, StepInput{}, &ws, &next).ok) << "step " << k;
      std::swap(x, next);
      const Detection d = Detect(ws.model, x);
      std::vector<BodyKinematics> kin;
      const std::vector<Contact> fresh = Fresh(*ws.model, x, &kin);
      taken += d.taken;
      with_contacts += !fresh.empty();
      EXPECT_TRUE(SameContacts(d.contacts, fresh)) << "step " << k;
      EXPECT_TRUE(SameKinematics(d.kin, kin)) << "step " << k;
    }
    EXPECT_EQ(taken, 150);  // every step's detection was kept and taken
    EXPECT_GT(with_contacts, 0);
  }
}

// A kept detection is not taken at another state, time, scene owner or envelope, nor outside
// a step scope; what is detected instead is the fresh detection there.
TEST(EndDetection, AnotherKeyDetectsAfresh) {
  const Simulator sim(LoadExample("box_stack.yaml"));
  Workspace ws;
  State x0 = sim.InitialState(), x;
  for (int k = 0; k < 50; ++k) {
    ASSERT_TRUE(sim.Step(sim.DefaultParams(), x0, StepInput{}, &ws, &x).ok);
    std::swap(x0, x);
  }
  ASSERT_TRUE(sim.Step(sim.DefaultParams(), x0, StepInput{}, &ws, &x).ok);
  ASSERT_TRUE(internal::HoldsEndDetection());
  const std::shared_ptr<const Scene> scene = ws.model;
  std::vector<BodyKinematics> kin;
  const auto expect_fresh = [&](const std::shared_ptr<const Scene>& s, const State& at) {
    const Detection d = Detect(s, at);
    EXPECT_FALSE(d.taken);
    EXPECT_TRUE(internal::HoldsEndDetection());  // still kept for its own key
    EXPECT_TRUE(SameContacts(d.contacts, Fresh(*s, at, &kin)));
    EXPECT_TRUE(SameKinematics(d.kin, kin));
  };
  State moved = x;  // one ulp in one coordinate of q
  moved.q[2] = std::nextafter(moved.q[2], 1.0);
  expect_fresh(scene, moved);
  State spun = x;  // ν only (the kept kinematics carry ν)
  spun.v[3] = std::nextafter(spun.v[3], 1.0);
  expect_fresh(scene, spun);
  State later = x;
  later.t = std::nextafter(later.t, 1.0);
  expect_fresh(scene, later);
  State negative_zero = x;  // −0 and +0 are different keys
  negative_zero.v[0] = negative_zero.v[0] == 0.0 && !std::signbit(negative_zero.v[0]) ? -0.0 : 0.0;
  if (!SameBits(negative_zero.v, x.v)) expect_fresh(scene, negative_zero);
  // An equal scene under another owner, and the same scene object under another owner (a scene
  // is identified by its owner, not by its contents or address).
  expect_fresh(std::make_shared<const Scene>(*scene), x);
  expect_fresh(std::shared_ptr<const Scene>(std::make_shared<int>(0), scene.get()), x);
  // Another envelope.
  {
    const internal::StepSceneScope scope(scene);
    std::vector<Contact> contacts;
    std::vector<BodyKinematics> k;
    internal::DetectAtStart(*scene, x, scene->options.dt, 2.0 * scene->options.envelope, &k,
                            &contacts);
    EXPECT_TRUE(internal::HoldsEndDetection());
    std::vector<Contact> fresh;
    FindContacts(*scene, ComputeBodyKinematics(*scene, x), 2.0 * scene->options.envelope, &fresh);
    EXPECT_TRUE(SameContacts(contacts, fresh));
  }
  // Outside a scope nothing is taken.
  {
    std::vector<Contact> contacts;
    std::vector<BodyKinematics> k;
    internal::DetectAtStart(*scene, x, scene->options.dt, scene->options.envelope, &k, &contacts);
    EXPECT_TRUE(internal::HoldsEndDetection());
  }
  // At its key it is taken.
  EXPECT_TRUE(Detect(scene, x).taken);
  EXPECT_FALSE(internal::HoldsEndDetection());
}

// The kept end detection read without a scope (KeptEndContacts: StewartTrinkle::Layout of the
// mode-change flag at x_ℓ+1): the fresh list at its key, null at any other; the layouts alike.
TEST(EndDetection, KeptEndContactsAreTheFreshListAtTheirKeyOnly) {
  for (const Case& c : {Cases()[1], Cases()[3], Cases()[4]}) {
    SCOPED_TRACE(c.name);
    const Simulator sim(c.scene);
    const Params p = ParamsOf(sim, c);
    Workspace ws;
    State x = sim.InitialState(), next;
    for (int k = 0; k < 20; ++k) {
      ASSERT_TRUE(sim.Step(p, x, StepInput{}, &ws, &next).ok);
      std::swap(x, next);
    }
    const Scene& m = *ws.model;
    const double h = m.options.dt, envelope = m.options.envelope;
    const std::vector<Contact>* kept = internal::KeptEndContacts(m, x, h, envelope);
    ASSERT_NE(kept, nullptr);
    std::vector<BodyKinematics> kin;
    EXPECT_TRUE(SameContacts(*kept, Fresh(m, x, &kin)));
    State moved = x;
    moved.q[0] = std::nextafter(moved.q[0], 1e9);
    EXPECT_EQ(internal::KeptEndContacts(m, moved, h, envelope), nullptr);
    EXPECT_EQ(internal::KeptEndContacts(m, x, 2.0 * h, envelope), nullptr);
    EXPECT_EQ(internal::KeptEndContacts(m, x, h, 2.0 * envelope), nullptr);
    EXPECT_EQ(internal::KeptEndContacts(Scene(m), x, h, envelope), nullptr);  // another object
    // Layout with the kept list against a thread that holds none.
    const StepLayout with = sim.formulation().Layout(m, x);
    StepLayout without;
    std::thread([&] { without = sim.formulation().Layout(m, x); }).join();
    EXPECT_EQ(with.nc, without.nc);
    EXPECT_EQ(with.nk, without.nk);
    EXPECT_EQ(with.ns, without.ns);
    EXPECT_EQ(with.size(), without.size());
    EXPECT_NE(internal::KeptEndContacts(m, x, h, envelope), nullptr);  // read, not taken
  }
}

// A scene whose owner is gone is never matched, even by a new owner of a scene at the same
// address (here the same object, under owners that alias it).
TEST(EndDetection, ExpiredOwnerIsNeverMatched) {
  const Scene base = LoadExample("box_on_plane.yaml");
  const Simulator sim(base);
  const State x = sim.InitialState();
  const auto object = std::make_shared<const Scene>(sim.scene());
  auto scene = std::shared_ptr<const Scene>(std::make_shared<int>(1), object.get());
  {
    const internal::StepSceneScope scope(scene);
    std::vector<Contact> contacts;
    std::vector<BodyKinematics> kin;
    internal::DetectAtStart(*scene, x, scene->options.dt, scene->options.envelope, &kin,
                            &contacts);  // asks for the end detection
    internal::EndOfStepMinGap(*scene, x, scene->options.dt, -scene->options.max_penetration);
  }
  ASSERT_TRUE(internal::HoldsEndDetection());
  scene.reset();
  EXPECT_FALSE(
      Detect(std::shared_ptr<const Scene>(std::make_shared<int>(2), object.get()), x).taken);
  EXPECT_FALSE(Detect(object, x).taken);
}

// A changed parameter resolves to another scene: the step detects with the new μ.
TEST(EndDetection, ChangedParameterDetectsAfresh) {
  const Simulator sim(LoadExample("block_on_incline.yaml"));
  const int mu = sim.scene().param_table().Index("mu.default");
  Params p = sim.DefaultParams();
  p.values[mu] = 0.6;
  Workspace ws;
  State x = sim.InitialState(), next;
  for (int k = 0; k < 20; ++k) {
    ASSERT_TRUE(sim.Step(p, x, StepInput{}, &ws, &next).ok);
    std::swap(x, next);
  }
  ASSERT_TRUE(internal::HoldsEndDetection());
  p.values[mu] = 0.3248;
  ASSERT_TRUE(sim.Step(p, x, StepInput{}, &ws, &next).ok);
  ASSERT_FALSE(ws.contacts.empty());
  for (const Contact& c : ws.contacts) EXPECT_EQ(c.mu, 0.3248);
}

// Simulator steps (which keep and take detections) and RunStep outside a Simulator (which
// detects afresh every time) give the same bits, for every formulation the scene supports.
TEST(EndDetection, SimulatorStepsMatchStepsWithoutReuse) {
  int runs = 0;
  for (const Case& c : Cases()) {
    for (const auto& [name, f] : FormulationTable()) {
      SCOPED_TRACE(c.name + " / " + name);
      if (c.name == "box_stack" && f == FormulationType::kGeometricallyImplicit) continue;  // slow
      const Scene& scene = c.scene;
      SimulatorOptions options = SimulatorOptions::FromScene(scene);
      options.formulation = f;
      std::unique_ptr<Simulator> sim;
      try {
        sim = std::make_unique<Simulator>(scene, options);
      } catch (const std::invalid_argument&) {
        continue;  // a scene feature the formulation lacks
      }
      const Params params = ParamsOf(*sim, c);
      const Scene model = sim->scene().ApplyParams(params);
      const std::unique_ptr<Formulation> formulation = MakeFormulation(model.options);
      Workspace ws, ws_plain;
      State x = sim->InitialState(), y = x, next_x, next_y;
      ++runs;
      for (int k = 0; k < 40; ++k) {
        const StepInfo a = sim->Step(params, x, StepInput{}, &ws, &next_x);
        const StepInfo b = RunStep(*formulation, model, y, StepInput{}, &ws_plain, &next_y);
        ASSERT_EQ(a.ok, b.ok) << "step " << k;
        if (!a.ok) break;
        ASSERT_TRUE(SameBits(next_x.q, next_y.q) && SameBits(next_x.v, next_y.v) &&
                    SameBits(next_x.warm_start, next_y.warm_start) && Same(next_x.t, next_y.t))
            << "step " << k;
        std::swap(x, next_x);
        std::swap(y, next_y);
      }
    }
  }
  EXPECT_GE(runs, 24);  // of the 8 scenes × 8 formulations, those the scene supports
}

// FindContactsAt's two lists are exactly two FindContacts calls, whichever envelope is larger,
// with and without the kept static shapes, at resting, deep and tilted states.
TEST(EndDetection, OnePassEqualsTwoDetections) {
  for (const char* file :
       {"box_stack.yaml", "box_on_plane.yaml", "concave_trench.yaml", "block_on_incline.yaml"}) {
    SCOPED_TRACE(file);
    const Simulator sim(LoadExample(file));
    const Scene& scene = sim.scene();
    internal::StaticShapes statics;
    for (const Body& b : scene.bodies)
      for (const Shape& sh : b.shapes) {
        statics.poses.push_back(b.X_WB0 * sh.X_BS);
        statics.boxes.push_back(ComputeAabb(sh, statics.poses.back()));
      }
    const int up = scene.dim == Dim::kPlanar ? 1 : 2;
    for (double depth : {0.0, 0.003, 0.06}) {
      State x = sim.InitialState();
      for (int bi : scene.dynamic_bodies()) x.q[scene.index(bi).q + up] -= depth;
      const std::vector<BodyKinematics> kin = ComputeBodyKinematics(scene, x);
      const std::pair<double, double> envelopes[] = {
          {1e-3, -0.05}, {-0.05, 1e-3}, {0.01, 0.01}, {0.0, -1e-3}, {-1e-3, -0.05}};
      for (const auto& [e, check_e] : envelopes) {
        std::vector<Contact> a, b, fresh_a, fresh_b;
        FindContacts(scene, kin, e, &fresh_a);
        FindContacts(scene, kin, check_e, &fresh_b);
        for (const internal::StaticShapes* st :
             {&statics, static_cast<internal::StaticShapes*>(nullptr)}) {
          internal::FindContactsAt(scene, kin, e, &a, check_e, &b, st);
          EXPECT_TRUE(SameContacts(a, fresh_a)) << depth << " " << e << " " << check_e;
          EXPECT_TRUE(SameContacts(b, fresh_b)) << depth << " " << e << " " << check_e;
        }
        if (depth == 0.06 && std::string(file) != "concave_trench.yaml") {
          EXPECT_FALSE(fresh_b.empty());  // the deep state has contacts at every envelope
        }
      }
    }
  }
}

// The end-of-step check's value is MinGapAt's, with or without a kept detection made with it,
// shallow or deeper than max_penetration.
TEST(EndDetection, EndOfStepMinGapIsMinGapAt) {
  for (const char* file : {"box_on_plane.yaml", "box_stack.yaml", "concave_trench.yaml"}) {
    SCOPED_TRACE(file);
    const Simulator sim(LoadExample(file));
    const auto scene = std::make_shared<const Scene>(sim.scene());
    const double h = scene->options.dt, check = -scene->options.max_penetration;
    const int up = scene->dim == Dim::kPlanar ? 1 : 2;
    const bool resting = std::string(file) != "concave_trench.yaml";  // starts on the ground
    for (double depth : {0.0, 0.049, 0.051, 0.2}) {
      for (bool kept : {false, true}) {
        State x = sim.InitialState();
        for (int bi : scene->dynamic_bodies()) x.q[scene->index(bi).q + up] -= depth;
        const double expected = MinGapAt(*scene, x, h, check, nullptr);
        const internal::StepSceneScope scope(scene);
        if (kept) {
          std::vector<Contact> contacts;
          std::vector<BodyKinematics> kin;
          internal::DetectAtStart(*scene, x, h, scene->options.envelope, &kin, &contacts);
        }
        const double gap = internal::EndOfStepMinGap(*scene, x, h, check);
        EXPECT_TRUE(Same(gap, expected) || (std::isinf(gap) && std::isinf(expected)))
            << "depth " << depth << ": " << gap << " vs " << expected;
        if (resting && depth >= 0.051) {
          EXPECT_LT(gap, check);  // the step would fail
        }
      }
    }
  }
}

}  // namespace
}  // namespace vinci::sim
