// Builds a scene in code with the installed vinci::sim, rolls it out and checks the result:
// a sphere (r = 0.1 m, 1 kg) dropped onto a static half-space must come to rest on it.
#include <cmath>
#include <cstdio>
#include <exception>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/model/scene.h"
#include "vinci/sim/model/state.h"
#include "vinci/sim/simulator/simulator.h"

namespace vs = vinci::sim;

int main() {
  constexpr double kRadius = 0.1;      // m
  constexpr int kSteps = 1000;         // 1 s at the default dt = 1e-3 s
  constexpr double kTolerance = 2e-3;  // m; resting height within the contact envelope (1e-3)
  try {
    vs::Scene scene;
    scene.dim = vs::Dim::kSpatial;
    scene.name = "consumer_sphere_on_ground";

    vs::Body ground;
    ground.name = "ground";
    ground.kind = vs::BodyKind::kStatic;
    vs::Shape half_space;
    half_space.type = vs::ShapeType::kHalfSpace;
    ground.shapes.push_back(half_space);
    scene.bodies.push_back(ground);

    vs::Body ball;
    ball.name = "ball";
    ball.kind = vs::BodyKind::kDynamic;
    ball.mass = 1.0;
    vs::Shape sphere;
    sphere.type = vs::ShapeType::kSphere;
    sphere.radius = kRadius;
    ball.shapes.push_back(sphere);
    ball.X_WB0.translation() = vs::Vector3d(0.0, 0.0, 0.2);  // 0.1 m above the ground
    scene.bodies.push_back(ball);

    vs::Simulator sim(scene);
    const vs::Trajectory traj = sim.Rollout(sim.DefaultParams(), sim.InitialState(), kSteps);

    bool all_ok = traj.ok && static_cast<int>(traj.steps.size()) == kSteps;
    for (const vs::StepInfo& s : traj.steps) all_ok = all_ok && s.ok;
    if (!all_ok) {
      std::fprintf(stderr, "consumer: rollout failed after %zu steps: %s\n", traj.steps.size(),
                   traj.failure.c_str());
      return 1;
    }
    const int b = sim.scene().FindBody("ball");
    const double z = traj.states.back().q[sim.scene().index(b).q + 2];  // q = (p, quaternion)
    const double vz = traj.states.back().v[sim.scene().index(b).v + 2];
    std::printf("consumer: %d steps (dt = %g s), final z = %.6f m, v_z = %.3g m/s\n", kSteps,
                sim.scene().options.dt, z, vz);
    if (!(std::abs(z - kRadius) < kTolerance)) {
      std::fprintf(stderr, "consumer: sphere should rest at z = %g m (±%g), got %.6f\n", kRadius,
                   kTolerance, z);
      return 1;
    }
    std::printf("consumer: OK\n");
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: exception: %s\n", e.what());
    return 1;
  }
}
