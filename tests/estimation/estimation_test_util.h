// Synthetic logs for the estimation tests: simulate a scene with known parameters and write
// the observed bodies' poses at chosen times in the log format (vinci/estimation/log.h).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "vinci/estimation/log.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::estimation::testing {

inline std::string TempDir() {
  const std::filesystem::path d = std::filesystem::temp_directory_path() /
                                  ("vinci_estimation_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d.string();
}

inline std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// A small box (4 cm × 1 cm, 20 g) on a plate vibrating at 20 Hz, sticking and slipping twice
// per cycle; the scene says μ = 0.5 (tests/data/scenes/plate_box_planar.yaml).
inline const std::string kPlateBoxFile =
    std::string(VINCI_SOURCE_DIR) + "/tests/data/scenes/plate_box_planar.yaml";

// Largest constraint violation and complementarity violation at an MPEC's starting point.
inline void StartViolation(const MpecEstimationProblem& problem, double* constraints,
                           double* pairs) {
  const sim::VectorXd x = problem.StartingPoint();
  sim::VectorXd g;
  ASSERT_TRUE(problem.Constraints(x, &g));
  *constraints = g.cwiseAbs().maxCoeff();
  *pairs = 0.0;
  for (const auto& [a, b] : problem.ComplementarityPairs())
    *pairs = std::max(*pairs, std::abs(std::min(x[a], x[b])));
}

// A planar block (0.4 × 0.2 m, 1 kg) launched at 1.5 m/s along a floor; the scene's μ = 0.5
// (the estimator's starting value), the logs are simulated with another μ.
inline const char* kPlanarBlock =
    "dimension: 2\n"
    "gravity: [0, -9.81]\n"
    "stepper: {dt: 0.002, duration: 0.6, envelope: 0.002}\n"
    "friction: {default: 0.5}\n"
    "bodies:\n"
    "  - {name: floor, kind: static, shapes: [{type: halfplane}]}\n"
    "  - name: block\n"
    "    mass: 1.0\n"
    "    pose: {position: [0, 0.1]}\n"
    "    velocity: {linear: [1.5, 0]}\n"
    "    shapes: [{type: polygon, vertices: [[-0.2, -0.1], [0.2, -0.1], [0.2, 0.1], "
    "[-0.2, 0.1]]}]\n";

// A spatial box (0.2 × 0.2 × 0.1 m) sliding on a plane at 1.2 m/s along x.
inline const char* kSpatialBox =
    "dimension: 3\n"
    "stepper: {dt: 0.002, duration: 0.5, friction_directions: 8, envelope: 0.002}\n"
    "friction: {default: 0.5}\n"
    "bodies:\n"
    "  - {name: floor, kind: static, shapes: [{type: halfspace}]}\n"
    "  - name: box\n"
    "    mass: 1.0\n"
    "    pose: {position: [0, 0, 0.05]}\n"
    "    velocity: {linear: [1.2, 0, 0]}\n"
    "    shapes: [{type: box, half_extents: [0.1, 0.1, 0.05]}]\n";

// A 5 cm, 0.1 kg cube tossed onto a table from 12 cm, spinning (the studies' cube,
// examples/estimation/estimation_study.cc, at its scene's launch): it lands after ~0.2 s,
// bounces, tumbles and slides to rest. The scene's μ = 0.6.
inline const char* kTossedCube =
    "dimension: 3\n"
    "stepper: {dt: 0.001, duration: 1, friction_directions: 8, envelope: 0.002}\n"
    "friction: {default: 0.6}\n"
    "bodies:\n"
    "  - {name: table, kind: static, shapes: [{type: halfspace}]}\n"
    "  - name: cube\n"
    "    mass: 0.1\n"
    "    pose: {position: [0, 0, 0.12], rotation: {axis: [1, 1, 0], angle: 0.4}}\n"
    "    velocity: {linear: [0.8, 0.2, 0.5], angular: [3, -2, 5]}\n"
    "    shapes: [{type: box, half_extents: [0.025, 0.025, 0.025]}]\n";

// Simulates `sim` from its initial state with mu.default = mu for `duration` and writes the
// body's pose (planar x, y, theta; spatial x, y, z, qw..qz) at irregular times (every
// `every`-th step, with every third gap one step longer), with Gaussian position noise of
// standard deviation sigma (angles get sigma / orientation_length, 0.1 m); without
// `orientation` the log has positions only. Returns the path.
inline std::string SyntheticLog(const sim::Simulator& sim, const std::string& body, double mu,
                                double duration, int every, double sigma, unsigned seed,
                                const std::string& name, bool orientation = true) {
  sim::Params p = sim.DefaultParams();
  p.values[sim.scene().param_table().Index("mu.default")] = mu;
  const int steps = static_cast<int>(std::lround(duration / sim.scene().options.dt));
  const sim::Trajectory tr = sim.Rollout(p, sim.InitialState(), steps);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const bool planar = sim.scene().dim == sim::Dim::kPlanar;
  const int qo = sim.scene().index(sim.scene().FindBody(body)).q;
  std::string text = "# synthetic log, mu = " + std::to_string(mu) + "\n";
  text += "t," + body + ".x," + body + ".y" + (planar ? "" : "," + body + ".z");
  if (orientation)
    text += planar ? "," + body + ".theta"
                   : "," + body + ".qw," + body + ".qx," + body + ".qy," + body + ".qz";
  text += "\n";
  char buf[128];
  int gap = 0;
  for (int k = 0; k < static_cast<int>(tr.states.size());) {
    const sim::State& x = tr.states[k];
    std::snprintf(buf, sizeof buf, "%.17g", x.t);
    text += buf;
    const int np = planar ? 2 : 3;
    for (int j = 0; j < np; ++j) {
      std::snprintf(buf, sizeof buf, ",%.17g", x.q[qo + j] + sigma * n01(rng));
      text += buf;
    }
    if (!orientation) {
      // positions only
    } else if (planar) {
      std::snprintf(buf, sizeof buf, ",%.17g", x.q[qo + 2] + sigma / 0.1 * n01(rng));
      text += buf;
    } else {
      Eigen::Quaterniond q(x.q[qo + 3], x.q[qo + 4], x.q[qo + 5], x.q[qo + 6]);
      if (sigma > 0) {
        const Eigen::Vector3d d(n01(rng), n01(rng), n01(rng));
        q = Eigen::Quaterniond(Eigen::AngleAxisd(sigma / 0.1 * d.norm(), d.normalized())) * q;
      }
      std::snprintf(buf, sizeof buf, ",%.17g,%.17g,%.17g,%.17g", q.w(), q.x(), q.y(), q.z());
      text += buf;
    }
    text += "\n";
    k += every + (++gap % 3 == 0 ? 1 : 0);
  }
  return WriteFile(name, text);
}

// A particle (2 mm disc, 10 g, huge inertia: it slides without rolling) on a planar plate
// vibrating at 20 Hz (x acceleration amplitude 20 m/s², y 5 m/s² a quarter cycle ahead): the
// thesis' single-particle study (chapter 7). The scene's μ = 0.3.
inline const char* kVibratingPlate = R"(dimension: 2
gravity: [0, -9.81]
stepper: {dt: 0.001, duration: 1, envelope: 0.001, prescribed_velocity: exact}
friction: {default: 0.3}
bodies:
  - name: plate
    kind: prescribed
    shapes: [{type: halfplane}]
    motion:
      frequency: 20
      x: {harmonics: [{order: 1, amplitude: 1.2665e-3, phase: 0}]}
      y: {harmonics: [{order: 1, amplitude: 3.166e-4, phase: 1.5707963267948966}]}
  - name: p0
    mass: 0.01
    inertia: 1.0
    pose: {position: [0, 0.0023]}
    shapes: [{type: disc, radius: 0.002}]
)";

// An in-memory log of every dynamic body's position: the scene simulated with mu.default = mu
// from its initial state, sampled every `every` steps after `warmup` steps, `samples` samples,
// Gaussian noise σ.
inline Log SampledLog(const sim::Simulator& sim, double mu, int warmup, int every, int samples,
                      double sigma, unsigned seed) {
  sim::Params p = sim.DefaultParams();
  p.values[sim.scene().param_table().Index("mu.default")] = mu;
  const sim::Trajectory tr = sim.Rollout(p, sim.InitialState(), warmup + every * samples);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const sim::Scene& scene = sim.scene();
  const int np = scene.dim == sim::Dim::kPlanar ? 2 : 3;
  Episode ep;
  ep.file = "sampled_" + std::to_string(seed);
  for (int i = 0; i < samples; ++i) {
    ep.t.push_back(tr.states[warmup + i * every].t);
    ep.lines.push_back(i + 2);
  }
  for (int b = 0; b < static_cast<int>(scene.bodies.size()); ++b) {
    if (scene.bodies[b].kind != sim::BodyKind::kDynamic) continue;
    BodyTrack track;
    track.body = scene.bodies[b].name;
    track.body_index = b;
    track.dynamic = true;
    track.pose = sim::MatrixXd::Zero(samples, np == 2 ? 3 : 7);
    const int qo = scene.index(b).q;
    for (int i = 0; i < samples; ++i)
      for (int j = 0; j < np; ++j)
        track.pose(i, j) = tr.states[warmup + i * every].q[qo + j] + sigma * n01(rng);
    ep.bodies.push_back(std::move(track));
  }
  Log log;
  log.episodes.push_back(std::move(ep));
  return log;
}

// Estimates twice: as `o` says, then with the final and early polish off, so that the second
// result is a relaxed iterate. Checks that both converged, the first polished with Laplace
// standard errors, the second unpolished with its profile's (std_error_method "profile").
struct PolishedAndRelaxed {
  MpecEstimateResult polished, relaxed;
};
inline PolishedAndRelaxed EstimatePolishedAndRelaxed(const sim::Simulator& sim, const Log& log,
                                                     MpecOptions o) {
  PolishedAndRelaxed r;
  r.polished = EstimateMpec(sim, log, o);
  o.solver.polish = false;
  o.solver.early_polish_tolerance = -1.0;
  r.relaxed = EstimateMpec(sim, log, o);
  EXPECT_TRUE(r.polished.converged) << r.polished.reason;
  EXPECT_TRUE(r.relaxed.converged) << r.relaxed.reason;
  EXPECT_TRUE(r.polished.polished);
  EXPECT_FALSE(r.relaxed.polished);
  EXPECT_EQ(r.polished.std_error_method, "laplace");
  EXPECT_EQ(r.relaxed.std_error_method, "profile");
  return r;
}

}  // namespace vinci::estimation::testing
