// The immutable description of a multibody system with contact.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "vinci/sim/motion.h"
#include "vinci/sim/params.h"
#include "vinci/sim/shape.h"
#include "vinci/sim/types.h"

namespace vinci::sim {

/// How a body moves.
enum class BodyKind {
  kDynamic,     ///< integrated by the stepper
  kStatic,      ///< fixed in the world
  kPrescribed,  ///< position-controlled: follows its PrescribedMotion exactly
};

struct Material {
  std::string name;
};

/// A rigid body. Planar bodies use (x, y, θ); spatial bodies position + unit quaternion with
/// angular velocity expressed in the BODY frame (so the inertia is constant).
struct Body {
  std::string name;
  BodyKind kind = BodyKind::kDynamic;
  double mass = 1.0;  ///< kg (dynamic bodies)
  /// Rotational inertia about the centre of mass in the body frame (kg·m²). Planar bodies use
  /// (2,2). If not set by the user it is computed from the shapes (uniform density).
  Matrix3d inertia = Matrix3d::Identity();
  bool inertia_from_shapes = true;  ///< Finalize() computes `inertia` from the shapes
  std::vector<Shape> shapes;
  Isometry3d X_WB0 = Isometry3d::Identity();     ///< initial pose (planar: rotation about z)
  Vector3d v0_W = Vector3d::Zero();              ///< initial velocity of the origin, world (m/s)
  Vector3d w0_W = Vector3d::Zero();              ///< initial angular velocity, world (rad/s)
  PrescribedMotion motion;                       ///< kPrescribed only
  Vector3d applied_force_W = Vector3d::Zero();   ///< constant applied force at the COM (N)
  Vector3d applied_torque_W = Vector3d::Zero();  ///< constant applied torque (N·m)
  bool gravity = true;                           ///< false: gravity does not act on this body
};

/// Joint kinds. Planar: revolute (2 eqs), prismatic (2), weld (3).
/// Spatial: revolute (5), prismatic (5), spherical (3), fixed (6).
enum class JointType { kRevolute, kPrismatic, kWeld, kSpherical, kFixed };

/// A bilateral constraint between bodies a and b (b = −1: the world). The joint frame J is
/// given in each body frame; the constraint keeps the two copies of J coincident except along
/// the free axis: rotation about J's z (spatial revolute; planar revolute rotates about z),
/// translation along J's z (spatial prismatic) or J's x (planar prismatic).
struct Joint {
  std::string name;
  JointType type = JointType::kRevolute;
  int body_a = -1;
  int body_b = -1;
  Isometry3d X_AJ = Isometry3d::Identity();
  Isometry3d X_BJ = Isometry3d::Identity();  ///< if b = −1, X_WJ
};

/// Which discrete-time equations a step solves.
enum class FormulationType {
  kStewartTrinkle,  ///< formulations.md §1: position-level normal constraint with ψ_n/h
  kAnitescuPotra,   ///< velocity-level normal constraint (no ψ_n/h)
  kGeometricallyImplicit,  ///< formulations.md §3: contact points at ℓ+1 are unknowns of one
                           ///< mixed NCP (geometrically_implicit.h); implicit-surface shapes
};

/// Stepper options stored with the scene.
struct StepperOptions {
  FormulationType formulation = FormulationType::kStewartTrinkle;
  double dt = 1e-3;                 ///< step h (s)
  double duration = 1.0;            ///< default simulated time for `vinci simulate` (s)
  int friction_directions = 4;      ///< n_d (spatial); planar always uses ±t
  double envelope = 1e-3;           ///< ε: contacts with ψ_n ≤ ε enter the step (m)
  bool joint_stabilization = true;  ///< include ψ_b/h in the joint rows
  std::string solver = "lemke";     ///< LCP solver by name
  double max_penetration = 0.05;    ///< a step with ψ_n below −this fails (m)
};

/// Layout of one body in the generalized coordinate and velocity vectors.
struct BodyIndex {
  int q = -1;  ///< offset in q, −1 for non-dynamic bodies
  int v = -1;  ///< offset in v
};

/// Immutable scene. Build with SceneBuilder or LoadSceneFile; then Finalize() computes the
/// indices and the parameter table. Copying a Scene and applying Params gives the model a
/// step uses (ApplyParams), without rebuilding topology.
class Scene {
 public:
  Dim dim = Dim::kSpatial;
  std::string name;
  Vector3d gravity_W = Vector3d(0, 0, -9.81);  ///< m/s² (planar scenes use x, y)
  std::vector<Material> materials;             ///< index 0 is "default"
  /// Friction coefficient per unordered material pair; pairs not listed use default_mu.
  std::map<std::pair<int, int>, double> mu;
  double default_mu = 0.5;
  std::vector<Body> bodies;
  std::vector<Joint> joints;
  StepperOptions options;

  /// Computes indices, inertias from shapes where requested, and the parameter table.
  /// Throws std::invalid_argument on an inconsistent scene.
  void Finalize();

  int num_positions() const { return nq_; }
  int num_velocities() const { return nv_; }
  const BodyIndex& index(int body) const { return index_[body]; }
  const std::vector<int>& dynamic_bodies() const { return dynamic_; }
  /// −1 if absent.
  int FindBody(const std::string& name) const;
  int FindMaterial(const std::string& name) const;
  /// μ for a pair of materials.
  double Mu(int material_a, int material_b) const;

  const ParamTable& param_table() const { return params_; }
  /// The scene's own values of every parameter.
  Params DefaultParams() const { return params_.Defaults(); }
  /// A copy of this scene with `params` written into the fields they name.
  /// Throws std::invalid_argument if params has the wrong size or a value is out of range.
  Scene ApplyParams(const Params& params) const;

 private:
  int nq_ = 0, nv_ = 0;
  std::vector<BodyIndex> index_;
  std::vector<int> dynamic_;
  ParamTable params_;
};

}  // namespace vinci::sim
