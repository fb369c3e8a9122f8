#include "vinci/sim/formulations/capabilities.h"

#include <stdexcept>
#include <string>

#include "vinci/sim/model/scene_file.h"

namespace vinci::sim {

FormulationCapabilities CapabilitiesOf(FormulationType type) {
  FormulationCapabilities c;  // the Stewart–Trinkle set
  switch (type) {
    case FormulationType::kStewartTrinkle:
    case FormulationType::kAnitescuPotra:
      break;
    case FormulationType::kFirstOrder:
      c.first_order_damping = true;
      break;
    case FormulationType::kNcp:
      // The MCP has only the contact rows (ncp.h): no support disks, no corner unknowns.
      c.support_friction = false;
      c.corner_contacts = false;
      break;
    case FormulationType::kQuasistaticDlc:
    case FormulationType::kQuasistaticDqc:
    case FormulationType::kDynamicDqc:
      // quasistatic.h: planar, rigid normal rows ψ_n/h, no corner unknowns.
      c.spatial = false;
      c.corner_contacts = false;
      c.compliance = false;
      break;
    case FormulationType::kGeometricallyImplicit:
      // geometrically_implicit.h: implicit-surface pairs, exact poses and secant velocities of
      // prescribed bodies, no joint or support rows.
      c.joints = false;
      c.support_friction = false;
      c.corner_contacts = false;
      c.smooth_shapes = true;
      c.non_implicit_shapes = false;
      c.integrated_pose = false;
      c.exact_prescribed_velocity = false;
      break;
  }
  return c;
}

const char* FormulationKeyword(FormulationType type) {
  switch (type) {
    case FormulationType::kStewartTrinkle:
      return "stewart-trinkle";
    case FormulationType::kAnitescuPotra:
      return "anitescu-potra";
    case FormulationType::kNcp:
      return "ncp";
    case FormulationType::kFirstOrder:
      return "first-order";
    case FormulationType::kQuasistaticDlc:
      return "quasistatic-dlc";
    case FormulationType::kQuasistaticDqc:
      return "quasistatic-dqc";
    case FormulationType::kDynamicDqc:
      return "dynamic-dqc";
    case FormulationType::kGeometricallyImplicit:
      return "gi";
  }
  throw std::logic_error("FormulationKeyword: unknown FormulationType");
}

const std::vector<FormulationType>& AllFormulationTypes() {
  static const std::vector<FormulationType> all = {FormulationType::kStewartTrinkle,
                                                   FormulationType::kAnitescuPotra,
                                                   FormulationType::kNcp,
                                                   FormulationType::kFirstOrder,
                                                   FormulationType::kQuasistaticDlc,
                                                   FormulationType::kQuasistaticDqc,
                                                   FormulationType::kDynamicDqc,
                                                   FormulationType::kGeometricallyImplicit};
  return all;
}

namespace {

std::string BodyShape(const Body& b, const Shape& s) {
  return "body '" + b.name + "' shape '" + s.name + "'";
}

bool IsNonImplicit(ShapeType t) {
  return t == ShapeType::kCapsule || t == ShapeType::kSegment || t == ShapeType::kConcavePolygon;
}

}  // namespace

std::vector<SceneFeatureUse> SceneFeatureUses(const Scene& scene) {
  std::vector<SceneFeatureUse> uses;
  const auto add = [&](const std::string& feature, const std::string& where,
                       bool (*supported)(const FormulationCapabilities&)) {
    for (const SceneFeatureUse& u : uses)
      if (u.feature == feature) return;
    uses.push_back({feature, where, supported});
  };
  if (scene.dim == Dim::kPlanar)
    add("planar scenes", "dim: planar", [](const FormulationCapabilities& c) { return c.planar; });
  else
    add("spatial scenes", "dim: spatial",
        [](const FormulationCapabilities& c) { return c.spatial; });
  if (!scene.joints.empty())
    add("joints", "joint '" + scene.joints[0].name + "'",
        [](const FormulationCapabilities& c) { return c.joints; });
  bool any_prescribed = false;
  for (const Body& b : scene.bodies) {
    any_prescribed = any_prescribed || b.kind == BodyKind::kPrescribed;
    if (b.kind == BodyKind::kDynamic && !b.support.empty())
      add("2.5D support friction", "body '" + b.name + "': support",
          [](const FormulationCapabilities& c) { return c.support_friction; });
    if (b.kind == BodyKind::kDynamic && b.damping.size() > 0)
      add("first-order damping", "body '" + b.name + "': damping",
          [](const FormulationCapabilities& c) { return c.first_order_damping; });
    if (!b.compliance.rigid())
      add("compliant contact", "body '" + b.name + "': compliance",
          [](const FormulationCapabilities& c) { return c.compliance; });
    if (b.kind == BodyKind::kPrescribed && b.motion.pose == PoseRule::kIntegrated)
      add("pose: integrated", "body '" + b.name + "': motion pose",
          [](const FormulationCapabilities& c) { return c.integrated_pose; });
    for (const Shape& s : b.shapes) {
      if (s.type == ShapeType::kConcavePolygon && scene.options.nonconvex_corners)
        add("corner contacts of concave polygons", BodyShape(b, s),
            [](const FormulationCapabilities& c) { return c.corner_contacts; });
      if (RequiresImplicitContact(s.type))
        add(std::string("smooth shapes (") + ShapeKeyword(s.type) + ")", BodyShape(b, s),
            [](const FormulationCapabilities& c) { return c.smooth_shapes; });
      if (IsNonImplicit(s.type))
        add(std::string("shapes without an implicit form (") + ShapeKeyword(s.type) + ")",
            BodyShape(b, s),
            [](const FormulationCapabilities& c) { return c.non_implicit_shapes; });
    }
  }
  if (any_prescribed && scene.options.prescribed_velocity == PrescribedVelocity::kExact)
    add("prescribed_velocity: exact", "stepper option prescribed_velocity",
        [](const FormulationCapabilities& c) { return c.exact_prescribed_velocity; });
  return uses;
}

void CheckSceneSupported(const Scene& scene, FormulationType type,
                         const FormulationCapabilities& caps) {
  std::string message;
  for (const SceneFeatureUse& use : SceneFeatureUses(scene)) {
    if (use.supported(caps)) continue;
    std::string others;
    for (FormulationType t : AllFormulationTypes())
      if (use.supported(CapabilitiesOf(t)))
        others += std::string(others.empty() ? "" : ", ") + FormulationKeyword(t);
    message += std::string(message.empty() ? "" : "; ") + "formulation " +
               FormulationKeyword(type) + " does not support " + use.feature + " (" + use.where +
               "); formulations that do: " + (others.empty() ? "none" : others);
  }
  // Steppers whose Newton systems are dense in ν (SceneLimits::kMaxDenseBodies).
  const bool dense =
      type == FormulationType::kGeometricallyImplicit || type == FormulationType::kQuasistaticDlc ||
      type == FormulationType::kQuasistaticDqc || type == FormulationType::kDynamicDqc;
  const int bodies = static_cast<int>(scene.bodies.size());
  if (dense && bodies > SceneLimits::kMaxDenseBodies)
    message += std::string(message.empty() ? "" : "; ") + "formulation " +
               FormulationKeyword(type) + " takes at most " +
               std::to_string(SceneLimits::kMaxDenseBodies) + " bodies (its Newton system is " +
               "dense in the velocities), got " + std::to_string(bodies) +
               "; the LCP formulations take up to " + std::to_string(SceneLimits::kMaxBodies);
  if (!message.empty())
    throw std::invalid_argument((scene.name.empty() ? "scene: " : "scene '" + scene.name + "': ") +
                                message);
}

}  // namespace vinci::sim
