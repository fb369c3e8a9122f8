// The design-spec loader: the spellings are accepted, bad specs rejected with
// "file:line: field: expected ..." messages.
#include "vinci/design/spec.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "vinci/design/best_scene.h"
#include "vinci/sim/model/scene_file.h"

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
      {head + params + tail + "samples: -3\n", "bad.yaml:5: samples: expected an integer >= 1"},
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

}  // namespace
}  // namespace vinci::design
