// Long vibrating-plate checks (label slow): finer steps and more cycles than tests/sim/
// plate_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "vinci/sim/plate_theory.h"
#include "vinci/sim/scene_file.h"
#include "vinci/sim/velocity_field.h"

namespace vinci::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.81;

std::string ConveyorYaml(double f, double a_x, double a_z, double phase_z, int steps_per_cycle) {
  const double w = 2 * kPi * f;
  std::ostringstream s;
  s.precision(17);
  s << "dimension: 3\nstepper: {dt: " << 1.0 / (f * steps_per_cycle)
    << ", envelope: 0.002, prescribed_velocity: exact}\nfriction: {default: 0.2}\nbodies:\n"
    << "  - {name: plate, kind: prescribed, shapes: [{type: halfspace}], motion: {frequency: " << f
    << ", x: {harmonics: [{order: 1, amplitude: " << a_x / (w * w)
    << "}]}, z: {harmonics: [{order: 1, amplitude: " << a_z / (w * w) << ", phase: " << phase_z
    << "}]}}}\n  - {name: part, mass: 0.01, inertia: [1, 1, 1], pose: {position: [0, 0, 0.001]},"
       " shapes: [{type: sphere, radius: 0.001}]}\n";
  return s.str();
}

FieldPoint Simulate(const Simulator& sim, double f, int cycles, int average) {
  FieldSpec spec;
  spec.plate = 0;
  spec.part = 1;
  spec.frequency = f;
  spec.nx = spec.ny = 1;
  spec.cycles = cycles;
  spec.average_cycles = average;
  return ComputeFieldPoint(sim, sim.DefaultParams(), spec, 0.0, 0.0);
}

// Theory vs simulation over four frequencies at fixed accelerations with fine steps (T/400) and
// 60 cycles: within μgT/2 + h·a_max (derivation in tests/sim/plate_test.cc), monotone in f.
TEST(PlateSlowTest, ConveyorTheoryAgreementOverFourFrequencies) {
  double prev = 1e9;
  for (double f : {15.0, 30.0, 60.0, 120.0}) {
    Simulator sim(ParseScene(ConveyorYaml(f, 30.0, 5.0, 0.5 * kPi, 400)));
    const FieldPoint p = Simulate(sim, f, 60, 20);
    const PointTheoryResult th =
        SolvePointVelocity(PlateTheoryFromScene(sim.scene(), 0, 1, f), Vector2d::Zero());
    ASSERT_TRUE(th.ok);
    const double err = std::abs(p.vx - th.v.x());
    EXPECT_LT(err, 0.5 * 0.2 * kG / f + sim.scene().options.dt * 30.0) << f;
    EXPECT_LT(err, prev) << f;
    prev = err;
  }
}

// The averaged velocity converges as h shrinks: against a T/800 reference, the T/400 error is
// below the T/50 error. (Known: for T/h >= 1200 the averaged velocity shifts by 0.6% to another
// value, with Lemke and PGS alike; not yet explained, see docs/field.md.)
TEST(PlateSlowTest, AveragedVelocityConvergesInH) {
  const auto v = [](int n) {
    Simulator sim(ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.5 * kPi, n)));
    return Simulate(sim, 30.0, 40, 20).vx;
  };
  const double ref = v(800);
  const double e50 = std::abs(v(50) - ref), e400 = std::abs(v(400) - ref);
  EXPECT_LT(e400, e50);
  EXPECT_LT(e400, 2e-3 * std::abs(ref));  // 0.2%: the noise floor of stick–slip switching
}

// A 5 × 5 whirlpool with a fine friction cone (n_d = 32): every off-centre point circulates
// counter-clockwise, tangential speed above the radial drift.
TEST(PlateSlowTest, WhirlpoolFieldCirculatesEverywhere) {
  const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_whirlpool.yaml";
  Scene scene = LoadSceneFile(path);
  scene.options.friction_directions = 32;
  Simulator sim(scene);
  FieldSpec spec = LoadFieldSpec(path, sim.scene());
  spec.nx = spec.ny = 5;
  spec.cycles = 10;
  spec.average_cycles = 3;
  const VelocityField field = ComputeVelocityField(sim, sim.DefaultParams(), spec, {2, {}});
  for (const FieldPoint& p : field.points) {
    if (p.x == 0.0 && p.y == 0.0) continue;
    const Vector2d r(p.x_mean, p.y_mean), v(p.vx, p.vy);
    const Vector2d t = Vector2d(-r.y(), r.x()).normalized();
    EXPECT_GT(v.dot(t), std::abs(v.dot(r.normalized()))) << p.x << ", " << p.y;
  }
}

}  // namespace
}  // namespace vinci::sim
