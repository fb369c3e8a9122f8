// Params: a parameter set through Params gives, bit for bit, the rollout of the scene file with
// that value written in it (sizes, masses, poses of static/prescribed bodies and of shapes,
// polyhedron scale, tilt motion), with the derived quantities (inertia from shapes, hulls)
// recomputed; the table's names, defaults and differentiable flags.
#include "vinci/sim/model/params.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "test_util.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/state_util.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

using testing::WithParams;

using testing::SameBits;

bool SameBits(const Matrix3d& a, const Matrix3d& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 9) == 0;
}

// Rolls `a` with params pa and `b` with pb for `steps` steps from their initial states and
// expects bit-identical trajectories; returns the final state of a.
State ExpectSameRollout(const Simulator& a, const Params& pa, const Simulator& b, const Params& pb,
                        int steps) {
  const Trajectory ta = a.Rollout(pa, a.InitialState(), steps);
  const Trajectory tb = b.Rollout(pb, b.InitialState(), steps);
  EXPECT_TRUE(ta.ok) << ta.failure;
  EXPECT_TRUE(tb.ok) << tb.failure;
  EXPECT_EQ(ta.states.size(), tb.states.size());
  for (std::size_t k = 0; k < std::min(ta.states.size(), tb.states.size()); ++k) {
    const State& x = ta.states[k];
    const State& y = tb.states[k];
    EXPECT_EQ(StateHash(x), StateHash(y)) << "state " << k;
    if (!(x.t == y.t && SameBits(x.q, y.q) && SameBits(x.v, y.v) &&
          SameBits(x.warm_start, y.warm_start))) {
      ADD_FAILURE() << "state " << k << " differs: q " << x.q.transpose() << " vs "
                    << y.q.transpose();
      break;
    }
  }
  return ta.states.back();
}

// A disc thrown onto a floor: it bounces, slides and starts rolling (the rolling transition
// depends on its inertia, hence on its radius through the inertia from its shape).
std::string DiscScene(const std::string& radius, const std::string& floor_pose = "",
                      const std::string& floor_shape_pose = "",
                      const std::string& formulation = "stewart-trinkle") {
  return R"(
name: disc
dimension: 2
gravity: [0, -9.81]
stepper: {dt: 0.001, formulation: )" +
         formulation + R"(}
friction: {default: 0.3}
bodies:
  - name: floor
    kind: static
)" + (floor_pose.empty() ? "" : "    pose: " + floor_pose + "\n") +
         "    shapes: [{type: halfplane" +
         (floor_shape_pose.empty() ? "" : ", pose: " + floor_shape_pose) + R"(}]
  - name: disc
    mass: 1.0
    pose: {position: [0, 0.25]}
    velocity: {linear: [1.0, 0], angular: 0}
    shapes: [{type: disc, radius: )" +
         radius + "}]\n";
}

// A box dropped tumbling onto an incline.
std::string BoxScene(const std::string& half_z, const std::string& mass,
                     const std::string& incline_pose = "", const std::string& box_shape_pose = "") {
  return R"(
name: box
dimension: 3
stepper: {dt: 0.001, friction_directions: 4, envelope: 0.002}
friction: {default: 0.4}
bodies:
  - name: incline
    kind: static
)" + (incline_pose.empty() ? "" : "    pose: " + incline_pose + "\n") +
         R"(    shapes: [{type: halfspace}]
  - name: box
    mass: )" +
         mass +
         R"(
    pose: {position: [0, 0, 0.3], rpy: [0.2, 0.1, 0]}
    velocity: {linear: [0.5, 0, 0], angular: [0, 1, 2]}
    shapes: [{type: box, half_extents: [0.1, 0.07, )" +
         half_z + "]" + (box_shape_pose.empty() ? "" : ", pose: " + box_shape_pose) + "}]\n";
}

TEST(ParamsTest, DiscRadiusGivesTheSceneFileRollout) {
  const Simulator a(ParseScene(DiscScene("0.1")));
  const Simulator b(ParseScene(DiscScene("0.15")));
  const Params p = WithParams(a, {{"size.disc.s0.radius", 0.15}});
  Workspace ws;
  const Body& resolved = a.Resolve(p, &ws).bodies[1];
  EXPECT_TRUE(SameBits(resolved.inertia, b.scene().bodies[1].inertia));  // recomputed
  EXPECT_FALSE(SameBits(resolved.inertia, a.scene().bodies[1].inertia));
  const State x = ExpectSameRollout(a, p, b, b.DefaultParams(), 600);
  EXPECT_NEAR(x.q[1], 0.15, 1e-3);  // resting on the floor at its new radius
}

// The other formulations read the resolved scene as they read a loaded file.
TEST(ParamsTest, DiscRadiusGivesTheSceneFileRolloutInEveryFormulation) {
  for (const char* f : {"anitescu-potra", "ncp", "gi"}) {
    const Simulator a(ParseScene(DiscScene("0.1", "", "", f)));
    const Simulator b(ParseScene(DiscScene("0.15", "", "", f)));
    SCOPED_TRACE(f);
    ExpectSameRollout(a, WithParams(a, {{"size.disc.s0.radius", 0.15}}), b, b.DefaultParams(), 300);
  }
}

TEST(ParamsTest, BoxHalfExtentAndMassGiveTheSceneFileRollout) {
  const Simulator a(ParseScene(BoxScene("0.05", "1.0", "{rpy: [0, 0.2, 0]}")));
  const Simulator b(ParseScene(BoxScene("0.08", "2.5", "{rpy: [0, 0.2, 0]}")));
  const Params p = WithParams(a, {{"size.box.s0.half_extents.z", 0.08}, {"mass.box", 2.5}});
  ExpectSameRollout(a, p, b, b.DefaultParams(), 400);
}

TEST(ParamsTest, StaticBodyPoseGivesTheSceneFileRollout) {
  {  // planar: x, y, θ
    const Simulator a(ParseScene(DiscScene("0.1")));
    const Simulator b(ParseScene(DiscScene("0.1", "{position: [0.5, -0.05], angle: 0.1}")));
    const Params p =
        WithParams(a, {{"pose.floor.x", 0.5}, {"pose.floor.y", -0.05}, {"pose.floor.theta", 0.1}});
    const State x = ExpectSameRollout(a, p, b, b.DefaultParams(), 600);
    // Uphill the rolling disc slows (g sin θ / 1.5 ≈ 0.65 m/s² for 0.4 s); on the flat floor
    // it rolls on at (2 v0 + r ω0)/3 = 0.67 m/s.
    const Trajectory flat = a.Rollout(a.DefaultParams(), a.InitialState(), 600);
    EXPECT_NEAR(flat.states.back().v[0], 2.0 / 3.0, 1e-3);
    EXPECT_LT(x.v[0], flat.states.back().v[0] - 0.2);
  }
  {  // spatial: position and roll, pitch, yaw
    const Simulator a(ParseScene(BoxScene("0.05", "1.0")));
    const Simulator b(
        ParseScene(BoxScene("0.05", "1.0", "{position: [0, 0, -0.02], rpy: [0.05, 0.3, 0.7]}")));
    const Params p = WithParams(a, {{"pose.incline.z", -0.02},
                                    {"pose.incline.roll", 0.05},
                                    {"pose.incline.pitch", 0.3},
                                    {"pose.incline.yaw", 0.7}});
    ExpectSameRollout(a, p, b, b.DefaultParams(), 400);
  }
}

TEST(ParamsTest, ShapePoseGivesTheSceneFileRollout) {
  {  // a static body's shape
    const Simulator a(ParseScene(DiscScene("0.1")));
    const Simulator b(ParseScene(DiscScene("0.1", "", "{position: [0, -0.02], angle: 0.05}")));
    const Params p = WithParams(a, {{"pose.floor.s0.y", -0.02}, {"pose.floor.s0.theta", 0.05}});
    ExpectSameRollout(a, p, b, b.DefaultParams(), 600);
  }
  {  // a dynamic body's shape, turned about the centre of mass: the inertia is recomputed
    const Simulator a(ParseScene(BoxScene("0.05", "1.0")));
    const Simulator b(ParseScene(BoxScene("0.05", "1.0", "", "{rpy: [0, 0, 0.6]}")));
    const Params p = WithParams(a, {{"pose.box.s0.yaw", 0.6}});
    Workspace ws;
    EXPECT_TRUE(SameBits(a.Resolve(p, &ws).bodies[1].inertia, b.scene().bodies[1].inertia));
    EXPECT_FALSE(SameBits(a.scene().bodies[1].inertia, b.scene().bodies[1].inertia));
    ExpectSameRollout(a, p, b, b.DefaultParams(), 400);
  }
}

// A vibrating, tilting plate (prescribed) carrying a disc.
std::string PlateScene(const std::string& plate_pose, const std::string& tilt) {
  return R"(
name: plate
dimension: 2
gravity: [0, -9.81]
stepper: {dt: 2.0e-4, envelope: 0.002, prescribed_velocity: exact}
friction: {default: 0.3}
bodies:
  - name: plate
    kind: prescribed
    pose: )" +
         plate_pose +
         R"(
    shapes: [{type: halfplane}]
    motion:
      frequency: 20
      tilt: )" +
         tilt +
         R"(
      x: {harmonics: [{order: 1, amplitude: 5.0e-4, phase: -1.5707963267948966}]}
  - name: part
    mass: 0.01
    pose: {position: [0.1, 0.011]}
    shapes: [{type: disc, radius: 0.01}]
)";
}

TEST(ParamsTest, PrescribedPoseAndTiltGiveTheSceneFileRollout) {
  const Simulator a(ParseScene(PlateScene("{position: [0, 0]}", "{amplitude: 0.01, depth: 0.05}")));
  const Simulator b(
      ParseScene(PlateScene("{position: [0.02, 0.001], angle: 0.01}",
                            "{amplitude: 0.02, depth: 0.03, phase: 0.5, frequency: 25}")));
  const Params p = WithParams(a, {{"pose.plate.x", 0.02},
                                  {"pose.plate.y", 0.001},
                                  {"pose.plate.theta", 0.01},
                                  {"motion.plate.tilt.amplitude", 0.02},
                                  {"motion.plate.tilt.depth", 0.03},
                                  {"motion.plate.tilt.phase", 0.5},
                                  {"motion.plate.tilt.frequency", 25.0}});
  ExpectSameRollout(a, p, b, b.DefaultParams(), 1000);
  // The tilt parameters are read from the scene.
  const ParamTable& t = a.scene().param_table();
  EXPECT_EQ(t.info(t.Index("motion.plate.tilt.amplitude")).default_value, 0.01);
  EXPECT_EQ(t.info(t.Index("motion.plate.tilt.frequency")).default_value, 20.0);
  EXPECT_EQ(t.info(t.Index("motion.plate.tilt.depth")).default_value, 0.05);
}

// A square pyramid with its centroid at the origin (base at −h/4, apex at 3h/4), vertices
// exactly representable so that ×1.5 is exact.
std::string PyramidScene(double s) {
  const auto n = [s](double v) { return std::to_string(v * s); };
  return R"(
name: pyramid
dimension: 3
stepper: {dt: 0.001, envelope: 0.002}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfspace}]
  - name: pyramid
    mass: 1.0
    pose: {position: [0, 0, 0.5], rpy: [0.3, 0.2, 0]}
    shapes:
      - type: polyhedron
        vertices: [[)" +
         n(-0.125) + ", " + n(-0.125) + ", " + n(-0.0625) + "], [" + n(0.125) + ", " + n(-0.125) +
         ", " + n(-0.0625) + "], [" + n(0.125) + ", " + n(0.125) + ", " + n(-0.0625) + "], [" +
         n(-0.125) + ", " + n(0.125) + ", " + n(-0.0625) + "], [0, 0, " + n(0.1875) + "]]\n";
}

TEST(ParamsTest, PolyhedronScaleGivesTheSceneFileRollout) {
  const Simulator a(ParseScene(PyramidScene(1.0)));
  const Simulator b(ParseScene(PyramidScene(1.5)));
  const Params p = WithParams(a, {{"size.pyramid.s0.scale", 1.5}});
  Workspace ws;
  const Scene& r = a.Resolve(p, &ws);
  EXPECT_TRUE(SameBits(r.bodies[1].inertia, b.scene().bodies[1].inertia));
  ASSERT_EQ(r.bodies[1].shapes[0].faces.size(), b.scene().bodies[1].shapes[0].faces.size());
  const State x = ExpectSameRollout(a, p, b, b.DefaultParams(), 1000);
  EXPECT_NEAR(x.q[2], 0.0625 * 1.5, 1e-4);  // resting on its (scaled) base
}

TEST(ParamsTest, FrictionPairIsFoundUnderEitherOrderOfItsMaterials) {
  const Simulator sim(ParseScene(
      "dimension: 2\n"
      "materials: [stone, wood]\n"
      "friction: {default: 0.5, pairs: [[wood, stone, 0.3]]}\n"
      "bodies:\n"
      "  - {name: floor, kind: static, shapes: [{type: halfplane, material: stone}]}\n"
      "  - {name: disc, mass: 1, shapes: [{type: disc, radius: 0.1, material: wood}]}\n"));
  const ParamTable& t = sim.scene().param_table();
  const int i = t.Index("mu.stone.wood");
  EXPECT_EQ(t.Index("mu.wood.stone"), i);
  EXPECT_EQ(t.info(i).default_value, 0.3);
  EXPECT_LT(t.Find("mu.wood.wood"), 0);  // not a listed pair
  EXPECT_LT(t.Find("mu.stone"), 0);
  EXPECT_THROW(t.Index("mu.wood.steel"), std::invalid_argument);
}

TEST(ParamsTest, TableNamesDefaultsAndFlags) {
  const Simulator sim(ParseScene(DiscScene("0.1", "{position: [0.5, -0.05], angle: 0.1}")));
  const ParamTable& t = sim.scene().param_table();
  // Static body pose and every shape's pose; no pose for the dynamic body (it is the state).
  for (const char* name : {"pose.floor.x", "pose.floor.y", "pose.floor.theta", "pose.floor.s0.x",
                           "pose.disc.s0.theta"})
    EXPECT_GE(t.Find(name), 0) << name;
  EXPECT_LT(t.Find("pose.disc.x"), 0);
  EXPECT_EQ(t.info(t.Index("pose.floor.x")).default_value, 0.5);
  EXPECT_NEAR(t.info(t.Index("pose.floor.theta")).default_value, 0.1, 1e-15);
  EXPECT_EQ(t.DifferentiableNames(), (std::vector<std::string>{"mu.default", "mass.disc"}));
  for (const ParamInfo& p : t.all())
    EXPECT_EQ(p.differentiable, p.kind == ParamKind::kDefaultFriction ||
                                    p.kind == ParamKind::kFriction || p.kind == ParamKind::kMass ||
                                    p.kind == ParamKind::kSupportFriction)
        << p.name;
  // A resolved scene reads back the applied values.
  Params p = sim.DefaultParams();
  for (int i = 0; i < t.size(); ++i)  // (moving the disc's shape would move its centroid)
    if (t.info(i).name != "pose.disc.s0.x" && t.info(i).name != "pose.disc.s0.y")
      p.values[i] += 0.01 * (i + 1);
  const Scene r = sim.scene().ApplyParams(p);
  for (int i = 0; i < t.size(); ++i)
    EXPECT_NEAR(r.ParamValue(t.info(i)), p.values[i], 1e-14) << t.info(i).name;
}

TEST(ParamsTest, UnchangedPoseKeepsItsBits) {
  Scene s = ParseScene(BoxScene("0.05", "1.0", "{quaternion: [0.9, 0.1, 0.3, 0.2]}"));
  const Simulator sim(s);
  const Scene same = sim.scene().ApplyParams(sim.DefaultParams());
  EXPECT_TRUE(same.bodies[0].X_WB0.matrix() == sim.scene().bodies[0].X_WB0.matrix());
  EXPECT_TRUE(SameBits(same.bodies[1].inertia, sim.scene().bodies[1].inertia));
  const Scene moved = sim.scene().ApplyParams(WithParams(sim, {{"pose.incline.x", 0.25}}));
  EXPECT_TRUE(moved.bodies[0].X_WB0.linear() == sim.scene().bodies[0].X_WB0.linear());
  EXPECT_EQ(moved.bodies[0].X_WB0.translation().x(), 0.25);
}

TEST(ParamsTest, InvalidChangesAreRejected) {
  const Simulator box(ParseScene(BoxScene("0.05", "1.0")));
  // Moving a dynamic body's only shape moves its centroid off the body origin.
  try {
    box.scene().ApplyParams(WithParams(box, {{"pose.box.s0.x", 0.1}}));
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("centre of mass"), std::string::npos) << e.what();
  }
  EXPECT_THROW(box.scene().ApplyParams(WithParams(box, {{"size.box.s0.half_extents.x", 0.0}})),
               std::invalid_argument);
  const Simulator plate(
      ParseScene(PlateScene("{position: [0, 0]}", "{amplitude: 0.01, depth: 0.05}")));
  try {
    plate.scene().ApplyParams(WithParams(plate, {{"motion.plate.tilt.frequency", 0.0}}));
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tilt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vinci::sim
