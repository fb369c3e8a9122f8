// Formulation capabilities (capabilities.h): a scene that uses a feature its formulation does not
// implement is rejected by the Simulator with the feature, where it is used and who supports it.
#include "vinci/sim/formulations/capabilities.h"

#include <gtest/gtest.h>

#include <string>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/simulator/simulator.h"

namespace vinci::sim {
namespace {

// A square slider resting on a plane tilted by 0.3 rad through four support points, μ_s = 0.5.
// tan(0.3) = 0.309 < 0.5, so support friction holds it.
std::string TiltedSlider(const std::string& formulation) {
  return R"(
dimension: 2
plane: {tilt: 0.3, g: 9.81}
stepper: {dt: 0.01, formulation: )" +
         formulation + R"(}
bodies:
  - name: slider
    mass: 1.0
    shapes: [{type: polygon, vertices: [[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]]}]
    support:
      points: [[-0.05, -0.05], [0.05, -0.05], [0.05, 0.05], [-0.05, 0.05]]
      normal_forces: static
      mu: 0.5
)";
}

void ExpectRejected(const std::string& yaml, const std::vector<std::string>& needles) {
  try {
    const Simulator sim(ParseScene(yaml));
    ADD_FAILURE() << "accepted; expected a rejection mentioning " << needles[0];
  } catch (const std::invalid_argument& e) {
    for (const std::string& n : needles)
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << e.what() << "\nlacks: " << n;
  }
}

TEST(Capabilities, SupportFrictionHoldsTheSliderWhereSupported) {
  for (const char* f :
       {"stewart-trinkle", "anitescu-potra", "quasistatic-dlc", "quasistatic-dqc", "dynamic-dqc"}) {
    const Simulator sim(ParseScene(TiltedSlider(f)));
    const Trajectory traj = sim.Rollout(sim.DefaultParams(), sim.InitialState(), 50);
    ASSERT_TRUE(traj.ok) << f << ": " << traj.failure;
    // Sliding would move it 0.5 g (sin θ − μ cos θ) t² ≠ 0; sticking keeps it within round-off.
    EXPECT_NEAR(traj.states.back().q[1], 0.0, 1e-9) << f;
  }
}

TEST(Capabilities, NcpAndGiRejectSupportFriction) {
  for (const char* f : {"ncp", "gi"})
    ExpectRejected(TiltedSlider(f), {std::string("formulation ") + f, "2.5D support friction",
                                     "body 'slider'", "stewart-trinkle", "dynamic-dqc"});
}

std::string ConcaveFloor(const std::string& formulation, bool corners) {
  return R"(
dimension: 2
stepper: {formulation: )" +
         formulation + ", nonconvex_corners: " + (corners ? "true" : "false") + R"(}
bodies:
  - name: floor
    kind: static
    shapes:
      - name: trench
        type: concave_polygon
        vertices: [[-5, -1], [5, -1], [5, 0], [0.5, 0], [0.5, -0.3], [-0.5, -0.3], [-0.5, 0], [-5, 0]]
  - name: block
    mass: 1.0
    pose: {position: [-1, 0.1]}
    shapes: [{type: polygon, vertices: [[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]]}]
)";
}

TEST(Capabilities, CornerContactsOfConcavePolygons) {
  ExpectRejected(ConcaveFloor("ncp", true),
                 {"corner contacts", "body 'floor' shape 'trench'", "stewart-trinkle"});
  ExpectRejected(ConcaveFloor("quasistatic-dlc", true), {"corner contacts"});
  // Per-edge contacts (no corner rows) are ordinary contacts: NCP accepts them.
  EXPECT_NO_THROW(Simulator(ParseScene(ConcaveFloor("ncp", false))));
  EXPECT_NO_THROW(Simulator(ParseScene(ConcaveFloor("stewart-trinkle", true))));
  ExpectRejected(ConcaveFloor("gi", false), {"without an implicit form"});
}

std::string MovingFloor(const std::string& formulation, const std::string& pose,
                        const std::string& rule) {
  return R"(
dimension: 2
stepper: {formulation: )" +
         formulation + ", prescribed_velocity: " + rule + R"(}
bodies:
  - name: floor
    kind: prescribed
    shapes: [{type: halfplane}]
    motion: {pose: )" +
         pose + R"(, x: {harmonics: [{amplitude: 0.01, frequency: 2.0, phase: 0}]}}
  - name: disc
    mass: 1.0
    pose: {position: [0, 0.1]}
    shapes: [{type: disc, radius: 0.1}]
)";
}

TEST(Capabilities, GiRejectsIntegratedPoseAndExactPrescribedVelocity) {
  ExpectRejected(MovingFloor("gi", "integrated", "secant"),
                 {"pose: integrated", "body 'floor'", "stewart-trinkle"});
  ExpectRejected(MovingFloor("gi", "exact", "exact"), {"prescribed_velocity: exact"});
  EXPECT_NO_THROW(Simulator(ParseScene(MovingFloor("gi", "exact", "secant"))));
  EXPECT_NO_THROW(Simulator(ParseScene(MovingFloor("ncp", "integrated", "exact"))));
}

TEST(Capabilities, QuasistaticRejectsComplianceAndSpatialScenes) {
  ExpectRejected(R"(
dimension: 2
stepper: {formulation: quasistatic-dlc}
bodies:
  - name: floor
    kind: static
    shapes: [{type: halfplane}]
    compliance: {law: kelvin-voigt, stiffness: 1.0e4, damping: 0}
  - name: disc
    mass: 1.0
    pose: {position: [0, 0.1]}
    shapes: [{type: disc, radius: 0.1}]
)",
                 {"compliant contact", "body 'floor'", "stewart-trinkle", "gi"});
  // (Scene::Finalize refuses this pairing before the capability check.)
  Scene spatial = ParseScene(R"(
dimension: 3
bodies:
  - name: ball
    mass: 1.0
    shapes: [{type: sphere, radius: 0.1}]
)");
  spatial.options.formulation = FormulationType::kDynamicDqc;
  try {
    const Simulator sim(spatial);
    ADD_FAILURE() << "a spatial scene was accepted by dynamic-dqc";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("planar"), std::string::npos) << e.what();
  }
}

TEST(Capabilities, DampingOnlyUnderFirstOrder) {
  ExpectRejected(R"(
dimension: 2
bodies:
  - name: block
    mass: 1.0
    damping: [2.0, 2.0, 0.5]
    shapes: [{type: disc, radius: 0.1}]
)",
                 {"first-order damping", "body 'block'", "first-order"});
}

TEST(Capabilities, GiRejectsJoints) {
  ExpectRejected(R"(
dimension: 2
stepper: {formulation: gi}
bodies:
  - name: link
    mass: 1.0
    shapes: [{type: disc, radius: 0.1}]
joints:
  - {name: pin, type: revolute, body_a: link, body_b: world}
)",
                 {"joints", "joint 'pin'"});
}

TEST(Capabilities, SmoothShapesOnlyUnderGi) {
  ExpectRejected(R"(
dimension: 3
bodies:
  - name: egg
    mass: 1.0
    shapes: [{type: ellipsoid, semi_axes: [0.1, 0.1, 0.2]}]
)",
                 {"smooth shapes (ellipsoid)", "body 'egg'", "formulations that do: gi"});
}

// Every built formulation reports the table's entry for its type.
TEST(Capabilities, FormulationsReportTheirTableEntry) {
  for (FormulationType t : AllFormulationTypes()) {
    StepperOptions o;
    o.formulation = t;
    const FormulationCapabilities c = MakeFormulation(o)->capabilities(), e = CapabilitiesOf(t);
    EXPECT_EQ(c.support_friction, e.support_friction) << FormulationKeyword(t);
    EXPECT_EQ(c.corner_contacts, e.corner_contacts) << FormulationKeyword(t);
    EXPECT_EQ(c.integrated_pose, e.integrated_pose) << FormulationKeyword(t);
    EXPECT_EQ(c.spatial, e.spatial) << FormulationKeyword(t);
  }
}

}  // namespace
}  // namespace vinci::sim
