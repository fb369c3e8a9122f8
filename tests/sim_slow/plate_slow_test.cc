// Long vibrating-plate checks (label slow): finer steps and more cycles than tests/sim/
// plate_test.cc.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/plate_theory.h"
#include "vinci/sim/plate/velocity_field.h"

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

// The averaged velocity converges at first order, erratically: one stick step per cycle pins
// the periodic motion (where the part's velocity crosses the plate's), and where that crossing
// falls in the step grid moves the steady velocity by up to the plate's velocity change in one
// step, h·a_max (a_max = 30 m/s²). So |v(h) − v(h → 0)| ≤ h·a_max, checked against T/6400 (whose
// own error, ≤ 1.6e-4 m/s by the same bound, is included).
TEST(PlateSlowTest, AveragedVelocityConvergesInH) {
  const auto v = [](int n) {
    Simulator sim(ParseScene(ConveyorYaml(30.0, 30.0, 5.0, 0.5 * kPi, n)));
    return Simulate(sim, 30.0, 40, 20).vx;
  };
  const double a_max = 30.0, f = 30.0;
  const double ref = v(6400), ref_err = a_max / (f * 6400);
  for (int n : {50, 100, 283, 800, 1100}) {
    EXPECT_LT(std::abs(v(n) - ref), a_max / (f * n) + ref_err) << "T/h = " << n;
  }
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
