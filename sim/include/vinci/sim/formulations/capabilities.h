// What each formulation can honour of a scene, and the check that rejects a scene a formulation
// would otherwise silently simplify (a dropped support friction, corner row or pose rule).
#pragma once

#include <string>
#include <vector>

#include "vinci/sim/model/scene.h"

namespace vinci::sim {

/// The scene features a formulation implements. A scene that uses a feature its formulation
/// lacks is rejected by CheckSceneSupported (the Simulator constructor calls it), never run with
/// the feature ignored.
struct FormulationCapabilities {
  bool planar = true;   ///< Dim::kPlanar scenes
  bool spatial = true;  ///< Dim::kSpatial scenes
  bool joints = true;   ///< bilateral joints (Scene::joints)
  /// 2.5D friction between planar bodies and the plane of motion (Body::support).
  bool support_friction = true;
  /// Corner contacts of concave polygons (StepperOptions::nonconvex_corners, formulations.md §7).
  bool corner_contacts = true;
  bool compliance = true;  ///< compliant normal laws (Body::compliance not rigid)
  /// Smooth shapes that only implicit-surface contact can collide (RequiresImplicitContact:
  /// ellipsoid, superquadric, cylinder, lens, ellipse, superellipse).
  bool smooth_shapes = false;
  /// Shapes with no implicit form (capsule, segment, concave polygon), which the implicit-surface
  /// contact of the geometrically implicit stepper cannot represent.
  bool non_implicit_shapes = true;
  bool integrated_pose = true;            ///< PoseRule::kIntegrated of prescribed bodies
  bool exact_prescribed_velocity = true;  ///< PrescribedVelocity::kExact with prescribed bodies
  /// Body::damping (the first-order model's C); the other formulations have inertia instead.
  bool first_order_damping = false;
};

/// The capabilities of each formulation type (the single table the formulations return from
/// Formulation::capabilities()).
FormulationCapabilities CapabilitiesOf(FormulationType type);

/// The scene-file keyword of a formulation ("stewart-trinkle", "ncp", "gi", ...).
const char* FormulationKeyword(FormulationType type);

/// Every formulation type, in scene-file order.
const std::vector<FormulationType>& AllFormulationTypes();

/// One use of a feature in a scene: `feature` names the capability (as in the messages), `where`
/// the body/shape/joint/option that uses it.
struct SceneFeatureUse {
  std::string feature;
  std::string where;
  bool (*supported)(const FormulationCapabilities&) = nullptr;
};

/// Every feature use in `scene` (first use per feature), whatever the formulation.
std::vector<SceneFeatureUse> SceneFeatureUses(const Scene& scene);

/// Throws std::invalid_argument if `scene` uses a feature that `caps` (formulation `type`) lacks:
/// "formulation ncp does not support 2.5D support friction (body 'slider': support); formulations
/// that do: stewart-trinkle, ...". Lists every unsupported feature.
void CheckSceneSupported(const Scene& scene, FormulationType type,
                         const FormulationCapabilities& caps);

}  // namespace vinci::sim
