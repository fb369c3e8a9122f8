// Vibrating plate (issue 6): plate motions (harmonics of a base frequency, the tilting family,
// integrated poses), the exact plate velocity in ∂ψ/∂t, velocity fields, and the cycle-averaged
// theory of point parts (applications.md §C).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <string>

#include "test_util.h"
#include "vinci/sim/formulations/stewart_trinkle.h"
#include "vinci/sim/plate/plate_theory.h"
#include "vinci/sim/plate/velocity_field.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;
constexpr double kExactTol = 1e-12;  // closed forms evaluated two ways: rounding only
constexpr double kFdTol = 1e-6;      // central differences, step 1e-6 s, on smooth signals

// A spatial conveyor scene: x = a_x/ω² sin ωt, z = a_z/ω² (sin(ωt + φ_z) − sin φ_z), point part.
std::string ConveyorYaml(double f, double a_x, double a_z, double phase_z, int steps_per_cycle,
                         double mu = 0.2) {
  const double w = 2 * kPi * f;
  std::ostringstream s;
  s.precision(17);
  s << "name: conveyor\ndimension: 3\n"
    << "stepper: {dt: " << 1.0 / (f * steps_per_cycle)
    << ", envelope: 0.002, prescribed_velocity: exact}\n"
    << "friction: {default: " << mu << "}\n"
    << "bodies:\n"
    << "  - {name: plate, kind: prescribed, shapes: [{type: halfspace}],\n"
    << "     motion: {frequency: " << f
    << ", x: {harmonics: [{order: 1, amplitude: " << a_x / (w * w)
    << "}]}, z: {harmonics: [{order: 1, amplitude: " << a_z / (w * w) << ", phase: " << phase_z
    << "}]}}}\n"
    << "  - {name: part, mass: 0.01, inertia: [1, 1, 1], pose: {position: [0, 0, 0.001]},\n"
    << "     shapes: [{type: sphere, radius: 0.001}]}\n";
  return s.str();
}

FieldSpec OnePoint(const Scene& s, double f, int cycles, int average) {
  FieldSpec spec;
  spec.plate = s.FindBody("plate");
  spec.part = s.FindBody("part");
  spec.frequency = f;
  spec.nx = spec.ny = 1;
  spec.cycles = cycles;
  spec.average_cycles = average;
  return spec;
}

// ----- plate motions ---------------------------------------------------------------------------

TEST(PlateMotionTest, PlanarTiltFamilyMatchesClosedForm) {
  PrescribedMotion m;
  m.tilt.amplitude = 0.05;
  m.tilt.frequency = 7.0;
  m.tilt.phase = 0.3;
  m.tilt.depth = 0.1;
  const Isometry3d X0 = PlanarPose(0.2, -0.1, 0.0);
  for (double t : {0.0, 0.011, 0.037, 0.1}) {
    const double th = 0.05 * std::sin(2 * kPi * 7.0 * t + 0.3);
    const BodyKinematics k = EvaluateMotion(m, X0, true, t);
    EXPECT_NEAR(k.X_WB.translation().x(), 0.2 - 0.1 * std::sin(th), kExactTol);
    EXPECT_NEAR(k.X_WB.translation().y(), -0.1 + 0.1 * (std::cos(th) - 1), kExactTol);
    EXPECT_NEAR(std::atan2(k.X_WB.linear()(1, 0), k.X_WB.linear()(0, 0)), th, kExactTol);
    const double e = 1e-6;
    const Vector3d v_fd = (EvaluateMotion(m, X0, true, t + e).X_WB.translation() -
                           EvaluateMotion(m, X0, true, t - e).X_WB.translation()) /
                          (2 * e);
    EXPECT_NEAR((k.v_WB - v_fd).norm(), 0.0, kFdTol);
    // The axis point (0, −d) below the surface stays fixed.
    EXPECT_NEAR((k.X_WB * Vector3d(0, -0.1, 0) - Vector3d(0.2, -0.2, 0)).norm(), 0.0, kExactTol);
  }
}

TEST(PlateMotionTest, SpatialTiltTurnsAboutHorizontalAxisAtDepth) {
  PrescribedMotion m;
  m.dofs.resize(6);
  m.dofs[2].harmonics = {{1e-4, 30.0, 0.5}};  // combined with a vertical vibration
  m.tilt.amplitude = 0.03;
  m.tilt.frequency = 30.0;
  m.tilt.depth = 0.05;
  m.tilt.axis_B = Vector3d(0, 1, 0);
  const Isometry3d X0 = Isometry3d::Identity();
  for (double t : {0.004, 0.013}) {
    const BodyKinematics k = EvaluateMotion(m, X0, false, t);
    const double th = m.tilt.Angle(t);
    // The axis point (0, 0, −d) moves only with the vertical dof.
    const Vector3d c = k.X_WB * Vector3d(0, 0, -0.05);
    EXPECT_NEAR((c - Vector3d(0, 0, -0.05 + m.dofs[2].Value(t))).norm(), 0.0, kExactTol);
    EXPECT_NEAR(
        (k.X_WB.linear() * Vector3d::UnitZ() - Vector3d(std::sin(th), 0, std::cos(th))).norm(), 0.0,
        kExactTol);
    EXPECT_NEAR((k.w_WB - m.tilt.Rate(t) * Vector3d::UnitY()).norm(), 0.0, kExactTol);
    const double e = 1e-6;
    const Vector3d v_fd = (EvaluateMotion(m, X0, false, t + e).X_WB.translation() -
                           EvaluateMotion(m, X0, false, t - e).X_WB.translation()) /
                          (2 * e);
    EXPECT_NEAR((k.v_WB - v_fd).norm(), 0.0, kFdTol);
  }
}

TEST(PlateMotionTest, IntegratedPoseIsTheStepwiseSumOfRates) {
  DofMotion d;
  d.velocity = 0.01;
  d.harmonics = {{1e-3, 30.0, 0.4}, {2e-4, 60.0, -1.0}};
  const double h = 1e-3;
  double sum = 0.0;
  for (int l = 1; l <= 250; ++l) {
    sum += h * d.Rate(l * h);
    if (l % 50 == 0) {
      EXPECT_NEAR(d.IntegratedValue(l * h, h), sum, kExactTol);
      // First order: Σ h r(kh) − ∫ r = (h/2)(r(t) − r(0)) + O(h²), at most h·max|r|.
      const double max_rate = 0.01 + 1e-3 * 2 * kPi * 30 + 2e-4 * 2 * kPi * 60;
      EXPECT_LT(std::abs(d.IntegratedValue(l * h, h) - d.Value(l * h)), h * max_rate);
    }
  }
  TiltMotion tilt;
  tilt.amplitude = 0.02;
  tilt.frequency = 30.0;
  tilt.phase = 0.2;
  double th = tilt.Angle(0.0);
  for (int l = 1; l <= 100; ++l) th += h * tilt.Rate(l * h);
  EXPECT_NEAR(tilt.IntegratedAngle(100 * h, h), th, kExactTol);
  // The integrated rule is honoured only with a step.
  PrescribedMotion m;
  m.dofs.resize(3);
  m.dofs[0] = d;
  m.pose = PoseRule::kIntegrated;
  const Isometry3d X0 = Isometry3d::Identity();
  EXPECT_NEAR(EvaluateMotion(m, X0, true, 0.1, h).X_WB.translation().x(), d.IntegratedValue(0.1, h),
              kExactTol);
  EXPECT_NEAR(EvaluateMotion(m, X0, true, 0.1).X_WB.translation().x(), d.Value(0.1), kExactTol);
}

TEST(PlateMotionTest, SceneFileHarmonicOrdersTiltAndPoseRule) {
  const Scene s = ParseScene(R"(
name: p
dimension: 3
stepper: {prescribed_velocity: exact}
bodies:
  - name: plate
    kind: prescribed
    shapes: [{type: halfspace}]
    motion:
      frequency: 25
      pose: integrated
      x: {harmonics: [{order: 1, amplitude: 0.001}, {order: 3, amplitude: 0.0002, phase: 1}]}
      tilt: {amplitude: 0.01, depth: 0.04, axis: [0, 2, 0]}
)");
  const PrescribedMotion& m = s.bodies[0].motion;
  EXPECT_EQ(m.pose, PoseRule::kIntegrated);
  EXPECT_EQ(s.options.prescribed_velocity, PrescribedVelocity::kExact);
  EXPECT_DOUBLE_EQ(m.base_frequency, 25.0);
  ASSERT_EQ(m.dofs[0].harmonics.size(), 2u);
  EXPECT_DOUBLE_EQ(m.dofs[0].harmonics[1].frequency, 75.0);
  EXPECT_DOUBLE_EQ(m.tilt.frequency, 25.0);  // inherits the base frequency
  EXPECT_DOUBLE_EQ(m.tilt.depth, 0.04);
  EXPECT_NEAR((m.tilt.axis_B - Vector3d::UnitY()).norm(), 0.0, kExactTol);
}

TEST(PlateMotionTest, SceneFileRejectsBadPlateMotions) {
  const auto scene = [](const std::string& motion) {
    return "dimension: 3\nbodies:\n  - name: plate\n    kind: prescribed\n    motion: " + motion +
           "\n";
  };
  const auto expect_error = [](const std::string& text, const std::string& needle) {
    try {
      ParseScene(text, "plate.yaml");
      FAIL() << "no error for " << text;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expect_error(scene("{x: {harmonics: [{order: 2, amplitude: 1}]}}"),
               "plate.yaml:5: bodies[0].motion.x.harmonics[0].order");
  expect_error(scene("{frequency: 5, x: {harmonics: [{order: 0}]}}"), "an integer >= 1");
  expect_error(scene("{frequency: 5, x: {harmonics: [{order: 1, frequency: 5}]}}"), "not both");
  expect_error(scene("{tilt: {amplitude: 0.1}}"), "tilt.frequency");
  expect_error(scene("{frequency: 5, tilt: {amplitude: 0.1, axis: [0, 0, 1]}}"),
               "in the plate plane");
  expect_error(scene("{pose: approximate}"), "a pose rule (exact, integrated)");
  expect_error(
      "dimension: 3\nstepper: {prescribed_velocity: mean}\nbodies: [{name: a, kind: "
      "static}]\n",
      "a prescribed-velocity rule (secant, exact)");
}

TEST(PlateMotionTest, SceneRejectsABadTiltBuiltInCode) {
  Scene s = ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.0, 50));
  s.bodies[0].motion.tilt.amplitude = 0.01;
  s.bodies[0].motion.tilt.frequency = 30.0;
  s.bodies[0].motion.tilt.axis_B = Vector3d(0, 0, 1);  // the normal, not in the plate plane
  try {
    s.Finalize();
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tilt axis"), std::string::npos) << e.what();
  }
  s.bodies[0].motion.tilt.axis_B = Vector3d(0, 1, 0);
  s.bodies[0].motion.tilt.frequency = 0.0;
  EXPECT_THROW(s.Finalize(), std::invalid_argument);
}

// ----- the exact plate velocity in ∂ψ/∂t ---------------------------------------------------------

TEST(PlateVelocityTest, ExactRuleUsesThePrescribedVelocityAtTheStepEnd) {
  Scene scene = ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.5 * kPi, 100));
  for (PrescribedVelocity rule : {PrescribedVelocity::kExact, PrescribedVelocity::kSecant}) {
    scene.options.prescribed_velocity = rule;
    Simulator sim(scene);
    const auto& st = dynamic_cast<const StewartTrinkle&>(sim.formulation());
    State x = sim.InitialState();
    x.t = 0.0123;
    const double h = scene.options.dt;
    const StewartTrinkle::Assembly a = st.Assemble(sim.scene(), x, StepInput{});
    ASSERT_EQ(a.contacts.size(), 1u);
    const Body& plate = sim.scene().bodies[0];
    const BodyKinematics k0 = EvaluateMotion(plate.motion, plate.X_WB0, false, x.t);
    const BodyKinematics k1 = EvaluateMotion(plate.motion, plate.X_WB0, false, x.t + h);
    // The part (body a, index 1 > plate) is pushed along n = +z; the plate enters with sign −1.
    const Vector3d n = a.contacts[0].point.n_W;
    const double expected = rule == PrescribedVelocity::kExact
                                ? -n.dot(k1.v_WB)
                                : -n.dot(k1.X_WB.translation() - k0.X_WB.translation()) / h;
    const double sign = a.contacts[0].body_a == 1 ? 1.0 : -1.0;
    EXPECT_NEAR(sign * a.dpsi_n[0], expected, kExactTol) << static_cast<int>(rule);
  }
}

// ----- velocity fields ---------------------------------------------------------------------------

TEST(VelocityFieldTest, BitIdenticalForAnyThreadCount) {
  const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_whirlpool.yaml";
  Simulator sim(LoadSceneFile(path));
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.nx = 3;
  spec.ny = 2;
  spec.cycles = 3;
  spec.average_cycles = 2;
  int calls = 0;
  const VelocityField one = ComputeVelocityField(sim, sim.DefaultParams(), spec, {1, {}});
  const VelocityField three =
      ComputeVelocityField(sim, sim.DefaultParams(), spec, {3, [&](int done, int total) {
                                                              ++calls;
                                                              EXPECT_LE(done, total);
                                                            }});
  EXPECT_EQ(calls, 6);
  std::ostringstream a, b;
  WriteFieldCsv(one, a);
  WriteFieldCsv(three, b);
  EXPECT_EQ(a.str(), b.str());
  ASSERT_EQ(one.points.size(), 6u);
  EXPECT_EQ(one.points[4].x, 0.0);  // row-major: y outer, x inner
  EXPECT_EQ(one.points[4].y, 0.1);
  EXPECT_NE(one.points[0].vx, 0.0);  // the part moved
}

// issue 18 finding 6: an exception inside a point (here a parameter out of its range) is
// rethrown after every thread is joined — never std::terminate — for any thread count.
TEST(VelocityFieldTest, ErrorInsideAPointIsRethrownForAnyThreadCount) {
  const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_whirlpool.yaml";
  Simulator sim(LoadSceneFile(path));
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.nx = spec.ny = 3;
  spec.cycles = spec.average_cycles = 1;
  Params bad = sim.DefaultParams();
  bad.values[sim.scene().param_table().Index("size.part.s0.radius")] = -1.0;
  for (int threads : {1, 2, 4}) {
    try {
      ComputeVelocityField(sim, bad, spec, {threads, {}});
      ADD_FAILURE() << "no exception, " << threads << " threads";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("size.part.s0.radius"), std::string::npos) << e.what();
    }
  }
}

TEST(VelocityFieldTest, PartLeavingThePlateIsFlaggedAndStops) {
  Scene scene = ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.5 * kPi, 50));
  Simulator sim(scene);
  FieldSpec spec = OnePoint(sim.scene(), 30.0, 20, 5);
  spec.plate_x_min = -0.002;  // the conveyor moves the part toward −x at ~7 cm/s
  const FieldPoint p = ComputeFieldPoint(sim, sim.DefaultParams(), spec, 0.0, 0.0);
  EXPECT_TRUE(p.left_plate);
  EXPECT_FALSE(p.failed);
  EXPECT_LT(p.vx, 0.0);
  EXPECT_LT(p.averaged_time, 5.0 / 30.0);  // stopped before the averaging window
}

// ----- theory vs simulation ----------------------------------------------------------------------

// Tolerance between the simulated and the theoretical asymptotic velocity, derived:
// the theory holds v constant over a cycle, but friction changes the part's velocity within a
// cycle by up to ∫μN/m dt over the sliding half of it, μ ḡ T/2 with ḡ = mean N/m = g (no
// separation). The balance is linear in that excursion, so the averaged velocity can be off by
// at most about μ g T / 2. The stepper adds its first-order error, bounded by the plate's
// velocity change over one step, h·a_max.
double TheoryTolerance(double mu, double f, double h, double a_max) {
  return 0.5 * mu * kG / f + h * a_max;
}

TEST(PlateTheoryTest, ConveyorAgreesWithSimulationAndImprovesWithFrequency) {
  // Fixed accelerations (x 30 m/s², z 5 m/s²): plate speed a/ω; μgT/(a_x/ω) = 2πμg/a_x = 0.41.
  double prev_error = 1e9;
  for (double f : {30.0, 60.0, 120.0}) {
    Simulator sim(ParseScene(ConveyorYaml(f, 30.0, 5.0, 0.5 * kPi, 100)));
    const FieldSpec spec = OnePoint(sim.scene(), f, 30, 10);
    const FieldPoint p = ComputeFieldPoint(sim, sim.DefaultParams(), spec, 0.0, 0.0);
    const PointTheoryResult th = SolvePointVelocity(
        PlateTheoryFromScene(sim.scene(), spec.plate, spec.part, f), Vector2d::Zero());
    ASSERT_TRUE(th.ok) << th.failure;
    ASSERT_FALSE(p.failed) << p.failure;
    EXPECT_DOUBLE_EQ(th.contact_fraction, 1.0);  // a_z < g: never separates
    const double error = std::hypot(p.vx - th.v.x(), p.vy - th.v.y());
    const double tol = TheoryTolerance(0.2, f, sim.scene().options.dt, 30.0);
    EXPECT_LT(error, tol) << "f = " << f << " sim " << p.vx << " theory " << th.v.x();
    EXPECT_LT(th.v.x(), -0.1 * 30.0 / (2 * kPi * f));  // conveys toward −x, > 10% plate speed
    EXPECT_LT(error, prev_error) << "f = " << f;       // monotone improvement
    prev_error = error;
  }
}

TEST(PlateTheoryTest, ConveyingReversesWithThePhase) {
  for (double phase : {0.5 * kPi, -0.5 * kPi}) {
    Simulator sim(ParseScene(ConveyorYaml(30.0, 30.0, 5.0, phase, 100)));
    const FieldSpec spec = OnePoint(sim.scene(), 30.0, 20, 5);
    const FieldPoint p = ComputeFieldPoint(sim, sim.DefaultParams(), spec, 0.03, -0.02);
    const PointTheoryResult th = SolvePointVelocity(
        PlateTheoryFromScene(sim.scene(), spec.plate, spec.part, 30.0), Vector2d(0.03, -0.02));
    const double sign = phase > 0 ? -1.0 : 1.0;
    // Uniform conveying along ∓x, at > 30% of the plate's speed 0.159 m/s; no sideways drift
    // beyond the 4-direction cone's rounding (1e-9 m/s).
    EXPECT_GT(sign * p.vx, 0.3 * 0.159);
    EXPECT_GT(sign * th.v.x(), 0.3 * 0.159);
    EXPECT_LT(std::abs(p.vy), 1e-9);
  }
}

TEST(PlateTheoryTest, YawWithVerticalVibrationMakesAWhirlpool) {
  const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_whirlpool.yaml";
  for (double phase : {-0.5 * kPi, 0.5 * kPi}) {
    Scene scene = LoadSceneFile(path);
    scene.bodies[0].motion.dofs[2].harmonics[0].phase = phase;
    scene.options.friction_directions = 16;  // a rounder cone: less spurious drift
    Simulator sim(scene);
    FieldSpec spec = LoadFieldSpec(path, sim.scene());
    spec.cycles = 6;
    spec.average_cycles = 2;
    const PlateTheoryInput in = PlateTheoryFromScene(sim.scene(), 0, 1, 30.0);
    const double ccw = phase < 0 ? 1.0 : -1.0;
    for (double angle : {0.3, 2.0, 4.0}) {
      const Vector2d r = 0.06 * Vector2d(std::cos(angle), std::sin(angle));
      const FieldPoint p = ComputeFieldPoint(sim, sim.DefaultParams(), spec, r.x(), r.y());
      const Vector2d at(p.x_mean, p.y_mean), v(p.vx, p.vy);
      const Vector2d tangent = Vector2d(-at.y(), at.x()).normalized();
      // Tangential circulation with the phase's sign dominates the (centripetal) radial drift.
      EXPECT_GT(ccw * v.dot(tangent), 2.0 * std::abs(v.dot(at.normalized()))) << angle;
      const PointTheoryResult th = SolvePointVelocity(in, r);
      ASSERT_TRUE(th.ok);
      const Vector2d t_r = Vector2d(-r.y(), r.x()).normalized();
      EXPECT_GT(ccw * th.v.dot(t_r), 0.0);
      EXPECT_LT(std::abs(th.v.dot(r.normalized())), 1e-9);  // purely tangential (symmetry)
    }
    // Tangential speed ∝ r in the theory (rigid rotation of the plate: v_p ∝ r).
    const double v1 = SolvePointVelocity(in, Vector2d(0.03, 0)).v.norm();
    const double v2 = SolvePointVelocity(in, Vector2d(0.06, 0)).v.norm();
    EXPECT_NEAR(v2 / v1, 2.0, 1e-6);
  }
}

TEST(PlateTheoryTest, TiltingFamilyMakesLinesOfAttractionOrRepulsion) {
  const std::string path =
      std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_tilt_planar.yaml";
  for (double phase : {-0.5 * kPi, 0.5 * kPi}) {
    Scene scene = LoadSceneFile(path);
    scene.bodies[0].motion.dofs[0].harmonics[0].phase = phase;
    Simulator sim(scene);
    FieldSpec spec = LoadFieldSpec(path, sim.scene());
    spec.cycles = 8;
    spec.average_cycles = 2;
    const PlateTheoryInput in = PlateTheoryFromScene(sim.scene(), 0, 1, spec.frequency);
    const double attract = phase < 0 ? 1.0 : -1.0;
    // |x| ≤ 0.06 m: the tilt's normal acceleration x α ω² ≤ 9.5 m/s² < g, no separation (with
    // separation, farther out, the simulated field turns over before the theory's does).
    for (double x : {-0.06, -0.03, 0.03, 0.06}) {
      const FieldPoint p = ComputeFieldPoint(sim, sim.DefaultParams(), spec, x, 0.0);
      const PointTheoryResult th = SolvePointVelocity(in, Vector2d(x, 0));
      ASSERT_TRUE(th.ok);
      // Attraction: velocity toward the line x = 0 above the axis; repulsion: away from it.
      EXPECT_LT(attract * p.vx * x, 0.0) << x;
      EXPECT_LT(attract * th.v.x() * x, 0.0) << x;
    }
    // On the line itself the field vanishes (symmetry x → −x).
    EXPECT_LT(std::abs(SolvePointVelocity(in, Vector2d::Zero()).v.x()), 1e-9);
  }
}

TEST(PlateTheoryTest, SpatialTiltMakesALineOfAttractionAlongTheAxis) {
  // Tilt about x at depth d with a y vibration: the line y = 0 attracts, whatever x.
  const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_tilt.yaml";
  Simulator sim(LoadSceneFile(path));
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.x_min = spec.x_max = 0.03;
  spec.nx = 1;
  spec.y_min = -0.04;
  spec.y_max = 0.04;
  spec.ny = 3;
  spec.cycles = 6;
  spec.average_cycles = 2;
  const VelocityField field = ComputeVelocityField(sim, sim.DefaultParams(), spec, {2, {}});
  const PlateTheoryInput in = PlateTheoryFromScene(sim.scene(), 0, 1, spec.frequency);
  for (const FieldPoint& p : field.points) {
    EXPECT_LT(std::abs(p.vx), 1e-9);  // nothing drives the part along the axis
    const PointTheoryResult th = SolvePointVelocity(in, Vector2d(p.x, p.y));
    ASSERT_TRUE(th.ok);
    if (p.y == 0.0) {
      EXPECT_LT(std::abs(th.v.y()), 1e-9);  // on the line: no field (symmetry y → −y)
      continue;
    }
    EXPECT_LT(p.vy * p.y, 0.0) << p.y;  // toward the line
    EXPECT_LT(th.v.y() * p.y, 0.0) << p.y;
  }
}

TEST(PlateTheoryTest, SlidingAwayAndBadInputAreReported) {
  PlateTheoryInput in;
  in.period = 0.05;
  in.mu = 0.1;
  in.X_WP0.linear() = Eigen::AngleAxisd(0.3, Vector3d::UnitX()).toRotationMatrix();  // tan > μ
  const PointTheoryResult r = SolvePointVelocity(in, Vector2d::Zero());
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.failure.find("slides away"), std::string::npos);
  in.period = 0.0;
  EXPECT_THROW(SolvePointVelocity(in, Vector2d::Zero()), std::invalid_argument);
}

// ----- convergence in h --------------------------------------------------------------------------

TEST(PlateConvergenceTest, DisplacementConvergesAtFirstOrder) {
  // The part's displacement over 4 cycles of the conveyor against a T/1600 reference; the
  // least-squares log–log slope over T/25..T/200 must be near 1 (first order, Stewart–Trinkle).
  const auto displacement = [](int steps_per_cycle) {
    Simulator sim(ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.5 * kPi, steps_per_cycle)));
    const Trajectory tr = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 4 * steps_per_cycle);
    EXPECT_TRUE(tr.ok) << tr.failure;
    return tr.states.back().q[0];
  };
  const double ref = displacement(1600);
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  std::vector<double> errors;
  for (int n : {25, 50, 100, 200}) {
    const double e = std::abs(displacement(n) - ref);
    errors.push_back(e);
    const double lx = std::log(1.0 / n), ly = std::log(e);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
  }
  const double slope = (4 * sxy - sx * sy) / (4 * sxx - sx * sx);
  EXPECT_GT(slope, 0.8);  // first order (noise from stick–slip switches at step boundaries)
  EXPECT_LT(errors.back(), errors.front() / 4);
}

}  // namespace
}  // namespace vinci::sim
