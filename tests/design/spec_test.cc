// The design-spec loader: the spellings are accepted, bad specs rejected with
// "file:line: field: expected ..." messages.
#include "vinci/design/spec.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "vinci/design/best_scene.h"
#include "vinci/design/evaluate.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

std::string Error(const std::string& text) {
  try {
    ParseDesignSpec(text, "bad.yaml", kData);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(DesignSpec, AcceptsTheDocumentedSpellings) {
  const DesignSpec s = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: mu.default, lower: 0.01, upper: 1.0}]\n"
      "uncertain: [{name: mass.block, uniform: [0.2, 0.4]},\n"
      "            {name: initial.block.x, normal: [0.0, 0.002]}]\n"
      "samples: 100\nseed: 1\nduration: 2.0\n"
      "objective: {type: success, body: block, region: {min: [0.4, 0], max: [0.6, 0.1]},\n"
      "            angle: {target: 0.0, tolerance: 0.3}, until: false}\n",
      "ok.yaml", kData);
  ASSERT_EQ(s.parameters.size(), 1u);
  EXPECT_EQ(s.parameters[0].start, 0.3);  // the scene's value
  EXPECT_EQ(s.uncertain.size(), 2u);
  EXPECT_EQ(s.samples, 100);
  EXPECT_EQ(s.objective.type, ObjectiveType::kSuccess);
  EXPECT_TRUE(s.objective.has_angle);
  const DesignSpec d = ParseDesignSpec(
      "scene: block_slide.yaml\nparameters: [{name: mu.default, lower: 0.01, upper: 1.0, "
      "start: 0.5}]\nduration: 1\nobjective: {type: distance, body: block, target: [0.5, 0.05]}\n",
      "ok.yaml", kData);
  EXPECT_EQ(d.parameters[0].start, 0.5);
  EXPECT_EQ(d.objective.target.size(), 2);
}

TEST(DesignSpec, RejectsBadSpecsWithFileLineAndField) {
  const std::string head = "scene: block_slide.yaml\n";
  const std::string params = "parameters: [{name: mu.default, lower: 0.01, upper: 1.0}]\n";
  const std::string tail =
      "duration: 1\nobjective: {type: distance, body: block, target: [0.5, 0]}\n";
  struct Case {
    std::string text, expected;
  };
  const Case cases[] = {
      {head + params + tail + "sampels: 10\n", "bad.yaml:5: sampels: expected one of the keys"},
      {head + "parameters: [{name: mu.nothing, lower: 0, upper: 1}]\n" + tail,
       "bad.yaml:2: parameters[0].name: expected a scene parameter"},
      {head + "parameters: [{name: mu.default, lower: 1, upper: 0.5}]\n" + tail,
       "bad.yaml:2: parameters[0].upper: expected a number > lower"},
      {head + "parameters: [{name: mu.default, lower: 0.1, upper: 0.5, start: 0.7}]\n" + tail,
       "bad.yaml:2: parameters[0].start: expected a number in [lower, upper]"},
      {head + params + "objective: {type: distance, body: block, target: [0.5, 0]}\n",
       "duration: expected a value (required)"},
      {head + params + tail + "uncertain: [{name: initial.block.x, uniform: [1]}]\n",
       "bad.yaml:5: uncertain[0].uniform: expected a list of 2 numbers, got a list of 1 item"},
      {head + params + tail + "uncertain: [{name: initial.floor.x, uniform: [0, 1]}]\n",
       "bad.yaml:5: uncertain[0].name: expected a scene parameter or initial.<dynamic body>"},
      {head + params + "duration: 1\nobjective: {type: distance, body: blok, target: [0.5, 0]}\n",
       "bad.yaml:4: objective.body: expected the name of a body of the scene, got 'blok'"},
      {head + params + "duration: 1\nobjective: {type: success, body: block}\n",
       "bad.yaml:4: objective: expected region: and/or angle:"},
      {head + params + tail + "samples: -3\n",
       "bad.yaml:5: samples: expected an integer in [1, 10000000]"},
      {head + params + "duration: 1\nobjective: {type: best, body: block}\n",
       "bad.yaml:4: objective.type: expected one of success, distance, margin, got 'best'"},
      {"scene: missing.yaml\n" + params + tail,
       "bad.yaml:1: scene: expected a readable scene file"},
      {head + params + tail + "uncertain: [{name: mu.default, uniform: [0, 1]}]\n",
       "uncertain[0].name: already a design parameter"},
  };
  for (const Case& c : cases) {
    const std::string e = Error(c.text);
    EXPECT_NE(e.find(c.expected), std::string::npos)
        << "got: " << e << "\nexpected: " << c.expected;
  }
}

// best.yaml: the scene with the design written in, loadable by the scene loader.
TEST(DesignSpec, BestSceneCarriesTheDesign) {
  const DesignSpec s = LoadDesignSpec(kData + "block_distance.yaml");
  const std::string text = BestSceneYaml(s, VectorXd::Constant(1, 0.123));
  const sim::Scene scene = sim::ParseScene(text, "best.yaml");
  EXPECT_EQ(scene.default_mu, 0.123);
  EXPECT_EQ(scene.options.duration, s.duration);
}

// Pose parameters (sim's pose.<body>.<d>) are written as whole poses: the floor's angle and
// position come back bit for bit through the scene loader.
TEST(DesignSpec, BestSceneCarriesPoseParameters) {
  const DesignSpec s = ParseDesignSpec(
      "scene: block_slide.yaml\n"
      "parameters: [{name: pose.floor.theta, lower: -0.5, upper: 0.5},\n"
      "             {name: pose.floor.y, lower: -0.1, upper: 0.1}]\n"
      "samples: 2\nseed: 1\nduration: 0.1\n"
      "objective: {type: distance, body: block, target: [0.5, 0.05]}\n",
      "pose.yaml", kData);
  VectorXd x(2);
  x << 0.1, -0.02;
  const sim::Scene scene = sim::ParseScene(BestSceneYaml(s, x), "best.yaml");
  sim::Params p = s.scene.DefaultParams();
  p.values[s.scene.param_table().Index("pose.floor.theta")] = 0.1;
  p.values[s.scene.param_table().Index("pose.floor.y")] = -0.02;
  const sim::Scene expected = s.scene.ApplyParams(p);
  const int floor = scene.FindBody("floor");
  EXPECT_TRUE(scene.bodies[floor].X_WB0.matrix() == expected.bodies[floor].X_WB0.matrix())
      << scene.bodies[floor].X_WB0.matrix() << "\nvs\n"
      << expected.bodies[floor].X_WB0.matrix();
}

// A shape's pose within its body is a design parameter: moving the wall of the `stops` body moves
// where the sliding block comes to rest (against the wall's face: x = wall.x − 0.05), and
// best.yaml carries the pose so that simulating it reproduces the design's rollout bit for bit.
TEST(DesignSpec, ShapePoseIsADesignParameter) {
  const DesignSpec s = ParseDesignSpec(
      "scene: block_stop.yaml\n"
      "parameters: [{name: pose.stops.wall.x, lower: 0.2, upper: 0.4}]\n"
      "samples: 1\nduration: 1.0\n"
      "objective: {type: distance, body: block, target: [0.0, 0.05]}\n",
      "shape_pose.yaml", kData);
  EXPECT_EQ(s.parameters[0].start, 0.3);  // the scene's value
  const DesignProblem problem(s);
  ThreadEvaluator evaluator(problem, 1);
  const std::vector<Evaluation> e = evaluator.Evaluate(
      {{VectorXd::Constant(1, 0.25), 1, 1}, {VectorXd::Constant(1, 0.35), 1, 1}});
  EXPECT_NEAR(e[0].objective, 0.25 - 0.05, 2e-3);
  EXPECT_NEAR(e[1].objective, 0.35 - 0.05, 2e-3);

  const VectorXd x = VectorXd::Constant(1, 0.3456789);
  const sim::Scene best = sim::ParseScene(BestSceneYaml(s, x), "best.yaml");
  const sim::Scene expected = problem.SceneFor(x);
  const int b = best.FindBody("stops");
  EXPECT_TRUE(best.bodies[b].shapes[0].X_BS.matrix() == expected.bodies[b].shapes[0].X_BS.matrix());
  // The same rollout: best.yaml with its own parameters, the spec's scene with design x.
  const sim::Simulator from_file(best), from_spec(s.scene);
  sim::Workspace w1, w2;
  sim::State a = from_file.InitialState(), c = from_spec.InitialState(), next;
  const sim::Params pa = from_file.DefaultParams(), pc = problem.ParamsFor(x);
  for (int k = 0; k < 250; ++k) {
    ASSERT_TRUE(from_file.Step(pa, a, {}, &w1, &next).ok);
    std::swap(a, next);
    ASSERT_TRUE(from_spec.Step(pc, c, {}, &w2, &next).ok);
    std::swap(c, next);
  }
  EXPECT_TRUE(a.q == c.q) << a.q.transpose() << " vs " << c.q.transpose();
  EXPECT_NEAR(a.q[0], 0.3456789 - 0.05, 2e-3);
}

// Spatial scenes: body and shape poses with z, roll, pitch, yaw; a shape pose the scene cannot
// take (it would move a dynamic body's centroid off its origin) is rejected at its bound.
TEST(DesignSpec, SpatialPosesAndRejectedShapePoses) {
  const DesignSpec s = ParseDesignSpec(
      "scene: box_floor3d.yaml\n"
      "parameters: [{name: pose.floor.z, lower: -0.01, upper: 0.01},\n"
      "             {name: pose.floor.top.roll, lower: -0.1, upper: 0.1},\n"
      "             {name: pose.floor.yaw, lower: -0.1, upper: 0.1}]\n"
      "duration: 0.05\n"
      "objective: {type: distance, body: box, target: [0, 0, 0.05]}\n",
      "spatial.yaml", kData);
  ASSERT_EQ(s.parameters.size(), 3u);
  VectorXd x(3);
  x << 0.005, 0.05, -0.02;
  const sim::Scene best = sim::ParseScene(BestSceneYaml(s, x), "best.yaml");
  const sim::Scene expected = DesignProblem(s).SceneFor(x);
  const int f = best.FindBody("floor");
  EXPECT_TRUE(best.bodies[f].X_WB0.matrix() == expected.bodies[f].X_WB0.matrix());
  EXPECT_TRUE(best.bodies[f].shapes[0].X_BS.matrix() == expected.bodies[f].shapes[0].X_BS.matrix());

  const std::string e = Error(
      "scene: block_slide.yaml\n"
      "parameters: [{name: pose.block.s0.x, lower: 0.01, upper: 0.02}]\n"
      "duration: 1\nobjective: {type: distance, body: block, target: [0.5, 0]}\n");
  EXPECT_NE(e.find("bad.yaml:2: parameters[0].lower: the scene rejects this value"),
            std::string::npos)
      << e;
  EXPECT_NE(Error("scene: block_slide.yaml\n"
                  "parameters: [{name: pose.block.x, lower: 0.01, upper: 0.02}]\n"
                  "duration: 1\nobjective: {type: distance, body: block, target: [0.5, 0]}\n")
                .find("parameters[0].name: expected a scene parameter"),
            std::string::npos);
}

}  // namespace
}  // namespace vinci::design
