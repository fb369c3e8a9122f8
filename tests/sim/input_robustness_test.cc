// Inputs that must never hang, crash or be silently misread (issue 18): each test is a
// fuzzing finding reduced to its smallest form, checked for a clean std::invalid_argument with
// file and line (bad input) or a correct result (legitimate input).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/plate/velocity_field.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/input_file.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::sim {
namespace {

using ::testing::HasSubstr;

std::string SceneError(const std::string& text) {
  try {
    ParseScene(text, "t.yaml");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no exception>";
}

std::string TempFile(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

// ----- YAML that yaml-cpp 0.7's LoadAll never finishes (issue 18, finding 1) ----------------

TEST(InputRobustnessTest, StrayCommaIsASyntaxErrorWithItsLine) {
  EXPECT_THAT(SceneError(","), HasSubstr("t.yaml:1: YAML syntax error: unexpected ','"));
  EXPECT_THAT(SceneError(",,"), HasSubstr("t.yaml:1: YAML syntax error: unexpected ','"));
  EXPECT_THAT(SceneError("# scene\n, name: x\n"),
              HasSubstr("t.yaml:2: YAML syntax error: unexpected ','"));
  EXPECT_THAT(SceneError("dimension: 3\n,\n"), HasSubstr("t.yaml:2: YAML syntax error"));
}

TEST(InputRobustnessTest, FieldSpecReaderHasTheSameGuard) {
  // LoadFieldSpec reads the file itself; give it a stray comma after the scene was parsed.
  Scene scene;
  const std::string path = TempFile("stray_comma_field.yaml", "# plate\n, field: x\n");
  try {
    LoadFieldSpec(path, scene);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(path + ":2: YAML syntax error: unexpected ','"));
  }
}

// ----- input size (issue 18, finding 10: `vinci simulate /dev/zero` read forever) -----------

std::string ReadError(const std::string& path, std::size_t max_bytes = kMaxInputFileBytes) {
  try {
    ReadInputFile(path, "scene file", max_bytes);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no exception>";
}

TEST(InputRobustnessTest, DevicesAndDirectoriesAreRejected) {
  EXPECT_THAT(ReadError("/dev/zero"), HasSubstr("/dev/zero: cannot read scene file: expected a "
                                                "regular file, got a device"));
  EXPECT_THAT(ReadError("/"), HasSubstr("/: cannot read scene file: it is a directory"));
  EXPECT_THAT(ReadError("/nonexistent/x.yaml"), HasSubstr("cannot open scene file"));
  try {
    LoadSceneFile("/dev/zero");
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("got a device"));
  }
}

TEST(InputRobustnessTest, FilesAboveTheLimitAreRejected) {
  const std::string path = TempFile("big.yaml", std::string(1000, '#'));
  EXPECT_EQ(ReadInputFile(path, "scene file", 1000).size(), 1000u);
  EXPECT_THAT(ReadError(path, 999), HasSubstr("larger than the limit of 999 bytes"));
}

// ----- rotations with overflowing or underflowing norms (finding 2) --------------------------

Eigen::Matrix3d RotationOf(const std::string& rotation) {
  const Scene scene = ParseScene(
      "dimension: 3\nbodies:\n  - name: a\n    kind: static\n"
      "    pose:\n      " +
          rotation + "\n",
      "t.yaml");
  return scene.bodies[0].X_WB0.linear();
}

TEST(InputRobustnessTest, RotationAxisScaleDoesNotMatter) {
  // The axis direction is what counts: [1, 1, 0] scaled by 1e155 (whose squared norm
  // overflows) or by 1e-200 (whose squared norm underflows) is the same rotation.
  for (const char* angle : {"3.14159", "1"}) {
    const Eigen::Matrix3d R =
        RotationOf(std::string("rotation: {axis: [1, 1, 0], angle: ") + angle + "}");
    EXPECT_TRUE((R * R.transpose()).isIdentity(1e-12));
    for (const char* axis : {"[1e155, 1e155, 0]", "[1.7e308, 1.7e308, 0]", "[1e-200, 1e-200, 0]"})
      EXPECT_TRUE(RotationOf(std::string("rotation: {axis: ") + axis + ", angle: " + angle + "}")
                      .isApprox(R, 1e-14))
          << axis << " angle " << angle;
  }
}

TEST(InputRobustnessTest, QuaternionScaleDoesNotMatter) {
  const Eigen::Matrix3d R = RotationOf("quaternion: [1, 1, 0, 0]");
  EXPECT_TRUE(
      R.isApprox(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix(), 1e-14));
  EXPECT_TRUE(RotationOf("quaternion: [1e200, 1e200, 0, 0]").isApprox(R, 1e-14));
  EXPECT_TRUE(RotationOf("quaternion: [1e-300, 1e-300, 0, 0]").isApprox(R, 1e-14));
  EXPECT_THAT(SceneError("dimension: 3\nbodies:\n  - name: a\n    kind: static\n    pose:\n"
                         "      quaternion: [0, 0, 0, 0]\n"),
              HasSubstr("t.yaml:6: bodies[0].pose.quaternion: expected a quaternion"));
}

// ----- integer overflow in `vinci field` (finding 5) -----------------------------------------

class FieldLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string path = std::string(VINCI_SOURCE_DIR) + "/examples/scenes/plate_conveyor.yaml";
    scene_ = LoadSceneFile(path);
    spec_ = LoadFieldSpec(path, scene_);
    spec_.Validate(scene_);  // the example itself is fine
  }
  std::string ValidateError(const FieldSpec& spec) const {
    try {
      spec.Validate(scene_);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "<no exception>";
  }
  Scene scene_;
  FieldSpec spec_;
};

TEST_F(FieldLimitsTest, GridPointsProductIsChecked) {
  FieldSpec s = spec_;
  s.nx = s.ny = 65536;  // nx·ny = 2^32 wrapped to 0 in int
  EXPECT_THAT(ValidateError(s), HasSubstr("field.grid.points: expected at most 1000000 points, "
                                          "got 65536 x 65536 = 4294967296"));
}

TEST_F(FieldLimitsTest, StepsPerPointAreChecked) {
  FieldSpec s = spec_;
  s.cycles = 2147483647;  // steps per cycle × cycles overflowed int
  s.average_cycles = 1;
  EXPECT_THAT(ValidateError(s), HasSubstr("field.cycles: expected at most 1000000000 steps per "
                                          "point, got 2147483647 cycles"));
  s.cycles = 100000000;
  EXPECT_THAT(ValidateError(s), HasSubstr("steps per point"));
}

// grid: {x: [-1e308, 1e308], points: 3}: the width overflows, every point was NaN (finding 3:
// NaN rows with failed = 0, exit 0; then failed rows and exit 3). Bad input, rejected by name.
TEST_F(FieldLimitsTest, GridWidthMustBeFinite) {
  FieldSpec s = spec_;
  s.x_min = -1e308;
  s.x_max = 1e308;
  EXPECT_THAT(ValidateError(s), HasSubstr("field.grid: expected a finite width"));
  const std::string path = TempFile(
      "huge_grid.yaml",
      "dimension: 3\nbodies:\n  - {name: plate, kind: prescribed, shapes: [{type: halfspace}],\n"
      "     motion: {frequency: 20, z: {harmonics: [{order: 1, amplitude: 0.001}]}}}\n"
      "  - {name: part, mass: 1, pose: {position: [0, 0, 0.1]}, shapes: [{type: sphere, radius: "
      "0.1}]}\nfield:\n  plate: plate\n  part: part\n  grid: {x: [-1e308, 1e308], points: 3}\n");
  const Scene scene = LoadSceneFile(path);
  try {
    LoadFieldSpec(path, scene);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("huge_grid.yaml:9: field.grid.x: expected a list [min, max] "
                                    "with min <= max and a finite width"));
  }
}

TEST_F(FieldLimitsTest, StepsPerCycleOutOfRangeIsAnError) {
  FieldSpec s = spec_;
  const double h = scene_.options.dt;
  s.frequency = 1.0e-7;  // T/h = 1e7/h overflowed int, giving 1 step per cycle silently
  EXPECT_THAT(ValidateError(s), HasSubstr("field.frequency: expected between 1 and 1000000000 "
                                          "time steps per plate cycle"));
  EXPECT_THROW(s.StepsPerCycle(h), std::invalid_argument);
  s.frequency = 10.0 / h;  // 0.1 steps per cycle
  EXPECT_THROW(s.StepsPerCycle(h), std::invalid_argument);
  s.frequency = 1.0 / (20.0 * h);
  EXPECT_EQ(s.StepsPerCycle(h), 20);
}

// ----- resource bounds (finding 8) ----------------------------------------------------------

std::string SpatialScene(const std::string& stepper, const std::string& bodies) {
  return "dimension: 3\n" + stepper + "bodies:\n" + bodies;
}

TEST(InputRobustnessTest, FrictionDirectionsAreBounded) {
  const std::string body = "  - {name: a, kind: static}\n";
  EXPECT_NO_THROW(ParseScene(SpatialScene("stepper: {friction_directions: 64}\n", body)));
  EXPECT_THAT(SceneError(SpatialScene("stepper: {friction_directions: 66}\n", body)),
              HasSubstr("t.yaml:2: stepper.friction_directions: expected an even integer in "
                        "[2, 64], got '66'"));
  EXPECT_THAT(SceneError(SpatialScene("stepper: {friction_directions: 20000}\n", body)),
              HasSubstr("got '20000'"));
}

TEST(InputRobustnessTest, BodyCountIsBounded) {
  std::string bodies;
  for (int i = 0; i <= SceneLimits::kMaxBodies; ++i)
    bodies += "  - {name: b" + std::to_string(i) + ", kind: static}\n";
  EXPECT_THAT(SceneError(SpatialScene("", bodies)),
              HasSubstr("t.yaml:3: bodies: expected at most 10000 bodies, got 10001 bodies"));
}

// 10,000 separated spheres: the mass matrix was dense nv × nv (60,000² doubles, bad_alloc);
// block diagonal and with a sweep-and-prune broad phase a step is O(bodies).
TEST(InputRobustnessTest, TenThousandSeparatedSpheresStep) {
  std::string bodies;
  for (int i = 0; i < SceneLimits::kMaxBodies; ++i)
    bodies += "  - {name: s" + std::to_string(i) + ", mass: 1, pose: {position: [" +
              std::to_string(3 * (i % 100)) + ", " + std::to_string(3 * (i / 100)) +
              ", 0]}, shapes: [{type: sphere, radius: 1}]}\n";
  const Scene scene = ParseScene(SpatialScene("", bodies), "t.yaml");
  Simulator sim(scene);
  State x = sim.InitialState(), next;
  Workspace ws;
  const StepInfo info = sim.Step(sim.DefaultParams(), x, StepInput{}, &ws, &next);
  ASSERT_TRUE(info.ok) << info.failure;
  EXPECT_EQ(info.contacts, 0);
  // Free fall: every sphere moved down by g h² (semi-implicit Euler), nothing else changed.
  const double h = scene.options.dt, g = -scene.gravity_W.z();
  for (int i : {0, 4321, SceneLimits::kMaxBodies - 1})
    EXPECT_NEAR(next.q[scene.index(i).q + 2], -g * h * h, 1e-12) << i;
}

// The Newton steppers stay dense in ν: more than kMaxDenseBodies bodies is rejected by name.
TEST(InputRobustnessTest, DenseFormulationsKeepTheirBodyLimit) {
  std::string bodies;
  for (int i = 0; i <= SceneLimits::kMaxDenseBodies; ++i)
    bodies += "  - {name: s" + std::to_string(i) + ", mass: 1, pose: {position: [" +
              std::to_string(3 * i) + ", 0, 0]}, shapes: [{type: sphere, radius: 1}]}\n";
  Scene scene = ParseScene(SpatialScene("stepper: {formulation: gi}\n", bodies), "t.yaml");
  try {
    Simulator sim(scene);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("formulation gi takes at most 1000 bodies"));
    EXPECT_THAT(e.what(), HasSubstr("got 1001"));
  }
}

TEST(InputRobustnessTest, VertexCountsAreBounded) {
  std::string v = "[";
  for (int i = 0; i <= SceneLimits::kMaxPolygonVertices; ++i) {
    const double a = 2.0 * M_PI * i / (SceneLimits::kMaxPolygonVertices + 1);
    v += (i ? ", [" : "[") + std::to_string(std::cos(a)) + ", " + std::to_string(std::sin(a)) + "]";
  }
  v += "]";
  for (const char* type : {"polygon", "concave_polygon"}) {
    const std::string text =
        "dimension: 2\nbodies:\n  - name: a\n    kind: static\n    shapes:\n"
        "      - type: " +
        std::string(type) + "\n        vertices: " + v + "\n";
    EXPECT_THAT(SceneError(text),
                HasSubstr("t.yaml:7: bodies[0].shapes[0].vertices: expected at most 1000 "
                          "vertices, got 1001 vertices"))
        << type;
  }
}

// The hull was an O(n⁴) search over all point triples (800 points: 73 s). 3000 points on a
// sphere (all on the hull) now take well under a second; the result is a valid hull.
TEST(InputRobustnessTest, PolyhedronHullOfManyPointsIsFastAndConvex) {
  Shape s;
  s.type = ShapeType::kPolyhedron;
  s.name = "ball";
  const int n = 3000;
  for (int i = 0; i < n; ++i) {  // Fibonacci sphere: well spread, no four coplanar
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(1.0 - z * z), phi = i * 2.399963229728653;
    s.vertices.push_back(Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z));
  }
  const auto start = std::chrono::steady_clock::now();
  PrepareShape(&s);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_LT(seconds, 5.0);  // generous for a loaded machine; the O(n⁴) search took hours here
  EXPECT_EQ(static_cast<int>(s.hull_vertices.size()), n);
  // Euler: a triangulated sphere with V vertices has 2V − 4 triangles.
  EXPECT_EQ(static_cast<int>(s.faces.size()), 2 * n - 4);
  for (const HullFace& f : s.faces) {
    EXPECT_NEAR(f.normal_S.norm(), 1.0, 1e-12);
    for (const Eigen::Vector3d& p : s.vertices) ASSERT_LE(f.normal_S.dot(p), f.offset + 1e-9);
  }
}

TEST(InputRobustnessTest, ConcavePolygonIsValidatedOnceByTheLoader) {
  const Scene scene = ParseScene(
      "dimension: 2\nbodies:\n  - name: a\n    kind: static\n    shapes:\n"
      "      - {type: concave_polygon, vertices: [[0, 0], [2, 0], [2, 2], [1, 1], [0, 2]]}\n",
      "t.yaml");
  EXPECT_TRUE(scene.bodies[0].shapes[0].polygon_checked);
}

// ----- messages (finding 10) ----------------------------------------------------------------

// A size the parameter table rejects (lower bound 1e-12) used to pass the parser and fail at
// the first step with "parameter ... = 0.000000 is outside [0.000000, inf]" and no file:line.
TEST(InputRobustnessTest, ParserAndParameterTableAgreeOnSizes) {
  const std::string head = "dimension: 3\nbodies:\n  - name: a\n    mass: ";
  const auto scene = [&](const std::string& mass, const std::string& shape) {
    return head + mass + "\n    shapes:\n      - " + shape + "\n";
  };
  const std::string m = "1e-12";
  for (const std::string& shape :
       {std::string("{type: sphere, radius: 1e-12}"),
        std::string("{type: box, half_extents: "
                    "[1e-12, 1e-12, 1e-12]}"),
        std::string("{type: cylinder, radius: 1e-12, half_length: 1e-12}"),
        std::string("{type: lens, radius: 1e-12, half_length: 1e-12}"),
        std::string("{type: ellipsoid, semi_axes: [1e-12, 1e-12, 1e-12]}"),
        std::string("{type: capsule, radius: 1e-12, half_length: 0}")}) {
    SCOPED_TRACE(shape);
    const Scene s = ParseScene(scene(m, shape), "t.yaml");
    EXPECT_NO_THROW(s.ApplyParams(s.DefaultParams()));
  }
  EXPECT_THAT(SceneError(scene("1", "{type: sphere, radius: 1e-13}")),
              HasSubstr("t.yaml:6: bodies[0].shapes[0].radius: expected a finite number >= "
                        "1e-12, got '1e-13'"));
  EXPECT_THAT(SceneError(scene("1e-13", "{type: sphere, radius: 1}")),
              HasSubstr("t.yaml:4: bodies[0].mass: expected a finite number >= 1e-12"));
  // ApplyParams itself prints numbers in %g form.
  const Scene s = ParseScene(scene("1", "{type: sphere, radius: 1}"), "t.yaml");
  Params p = s.DefaultParams();
  for (int i = 0; i < p.values.size(); ++i)
    if (s.param_table().info(i).name.find("radius") != std::string::npos) p.values[i] = 1e-13;
  try {
    s.ApplyParams(p);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr("= 1e-13 is outside [1e-12, inf]"));
  }
}

TEST(InputRobustnessTest, RawBytesAndEscapesNeverReachTheMessage) {
  // An ESC sequence in a body name (would end up in the CSV header) and in an unknown key.
  EXPECT_THAT(SceneError("dimension: 3\nbodies:\n  - name: \"a\\e[2Jb\"\n    kind: static\n"),
              HasSubstr("t.yaml:3: bodies[0].name: expected a non-empty name of printable "
                        "characters without ',' or '\"', got 'a\\x1b[2Jb'"));
  EXPECT_THAT(SceneError("dimension: 3\nbodies:\n  - name: \"a,b\"\n    kind: static\n"),
              HasSubstr("got 'a,b'"));
  const std::string msg = SceneError("dimension: 3\n\"k\\e]0;x\\a\": 1\nbodies: []\n");
  EXPECT_EQ(msg.find('\x1b'), std::string::npos) << msg;
  EXPECT_THAT(msg, HasSubstr("unknown key 'k\\x1b]0;x\\x07'"));
  // UTF-8 names are fine.
  EXPECT_NO_THROW(ParseScene("dimension: 3\nbodies:\n  - {name: Würfel, kind: static}\n"));
  EXPECT_EQ(EscapeText("a\xc3\xbc\x9b\xff"), "a\xc3\xbc\\x9b\\xff");
  EXPECT_EQ(FormatNumber(-1e308), "-1e+308");
  EXPECT_EQ(FormatNumber(1e-13), "1e-13");
}

TEST(InputRobustnessTest, EnvelopeLargerThanTheSmallestShapeIsWarnedAbout) {
  const auto scene = [](const std::string& envelope) {
    return ParseScene("dimension: 3\nstepper: {envelope: " + envelope +
                          "}\nbodies:\n  - {name: floor, kind: static, shapes: [{type: "
                          "halfspace}]}\n  - {name: box, mass: 1, shapes: [{name: b, type: box, "
                          "half_extents: [0.1, 0.1, 0.1]}]}\n",
                      "t.yaml");
  };
  EXPECT_TRUE(SceneWarnings(scene("0.001")).empty());
  const std::vector<std::string> w = SceneWarnings(scene("1"));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_THAT(w[0], HasSubstr("stepper.envelope = 1 m is larger than the smallest shape "
                              "('box.b', bounding radius 0.173205 m)"));
}

}  // namespace
}  // namespace vinci::sim
