// The YAML scene-file loader: valid scenes map to the expected Scene values, and every kind of
// bad input is rejected with "<file>:<line>: <field path>: expected ..., got ...".
#include "vinci/sim/model/scene_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <iomanip>
#include <sstream>
#include <stdexcept>
#include <string>

namespace vinci::sim {
namespace {

using ::testing::HasSubstr;

constexpr double kExact = 1e-15;        // values copied through without arithmetic
constexpr double kRotationTol = 1e-12;  // rotation matrices built by different formulas

const std::string kDataDir = std::string(VINCI_SOURCE_DIR) + "/tests/data/scenes/";

// Joins lines with '\n', so that line k of a test document is element k − 1.
std::string Yaml(std::initializer_list<const char*> lines) {
  std::string s;
  for (const char* l : lines) s += std::string(l) + "\n";
  return s;
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseScene(text, "t.yaml");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "<no exception>";
}

// The message names the file and line, then the field path, then what was expected/got.
void ExpectError(const std::string& text, int line, const std::string& field,
                 const std::string& detail) {
  const std::string msg = ErrorOf(text);
  EXPECT_THAT(msg, HasSubstr("t.yaml:" + std::to_string(line) + ": " + field + ": expected"));
  EXPECT_THAT(msg, HasSubstr(detail));
}
#define EXPECT_SCENE_ERROR(...) \
  do {                          \
    SCOPED_TRACE("here");       \
    ExpectError(__VA_ARGS__);   \
  } while (false)

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Num(double x) {
  std::ostringstream os;
  os << std::setprecision(17) << x;
  return os.str();
}

// ----- valid scenes ------------------------------------------------------------------------

TEST(SceneFileTest, PlanarExampleParsesIntoExpectedScene) {
  const Scene s = LoadSceneFile(kDataDir + "planar_pusher.yaml");
  EXPECT_EQ(s.name, "planar-pusher");
  EXPECT_EQ(s.dim, Dim::kPlanar);
  EXPECT_EQ(s.gravity_W, Vector3d(0, -9.81, 0));
  EXPECT_EQ(s.options.formulation, FormulationType::kAnitescuPotra);
  EXPECT_EQ(s.options.dt, 0.002);
  EXPECT_EQ(s.options.duration, 1.5);
  EXPECT_EQ(s.options.friction_directions, 4);  // not given: default
  EXPECT_EQ(s.options.envelope, 0.002);
  EXPECT_EQ(s.options.solver, "lemke");
  EXPECT_FALSE(s.options.joint_stabilization);
  EXPECT_EQ(s.options.max_penetration, 0.02);

  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.materials[0].name, "default");
  EXPECT_EQ(s.materials[1].name, "wood");
  EXPECT_EQ(s.materials[2].name, "steel");
  EXPECT_EQ(s.default_mu, 0.4);
  ASSERT_EQ(s.mu.size(), 2u);
  EXPECT_EQ(s.mu.at({1, 2}), 0.3);  // written [steel, wood]
  EXPECT_EQ(s.mu.at({0, 1}), 0.6);
  EXPECT_EQ(s.Mu(2, 2), 0.4);

  ASSERT_EQ(s.bodies.size(), 4u);
  const Body& table = s.bodies[0];
  EXPECT_EQ(table.kind, BodyKind::kStatic);
  ASSERT_EQ(table.shapes.size(), 1u);
  EXPECT_EQ(table.shapes[0].type, ShapeType::kHalfPlane);
  EXPECT_EQ(table.shapes[0].material, 2);

  const Body& box = s.bodies[1];
  EXPECT_EQ(box.kind, BodyKind::kDynamic);
  EXPECT_EQ(box.mass, 2.0);
  EXPECT_FALSE(box.inertia_from_shapes);
  EXPECT_EQ(box.inertia(2, 2), 0.0133);
  EXPECT_TRUE(box.X_WB0.isApprox(PlanarPose(0, 0.1, 0.2), kExact));
  EXPECT_EQ(box.v0_W, Vector3d(0.5, 0, 0));
  EXPECT_EQ(box.w0_W, Vector3d(0, 0, -1.0));
  EXPECT_EQ(box.applied_force_W, Vector3d(0, -1, 0));
  EXPECT_EQ(box.applied_torque_W, Vector3d(0, 0, 0.05));
  EXPECT_TRUE(box.gravity);
  ASSERT_EQ(box.shapes.size(), 1u);
  EXPECT_EQ(box.shapes[0].type, ShapeType::kPolygon);
  EXPECT_EQ(box.shapes[0].name, "hull");
  EXPECT_EQ(box.shapes[0].material, 1);
  ASSERT_EQ(box.shapes[0].vertices.size(), 4u);
  EXPECT_EQ(box.shapes[0].vertices[2], Vector3d(0.1, 0.1, 0.0));
  EXPECT_TRUE(box.motion.dofs.empty());

  const Body& pusher = s.bodies[2];
  EXPECT_EQ(pusher.kind, BodyKind::kPrescribed);
  EXPECT_TRUE(pusher.X_WB0.isApprox(PlanarPose(-0.3, 0.1, 0.0), kExact));
  EXPECT_EQ(pusher.shapes[0].type, ShapeType::kDisc);
  EXPECT_EQ(pusher.shapes[0].radius, 0.05);
  EXPECT_EQ(pusher.shapes[0].name, "s0");
  ASSERT_EQ(pusher.motion.dofs.size(), 3u);
  EXPECT_EQ(pusher.motion.dofs[0].velocity, 0.2);
  ASSERT_EQ(pusher.motion.dofs[1].harmonics.size(), 1u);
  EXPECT_EQ(pusher.motion.dofs[1].harmonics[0].amplitude, 0.001);
  EXPECT_EQ(pusher.motion.dofs[1].harmonics[0].frequency, 30.0);
  EXPECT_EQ(pusher.motion.dofs[1].harmonics[0].phase, 0.5);
  EXPECT_TRUE(pusher.motion.dofs[2].IsZero());

  const Body& link = s.bodies[3];
  EXPECT_FALSE(link.gravity);
  EXPECT_EQ(link.shapes[0].type, ShapeType::kSegment);
  EXPECT_EQ(link.shapes[0].radius, 0.01);
  EXPECT_EQ(link.shapes[0].half_length, 0.2);
  EXPECT_TRUE(link.shapes[0].X_BS.isApprox(PlanarPose(0.05, 0, 0.1), kExact));

  ASSERT_EQ(s.joints.size(), 2u);
  const Joint& hinge = s.joints[0];
  EXPECT_EQ(hinge.name, "hinge");
  EXPECT_EQ(hinge.type, JointType::kRevolute);
  EXPECT_EQ(hinge.body_a, 3);
  EXPECT_EQ(hinge.body_b, -1);
  EXPECT_TRUE(hinge.X_AJ.isApprox(PlanarPose(-0.2, 0, 0), kExact));
  // Default frame_b: frame_a's initial world pose, so the link hangs from (1, 0.3).
  EXPECT_TRUE(hinge.X_BJ.isApprox(PlanarPose(1.0, 0.3, 1.5707963267948966), kRotationTol));
  const Joint& slider = s.joints[1];
  EXPECT_EQ(slider.type, JointType::kPrismatic);
  EXPECT_EQ(slider.body_a, 1);
  EXPECT_EQ(slider.body_b, 3);
  EXPECT_TRUE(slider.X_BJ.isApprox(PlanarPose(0.1, 0, 0.5), kExact));

  // Finalize ran: dynamic bodies are indexed.
  EXPECT_EQ(s.dynamic_bodies(), (std::vector<int>{1, 3}));
  EXPECT_EQ(s.num_positions(), 6);
}

TEST(SceneFileTest, SpatialExampleParsesIntoExpectedScene) {
  const Scene s = LoadSceneFile(kDataDir + "spatial_plate.yaml");
  EXPECT_EQ(s.name, "vibrating-plate");
  EXPECT_EQ(s.dim, Dim::kSpatial);
  EXPECT_EQ(s.gravity_W, Vector3d(0, 0, -9.81));
  EXPECT_EQ(s.options.formulation, FormulationType::kStewartTrinkle);
  EXPECT_EQ(s.options.dt, 0.001);
  EXPECT_EQ(s.options.duration, 2.0);
  EXPECT_EQ(s.options.friction_directions, 8);
  EXPECT_EQ(s.options.envelope, 0.001);
  EXPECT_TRUE(s.options.joint_stabilization);
  EXPECT_EQ(s.options.max_penetration, 0.05);

  ASSERT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.materials[1].name, "steel");
  EXPECT_EQ(s.materials[2].name, "rubber");
  EXPECT_EQ(s.default_mu, 0.5);
  ASSERT_EQ(s.mu.size(), 2u);
  EXPECT_EQ(s.mu.at({1, 2}), 0.8);  // written [rubber, steel]
  EXPECT_EQ(s.mu.at({2, 2}), 1.1);

  ASSERT_EQ(s.bodies.size(), 5u);
  const Body& floor = s.bodies[0];
  EXPECT_EQ(floor.kind, BodyKind::kStatic);
  EXPECT_EQ(floor.shapes[0].type, ShapeType::kHalfSpace);
  EXPECT_EQ(floor.shapes[0].X_BS.translation(), Vector3d(0, 0, -0.5));
  EXPECT_EQ(floor.shapes[0].material, 0);

  const Body& plate = s.bodies[1];
  EXPECT_EQ(plate.kind, BodyKind::kPrescribed);
  EXPECT_EQ(plate.shapes[0].type, ShapeType::kBox);
  EXPECT_EQ(plate.shapes[0].half_extents, Vector3d(0.5, 0.5, 0.01));
  ASSERT_EQ(plate.motion.dofs.size(), 6u);
  for (int d : {0, 1, 3, 4}) EXPECT_TRUE(plate.motion.dofs[d].IsZero()) << d;
  ASSERT_EQ(plate.motion.dofs[2].harmonics.size(), 1u);
  EXPECT_EQ(plate.motion.dofs[2].harmonics[0].amplitude, 0.001);
  EXPECT_EQ(plate.motion.dofs[2].harmonics[0].frequency, 30.0);
  EXPECT_EQ(plate.motion.dofs[2].harmonics[0].phase, 0.0);
  ASSERT_EQ(plate.motion.dofs[5].keyframes.size(), 2u);
  EXPECT_EQ(plate.motion.dofs[5].keyframes[1].t, 1.0);
  EXPECT_EQ(plate.motion.dofs[5].keyframes[1].value, 0.5);

  const Body& crate = s.bodies[2];
  EXPECT_EQ(crate.mass, 1.5);
  EXPECT_EQ(crate.X_WB0.translation(), Vector3d(0.1, 0, 0.06));
  EXPECT_TRUE(crate.X_WB0.linear().isApprox(
      Eigen::AngleAxisd(0.3, Vector3d::UnitZ()).toRotationMatrix(), kRotationTol));
  EXPECT_EQ(crate.v0_W, Vector3d(0, 0.1, 0));
  EXPECT_EQ(crate.w0_W, Vector3d(0, 0, 1));
  EXPECT_FALSE(crate.inertia_from_shapes);
  EXPECT_EQ(crate.inertia, Vector3d(0.01, 0.02, 0.03).asDiagonal().toDenseMatrix());
  EXPECT_EQ(crate.applied_force_W, Vector3d(1, 0, 0));
  EXPECT_EQ(crate.applied_torque_W, Vector3d(0, 0, 0.1));
  EXPECT_EQ(crate.shapes[0].name, "shell");
  EXPECT_EQ(crate.shapes[0].material, 2);

  const Body& ball = s.bodies[3];
  EXPECT_TRUE(ball.X_WB0.linear().isApprox(Matrix3d::Identity(), kExact));  // [2,0,0,0] normalized
  EXPECT_EQ(ball.shapes[0].type, ShapeType::kSphere);
  EXPECT_EQ(ball.shapes[0].radius, 0.05);
  // No inertia given: Finalize computed it from the sphere (2/5 m r²).
  EXPECT_TRUE(ball.inertia_from_shapes);
  EXPECT_NEAR(ball.inertia(0, 0), 0.4 * 0.1 * 0.05 * 0.05, 1e-12);

  const Body& bob = s.bodies[4];
  EXPECT_FALSE(bob.gravity);
  EXPECT_EQ(bob.inertia(2, 2), 0.002);
  EXPECT_TRUE(bob.X_WB0.linear().isApprox(
      Eigen::AngleAxisd(1.5707963267948966, Vector3d::UnitZ()).toRotationMatrix(), kRotationTol));
  ASSERT_EQ(bob.shapes.size(), 2u);
  EXPECT_EQ(bob.shapes[0].type, ShapeType::kCapsule);
  EXPECT_EQ(bob.shapes[0].radius, 0.02);
  EXPECT_EQ(bob.shapes[0].half_length, 0.1);
  EXPECT_EQ(bob.shapes[1].type, ShapeType::kPolyhedron);
  EXPECT_EQ(bob.shapes[1].vertices.size(), 4u);
  EXPECT_EQ(bob.shapes[1].vertices[3], Vector3d(0, 0, 0.1));
  EXPECT_EQ(bob.shapes[1].name, "s1");

  ASSERT_EQ(s.joints.size(), 2u);
  EXPECT_EQ(s.joints[0].type, JointType::kSpherical);
  EXPECT_EQ(s.joints[0].body_a, 4);
  EXPECT_EQ(s.joints[0].body_b, -1);
  EXPECT_TRUE(s.joints[0].X_BJ.translation().isApprox(Vector3d(0, 1, 0.8), kRotationTol));
  const Joint& axle = s.joints[1];
  EXPECT_EQ(axle.type, JointType::kRevolute);
  EXPECT_EQ(axle.body_a, 3);
  EXPECT_EQ(axle.body_b, 2);
  // The default frame_b makes the joint satisfied at the initial configuration.
  EXPECT_TRUE((crate.X_WB0 * axle.X_BJ).isApprox(ball.X_WB0 * axle.X_AJ, kRotationTol));
  EXPECT_FALSE(axle.X_BJ.isApprox(Isometry3d::Identity(), 1e-3));

  EXPECT_EQ(s.dynamic_bodies(), (std::vector<int>{2, 3, 4}));
}

// The reference's complete examples are exactly the files tested above.
TEST(SceneFileTest, DocumentationExamplesAreTheTestedFiles) {
  const std::string doc = ReadText(std::string(VINCI_SOURCE_DIR) + "/docs/scene-format.md");
  ASSERT_FALSE(doc.empty());
  for (const char* file : {"planar_pusher.yaml", "spatial_plate.yaml"}) {
    const std::string text = ReadText(kDataDir + file);
    ASSERT_FALSE(text.empty()) << file;
    EXPECT_NE(doc.find("```yaml\n" + text + "```"), std::string::npos)
        << file << " is not reproduced verbatim in docs/scene-format.md";
  }
}

TEST(SceneFileTest, DefaultsOfAMinimalScene) {
  const Scene s = ParseScene(
      Yaml({"dimension: 3", "bodies:", "  - name: ball", "    mass: 2", "    inertia: [1, 1, 1]"}));
  EXPECT_EQ(s.gravity_W, Vector3d(0, 0, -9.81));
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "default");
  EXPECT_TRUE(s.mu.empty());
  EXPECT_EQ(s.options.formulation, FormulationType::kStewartTrinkle);
  EXPECT_EQ(s.bodies[0].kind, BodyKind::kDynamic);
  EXPECT_TRUE(s.bodies[0].X_WB0.isApprox(Isometry3d::Identity(), kExact));
  EXPECT_TRUE(s.joints.empty());

  const Scene p = ParseScene(Yaml({"dimension: 2", "bodies:", "  - name: wall",
                                   "    kind: prescribed", "    shapes: [{type: halfplane}]"}));
  EXPECT_EQ(p.gravity_W, Vector3d(0, -9.81, 0));
  EXPECT_TRUE(p.bodies[0].motion.dofs.empty());  // no `motion`: at rest
}

TEST(SceneFileTest, RotationSyntaxesAgree) {
  const Eigen::AngleAxisd aa(0.7, Vector3d(1, -2, 3).normalized());
  const Quaterniond q(aa);
  const Vector3d ypr = aa.toRotationMatrix().eulerAngles(2, 1, 0);  // R = Rz(y) Ry(p) Rx(r)
  const auto scene_with = [](const std::string& rotation) {
    return ParseScene(
        "dimension: 3\nbodies:\n  - name: b\n    mass: 1\n    inertia: [1, 1, 1]\n"
        "    pose: {position: [1, 2, 3], " +
        rotation + "}\n");
  };
  const Vector3d axis = 5.0 * aa.axis();  // axes need not be unit
  const Matrix3d R_aa = scene_with("rotation: {axis: [" + Num(axis.x()) + ", " + Num(axis.y()) +
                                   ", " + Num(axis.z()) + "], angle: 0.7}")
                            .bodies[0]
                            .X_WB0.linear();
  const Matrix3d R_q = scene_with("quaternion: [" + Num(3 * q.w()) + ", " + Num(3 * q.x()) + ", " +
                                  Num(3 * q.y()) + ", " + Num(3 * q.z()) + "]")
                           .bodies[0]
                           .X_WB0.linear();  // non-unit: normalized
  const Matrix3d R_rpy =
      scene_with("rpy: [" + Num(ypr[2]) + ", " + Num(ypr[1]) + ", " + Num(ypr[0]) + "]")
          .bodies[0]
          .X_WB0.linear();
  EXPECT_TRUE(R_aa.isApprox(aa.toRotationMatrix(), kRotationTol));
  EXPECT_TRUE(R_q.isApprox(aa.toRotationMatrix(), kRotationTol));
  EXPECT_TRUE(R_rpy.isApprox(aa.toRotationMatrix(), kRotationTol));
  // The rpy convention is not symmetric in its angles: swapping roll and yaw changes R.
  const Matrix3d R_swapped =
      scene_with("rpy: [" + Num(ypr[0]) + ", " + Num(ypr[1]) + ", " + Num(ypr[2]) + "]")
          .bodies[0]
          .X_WB0.linear();
  EXPECT_FALSE(R_swapped.isApprox(aa.toRotationMatrix(), 1e-3));
}

// ----- syntax, structure and types ---------------------------------------------------------

TEST(SceneFileTest, YamlSyntaxErrorReportsItsLine) {
  // Line 5 is indented by 3 spaces, between the body's keys (4) and the list item (2).
  const std::string msg = ErrorOf(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1", "   inertia: [1, 1, 1]"}));
  EXPECT_THAT(msg, HasSubstr("t.yaml:5: YAML syntax error: "));
  EXPECT_THAT(ErrorOf(Yaml({"dimension: 3", "bodies:", "  - name: a", "\tmass: 1"})),
              HasSubstr("t.yaml:4: YAML syntax error: illegal tab"));
}

TEST(SceneFileTest, EmptyDocumentIsRejected) {
  EXPECT_THAT(ErrorOf("# nothing here\n"), HasSubstr("t.yaml:1: (document): expected a scene"));
}

TEST(SceneFileTest, SeveralDocumentsAreRejected) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "---", "dimension: 3"}), 3, "(document)",
                     "a single YAML document");
}

TEST(SceneFileTest, UnknownTopLevelKeyIsNamedWithTheAllowedKeys) {
  const std::string text =
      Yaml({"dimension: 3", "gravty: [0, 0, -1]", "bodies: [{name: a, kind: static}]"});
  EXPECT_SCENE_ERROR(text, 2, "gravty", "unknown key 'gravty'");
  EXPECT_THAT(ErrorOf(text), HasSubstr("gravity"));  // the allowed keys are listed
}

TEST(SceneFileTest, UnknownKeyInANestedMapIsNamed) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "stepper:", "  dt: 0.01", "  time_step: 0.01",
                           "bodies: [{name: a, kind: static}]"}),
                     4, "stepper.time_step", "unknown key 'time_step'");
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
            "    shapes:", "      - type: sphere", "        radius: 1", "        radiuss: 2"}),
      8, "bodies[0].shapes[0].radiuss", "unknown key 'radiuss'");
}

TEST(SceneFileTest, SizeKeyOfAnotherShapeTypeIsRejected) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    shapes:", "      - type: box", "        half_extents: [1, 1, 1]",
                           "        radius: 2"}),
                     8, "bodies[0].shapes[0].radius", "{type, name, pose, material, half_extents}");
}

TEST(SceneFileTest, DuplicateKeyIsRejected) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: [1, 1, 1]", "    mass: 2"}),
                     6, "bodies[0].mass", "'mass' again (first on line 4)");
}

TEST(SceneFileTest, StringWhereNumberExpected) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: heavy", "    inertia: [1, 1, 1]"}),
      4, "bodies[0].mass", "got 'heavy'");
}

TEST(SceneFileTest, QuotedNumberIsAString) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: \"2\"", "    inertia: [1, 1, 1]"}),
      4, "bodies[0].mass", "(a quoted string)");
}

TEST(SceneFileTest, KeyWithoutValueReportsTheKeyLine) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass:", "    inertia: [1, 1, 1]"}), 4,
      "bodies[0].mass", "got null");
}

TEST(SceneFileTest, MapWhereListExpected) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "gravity: {z: -9.81}", "bodies: [{name: a, kind: static}]"}), 2,
      "gravity", "expected a list of 3 numbers, got a map");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  name: a"}), 3, "bodies",
                     "a non-empty list of bodies, got a map");
}

TEST(SceneFileTest, WrongVectorLength) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "gravity: [0, -9.81]", "bodies: [{name: a, kind: static}]"}), 2,
      "gravity", "expected a list of 3 numbers, got a list of 2 items");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: 1", "    velocity: {linear: [1, 2, 3]}"}),
                     6, "bodies[0].velocity.linear", "a list of 2 numbers");
}

TEST(SceneFileTest, PlanarTorqueIsAScalar) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: 1", "    torque: [0, 0, 1]"}),
                     6, "bodies[0].torque", "expected a finite number, got a list of 3 items");
}

TEST(SceneFileTest, WrongBoolean) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "stepper:", "  joint_stabilization: 1",
                           "bodies: [{name: a, kind: static}]"}),
                     3, "stepper.joint_stabilization", "expected true or false, got '1'");
}

TEST(SceneFileTest, NonFiniteNumbers) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: .nan", "    inertia: [1, 1, 1]"}),
      4, "bodies[0].mass", "got '.nan'");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    pose:", "      position: [0, .inf, 0]"}),
                     6, "bodies[0].pose.position[1]", "expected a finite number, got '.inf'");
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "stepper: {dt: -.inf}", "bodies: [{name: a, kind: static}]"}), 2,
      "stepper.dt", "got '-.inf'");
}

// ----- numeric ranges ----------------------------------------------------------------------

TEST(SceneFileTest, NegativeOrZeroMass) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: -1", "    inertia: [1, 1, 1]"}), 4,
      "bodies[0].mass", "expected a finite number >= 1e-12, got '-1'");
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    inertia: [1, 1, 1]", "    mass: 0"}), 5,
      "bodies[0].mass", "got '0'");
}

TEST(SceneFileTest, NegativeShapeSizes) {
  const auto body = [](const char* shape) {
    return Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1",
                 "    shapes:", "      - type: box", "        half_extents: [1, 1, 1]", shape});
  };
  EXPECT_SCENE_ERROR(body("      - {type: sphere, radius: -0.1}"), 8, "bodies[0].shapes[1].radius",
                     "got '-0.1'");
  EXPECT_SCENE_ERROR(body("      - {type: box, half_extents: [1, -2, 1]}"), 8,
                     "bodies[0].shapes[1].half_extents[1]", ">= 1e-12, got '-2'");
  EXPECT_SCENE_ERROR(body("      - {type: capsule, radius: 1, half_length: -1}"), 8,
                     "bodies[0].shapes[1].half_length", ">= 0, got '-1'");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    mass: 1",
                           "    shapes: [{type: segment, radius: -1, half_length: 1}]"}),
                     5, "bodies[0].shapes[0].radius", ">= 0, got '-1'");
}

TEST(SceneFileTest, NonPositiveStepperValues) {
  const auto stepper = [](const char* line) {
    return Yaml({"dimension: 3", "stepper:", line, "bodies: [{name: a, kind: static}]"});
  };
  EXPECT_SCENE_ERROR(stepper("  dt: 0"), 3, "stepper.dt", "> 0, got '0'");
  EXPECT_SCENE_ERROR(stepper("  duration: -2"), 3, "stepper.duration", "> 0, got '-2'");
  EXPECT_SCENE_ERROR(stepper("  max_penetration: 0"), 3, "stepper.max_penetration", "> 0");
  EXPECT_SCENE_ERROR(stepper("  envelope: -0.001"), 3, "stepper.envelope", ">= 0, got '-0.001'");
}

TEST(SceneFileTest, BadFrictionDirections) {
  const auto stepper = [](const char* line) {
    return Yaml({"dimension: 3", "stepper:", line, "bodies: [{name: a, kind: static}]"});
  };
  EXPECT_SCENE_ERROR(stepper("  friction_directions: 7"), 3, "stepper.friction_directions",
                     "an even integer in [2, 64], got '7'");
  EXPECT_SCENE_ERROR(stepper("  friction_directions: 0"), 3, "stepper.friction_directions",
                     "got '0'");
  EXPECT_SCENE_ERROR(stepper("  friction_directions: 4.5"), 3, "stepper.friction_directions",
                     "got '4.5'");
}

TEST(SceneFileTest, NegativeFriction) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "friction:", "  default: -0.1", "bodies: [{name: a, kind: static}]"}),
      3, "friction.default", ">= 0, got '-0.1'");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "materials: [ice]", "friction:", "  pairs:",
                           "    - [ice, ice, -1]", "bodies: [{name: a, kind: static}]"}),
                     5, "friction.pairs[0][2]", ">= 0, got '-1'");
}

TEST(SceneFileTest, BadInertia) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1", "    inertia: [1, 0, 1]"}), 5,
      "bodies[0].inertia[1]", "> 0, got '0'");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: [[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]"}),
                     5, "bodies[0].inertia", "symmetric");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: [[1, 2, 0], [2, 1, 0], [0, 0, 1]]"}),
                     5, "bodies[0].inertia", "positive definite");
}

// ----- enumerations ------------------------------------------------------------------------

TEST(SceneFileTest, BadDimension) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 4", "bodies: [{name: a, kind: static}]"}), 1, "dimension",
                     "expected 2 or 3, got '4'");
}

TEST(SceneFileTest, UnknownFormulation) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "stepper: {formulation: moreau}", "bodies: [{name: a, kind: static}]"}),
      2, "stepper.formulation", "expected a formulation (stewart-trinkle, anitescu-potra");
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "stepper: {formulation: moreau}", "bodies: [{name: a, kind: static}]"}),
      2, "stepper.formulation", "got 'moreau'");
}

TEST(SceneFileTest, UnknownSolver) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "stepper:", "  solver: magic", "bodies: [{name: a, kind: static}]"}), 3,
      "stepper.solver", "got 'magic'");
}

TEST(SceneFileTest, UnknownBodyKind) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: kinematic"}), 4,
                     "bodies[0].kind", "(dynamic, static, prescribed), got 'kinematic'");
}

TEST(SceneFileTest, UnknownShapeType) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    shapes:", "      - type: cone"}),
                     6, "bodies[0].shapes[0].type", "got 'cone'");
}

TEST(SceneFileTest, ShapeTypeOfTheOtherDimension) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    kind: static",
                           "    shapes:", "      - type: box", "        half_extents: [1, 1, 1]"}),
                     6, "bodies[0].shapes[0].type", "'box' (a spatial shape)");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    shapes: [{type: disc, radius: 1}]"}),
                     5, "bodies[0].shapes[0].type", "'disc' (a planar shape)");
}

TEST(SceneFileTest, UnknownJointType) {
  const auto joint = [](const char* type) {
    return Yaml({"dimension: 3", "bodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]",
                 "joints:", "  - name: j", "    body_a: a", type});
  };
  EXPECT_SCENE_ERROR(joint("    type: hinge"), 6, "joints[0].type", "got 'hinge'");
  // weld is planar; the spatial name is `fixed`.
  EXPECT_SCENE_ERROR(joint("    type: weld"), 6, "joints[0].type",
                     "a spatial joint type (revolute, prismatic, spherical, fixed), got 'weld'");
}

// ----- consistency -------------------------------------------------------------------------

TEST(SceneFileTest, HalfSpaceOnDynamicBody) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: [1, 1, 1]", "    shapes:", "      - type: halfspace"}),
                     7, "bodies[0].shapes[0].type", "a bounded shape on a dynamic body");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    mass: 1",
                           "    inertia: 1", "    shapes: [{type: halfplane}]"}),
                     6, "bodies[0].shapes[0].type", "got 'halfplane'");
}

std::string PolygonScene(const char* vertices) {
  return Yaml({"dimension: 2", "bodies:", "  - name: a", "    kind: static",
               "    shapes:", "      - type: polygon", vertices});
}

TEST(SceneFileTest, NonConvexPolygon) {
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[0, 0], [2, 0], [2, 2], [1, 0.5], [0, 2]]"),
                     7, "bodies[0].shapes[0].vertices", "got a non-convex polygon");
}

TEST(SceneFileTest, ClockwisePolygon) {
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[0, 0], [0, 1], [1, 1], [1, 0]]"), 7,
                     "bodies[0].shapes[0].vertices",
                     "expected counter-clockwise vertices, got clockwise vertices");
}

TEST(SceneFileTest, SelfIntersectingPolygon) {
  // A pentagram turns left at every vertex but winds twice.
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[1, 0], [-0.809, 0.588], [0.309, -0.951], "
                                  "[0.309, 0.951], [-0.809, -0.588]]"),
                     7, "bodies[0].shapes[0].vertices", "self-intersecting");
}

TEST(SceneFileTest, DegeneratePolygon) {
  const std::string text =
      Yaml({"dimension: 2", "bodies:", "  - name: a", "    kind: static",
            "    shapes:", "      - type: polygon", "        vertices:", "          - [0, 0]",
            "          - [1, 0]", "          - [1, 0]", "          - [0, 1]"});
  EXPECT_SCENE_ERROR(text, 10, "bodies[0].shapes[0].vertices[2]", "a repeat of vertex 1");
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[0, 0], [1, 0], [2, 0], [1, 1]]"), 7,
                     "bodies[0].shapes[0].vertices[1]", "a straight corner at vertex 1");
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[0, 0], [1, 0]]"), 7,
                     "bodies[0].shapes[0].vertices", "at least 3 points of 2 numbers");
  EXPECT_SCENE_ERROR(PolygonScene("        vertices: [[0, 0], [1, 0], [0, 1, 0]]"), 7,
                     "bodies[0].shapes[0].vertices[2]", "a list of 2 numbers");
}

TEST(SceneFileTest, FlatPolyhedron) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    shapes:", "      - type: polyhedron",
                           "        vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]"}),
                     7, "bodies[0].shapes[0].vertices", "coplanar vertices");
}

TEST(SceneFileTest, DuplicateBodyName) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "  - kind: static", "    name: a"}),
                     6, "bodies[1].name", "'a' again (first on line 3)");
}

TEST(SceneFileTest, BodyNamedWorld) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: world", "    kind: static"}), 3,
                     "bodies[0].name", "other than 'world'");
}

TEST(SceneFileTest, DuplicateJointName) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 2",
            "bodies: [{name: a, mass: 1, inertia: 1}, {name: b, mass: 1, inertia: 1}]",
            "joints:", "  - {name: j, body_a: a}", "  - {name: j, body_a: b}"}),
      5, "joints[1].name", "'j' again (first on line 4)");
}

TEST(SceneFileTest, DuplicateMaterialName) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "materials:", "  - steel", "  - wood", "  - steel",
                           "bodies: [{name: a, kind: static}]"}),
                     5, "materials[2]", "'steel' again (first on line 3)");
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "materials: [default]", "bodies: [{name: a, kind: static}]"}), 2,
      "materials[0]", "predefined");
}

TEST(SceneFileTest, DuplicateFrictionPairInEitherOrder) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "materials: [steel, wood]",
                           "friction:", "  pairs:", "    - [steel, wood, 0.3]",
                           "    - [wood, steel, 0.4]", "bodies: [{name: a, kind: static}]"}),
                     6, "friction.pairs[1]", "again (first on line 5)");
}

TEST(SceneFileTest, DanglingBodyNameInJoint) {
  const auto joint = [](const char* a, const char* b) {
    return Yaml({"dimension: 3", "bodies: [{name: a, mass: 1, inertia: [1, 1, 1]}]",
                 "joints:", "  - name: j", a, b});
  };
  EXPECT_SCENE_ERROR(joint("    body_a: ghost", "    body_b: world"), 5, "joints[0].body_a",
                     "got 'ghost'");
  EXPECT_SCENE_ERROR(joint("    body_a: a", "    body_b: ghost"), 6, "joints[0].body_b",
                     "a body name or 'world' (a), got 'ghost'");
  EXPECT_SCENE_ERROR(joint("    body_a: world", "    body_b: a"), 5, "joints[0].body_a",
                     "got 'world'");
  EXPECT_SCENE_ERROR(joint("    body_a: a", "    body_b: a"), 6, "joints[0].body_b",
                     "a body other than body_a");
}

TEST(SceneFileTest, DanglingMaterialName) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "materials: [steel]", "bodies:", "  - name: a", "    kind: static",
            "    shapes:", "      - {type: halfspace, material: stel}"}),
      7, "bodies[0].shapes[0].material", "(default, steel), got 'stel'");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "materials: [steel]", "friction:",
                           "  pairs: [[steel, ice, 0.1]]", "bodies: [{name: a, kind: static}]"}),
                     4, "friction.pairs[0][1]", "got 'ice'");
}

TEST(SceneFileTest, MotionOnANonPrescribedBody) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    motion:", "      z: {velocity: 1}"}),
                     6, "bodies[0].motion", "no motion on a static body");
}

TEST(SceneFileTest, DynamicOnlyKeyOnAStaticBody) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static", "    mass: 3"}), 5,
      "bodies[0].mass", "no 'mass' on a static body");
}

TEST(SceneFileTest, UnknownDofName) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: prescribed",
                           "    motion:", "      theta: {velocity: 1}"}),
                     6, "bodies[0].motion.theta",
                     "{x, y, z, roll, pitch, yaw, frequency, tilt, pose}");
}

TEST(SceneFileTest, KeyframesNotStrictlyIncreasing) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    kind: prescribed",
                           "    motion:", "      x:", "        keyframes:", "          - [0, 0]",
                           "          - [1, 0.5]", "          - [1, 0.7]"}),
                     10, "bodies[0].motion.x.keyframes[2]", "strictly increasing");
}

TEST(SceneFileTest, KeyframesCombinedWithVelocity) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 2", "bodies:", "  - name: a", "    kind: prescribed",
                           "    motion:", "      y:", "        velocity: 1",
                           "        keyframes: [[0, 0], [1, 1]]"}),
                     8, "bodies[0].motion.y.keyframes", "together with 'velocity'");
}

TEST(SceneFileTest, ZeroRotationAxisAndZeroQuaternion) {
  const auto pose = [](const char* rotation) {
    return Yaml(
        {"dimension: 3", "bodies:", "  - name: a", "    kind: static", "    pose:", rotation});
  };
  EXPECT_SCENE_ERROR(pose("      rotation: {axis: [0, 0, 0], angle: 1}"), 6,
                     "bodies[0].pose.rotation.axis", "non-zero length");
  EXPECT_SCENE_ERROR(pose("      quaternion: [0, 0, 0, 0]"), 6, "bodies[0].pose.quaternion",
                     "non-zero norm");
}

TEST(SceneFileTest, TwoRotationKeys) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static",
                           "    pose:", "      rpy: [0, 0, 1]", "      quaternion: [1, 0, 0, 0]"}),
                     6, "bodies[0].pose.rpy", "at most one of rotation, quaternion, rpy");
}

// ----- missing required keys ---------------------------------------------------------------

TEST(SceneFileTest, MissingDimension) {
  EXPECT_SCENE_ERROR(Yaml({"name: x", "bodies: [{name: a, kind: static}]"}), 1, "dimension",
                     "got nothing (missing key)");
}

TEST(SceneFileTest, MissingOrEmptyBodies) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3"}), 1, "bodies", "got nothing");
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies: []"}), 2, "bodies",
                     "a non-empty list of bodies, got a list of 0 items");
}

TEST(SceneFileTest, MissingBodyName) {
  EXPECT_SCENE_ERROR(
      Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static", "  - kind: static"}), 5,
      "bodies[1].name", "got nothing");
}

TEST(SceneFileTest, MissingMassOfADynamicBody) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    inertia: [1, 1, 1]"}), 3,
                     "bodies[0].mass", "got nothing");
}

TEST(SceneFileTest, MissingInertiaWithoutShapes) {
  EXPECT_SCENE_ERROR(Yaml({"dimension: 3", "bodies:", "  - name: a", "    mass: 1"}), 3,
                     "bodies[0].inertia", "no shapes to compute it from");
}

TEST(SceneFileTest, MissingShapeTypeAndSizes) {
  const auto shape = [](const char* s) {
    return Yaml({"dimension: 3", "bodies:", "  - name: a", "    kind: static", "    shapes:", s});
  };
  EXPECT_SCENE_ERROR(shape("      - {radius: 1}"), 6, "bodies[0].shapes[0].type", "got nothing");
  EXPECT_SCENE_ERROR(shape("      - {type: sphere}"), 6, "bodies[0].shapes[0].radius",
                     "got nothing");
  EXPECT_SCENE_ERROR(shape("      - {type: box}"), 6, "bodies[0].shapes[0].half_extents",
                     "got nothing");
  EXPECT_SCENE_ERROR(shape("      - {type: capsule, radius: 1}"), 6,
                     "bodies[0].shapes[0].half_length", "got nothing");
  EXPECT_SCENE_ERROR(shape("      - {type: polyhedron}"), 6, "bodies[0].shapes[0].vertices",
                     "got nothing");
}

// ----- files -------------------------------------------------------------------------------

TEST(SceneFileTest, LoadSceneFileOnAMissingPath) {
  const std::string path = kDataDir + "does_not_exist.yaml";
  try {
    LoadSceneFile(path);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot open scene file");
  }
}

TEST(SceneFileTest, LoadSceneFileNamesTheFileInErrors) {
  const std::string path = ::testing::TempDir() + "scene_file_test_bad_mass.yaml";
  {
    std::ofstream out(path);
    out << "dimension: 2\nbodies:\n  - name: a\n    mass: -3\n    inertia: 1\n";
  }
  try {
    LoadSceneFile(path);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(path + ":4: bodies[0].mass: expected"));
  }
  std::remove(path.c_str());
}

}  // namespace
}  // namespace vinci::sim
