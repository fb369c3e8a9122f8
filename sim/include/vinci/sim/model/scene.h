// The immutable description of a multibody system with contact.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "vinci/sim/geometry/shape.h"
#include "vinci/sim/model/compliance.h"
#include "vinci/sim/model/motion.h"
#include "vinci/sim/model/params.h"
#include "vinci/sim/solvers/solver_options.h"
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

/// Friction between a planar body and the plane of motion (the 2.5D model, docs/formulations.md §6;
/// sim/include/vinci/sim/model/support.h). Support point k at s_k (body frame) carries the normal
/// force N_k ≥ 0 and a friction disk of radius μ_s N_k. An empty `points_B` means no support
/// friction.
struct Support {
  std::vector<Vector3d> points_B;  ///< s_k in the body frame (m; z is ignored)
  /// N_k (N), one per point, when `static_distribution` is false.
  std::vector<double> normal_forces;
  /// true: N_k = f_k m g cos(tilt) with the static load fractions f_k computed by Finalize()
  /// (ComputeSupportFractions in support.h), so a mass parameter scales them.
  bool static_distribution = false;
  std::vector<double> load_fractions;  ///< f_k (Σ f_k = 1), filled by Finalize() when static
  double mu = 0.0;                     ///< μ_s ≥ 0
  int directions = 8;                  ///< n_d ≥ 3 of the linearized disk (LCP steppers)
  bool empty() const { return points_B.empty(); }
};

/// The plane of motion of a planar scene seen as a (possibly tilted) table, for the 2.5D model.
/// The plane is tilted by `tilt` about the world x axis with downhill along −y: a body's support
/// load is m g cos(tilt) and its in-plane gravity g sin(tilt) along −y (the scene file sets
/// Scene::gravity_W = (0, −g sin(tilt)) from these; a SceneBuilder user sets it likewise).
struct SupportPlane {
  double g = 9.81;    ///< magnitude of gravity (m/s²)
  double tilt = 0.0;  ///< angle between the plane of motion and the horizontal (rad), [0, π/2]
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
  /// Normal compliance of the body's surface layer (compliance.h); default rigid.
  ContactCompliance compliance;
  /// First-order model only (FormulationType::kFirstOrder): the damping matrix C of the body,
  /// symmetric positive definite, size of the body's ν (planar 3×3 on (vx, vy, ω): N·s/m on the
  /// translational, N·m·s/rad on the rotational entries; spatial 6×6 on (v_W, ω_B)). Empty
  /// otherwise.
  MatrixXd damping;
  Support support;  ///< friction against the plane of motion (planar dynamic bodies only)
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
  kStewartTrinkle,  ///< docs/formulations.md §1: position-level normal constraint with ψ_n/h
  kAnitescuPotra,   ///< velocity-level normal constraint (no ψ_n/h)
  kNcp,             ///< docs/formulations.md §2: quadratic friction cone, an MCP (ncp.h)
  kFirstOrder,  ///< docs/formulations.md §8: damping-dominated, C ν = (G_n p_n + G_f p_f)/h + F
  kQuasistaticDlc,  ///< §5 Model-DLC: quasistatic, linearized cones (quasistatic.h)
  kQuasistaticDqc,  ///< §5 Model-DQC: quasistatic, quadratic support-friction disks (an NCP)
  kDynamicDqc,  ///< §1 dynamics with exact (quadratic) §6 support disks, an NCP (quasistatic.h)
  kGeometricallyImplicit,  ///< docs/formulations.md §3: contact points at ℓ+1 are unknowns of one
                           ///< mixed NCP (geometrically_implicit.h); implicit-surface shapes
};

/// Which velocity of a prescribed body enters ∂ψ/∂t over a step [t, t + h].
enum class PrescribedVelocity {
  kSecant,  ///< (pose(t + h) − pose(t))/h: follows a translating body's displacement exactly
  kExact,   ///< the prescription's exact velocity at t + h (the end of the step, like ν_ℓ+1)
};

/// Stepper options stored with the scene: its file's `stepper:` section. A Simulator runs with
/// SimulatorOptions (simulator/options.h), which default to these.
struct StepperOptions {
  FormulationType formulation = FormulationType::kStewartTrinkle;
  double dt = 1e-3;                 ///< step h (s)
  double duration = 1.0;            ///< default simulated time for `vinci simulate` (s)
  int friction_directions = 4;      ///< n_d (spatial); planar always uses ±t
  double envelope = 1e-3;           ///< ε: contacts with ψ_n ≤ ε enter the step (m)
  bool joint_stabilization = true;  ///< include ψ_b/h in the joint rows
  std::string solver = "lemke";     ///< LCP solver by name
  /// Typed options of the solvers (the named LCP solver's entry, and `mcp` for the NCP
  /// formulations); not in the scene file: set them through SimulatorOptions (options.h).
  SolverOptions solver_options;
  double max_penetration = 0.05;  ///< a step with ψ_n below −this fails (m)
  PrescribedVelocity prescribed_velocity = PrescribedVelocity::kSecant;  ///< in ∂ψ/∂t
  /// docs/formulations.md §7: a vertex at a convex corner of a concave polygon is one corner
  /// contact (free iff max(ψ_1, ψ_2) ≥ 0). false: two per-edge contacts (ψ_1 ≥ 0 and ψ_2 ≥ 0),
  /// which snag on the extended edge lines; kept to demonstrate the difference.
  bool nonconvex_corners = true;
};

/// The complementarity solvers a formulation accepts by name (StepperOptions::solver): the LCP
/// solvers (LcpSolverNames) for the LCP formulations, which NCP and the quasistatic steppers also
/// use for their start; "semismooth-newton" (and the default "lemke", unused) for GI.
std::vector<std::string> SolverNames(FormulationType formulation);

/// The scene-file names of the formulations (`stepper.formulation`, `vinci simulate
/// --formulation`), one entry per FormulationType: stewart-trinkle, anitescu-potra, ncp,
/// first-order, quasistatic-dlc, quasistatic-dqc, dynamic-dqc, gi. The one table that the scene
/// loader, ParseFormulation and the CLI read.
const std::vector<std::pair<std::string, FormulationType>>& FormulationTable();
/// The names of FormulationTable(), in its order.
std::vector<std::string> FormulationNames();
/// The scene-file name of a formulation.
std::string_view ToString(FormulationType formulation);
/// The formulation named `name`. Throws std::invalid_argument naming the accepted names.
FormulationType ParseFormulation(const std::string& name);
/// The components of a pose as pose parameters see them (params.h): planar (x, y, θ, 0, 0, 0),
/// spatial (x, y, z, roll, pitch, yaw) with R = Rz(yaw) Ry(pitch) Rx(roll), pitch in
/// [−π/2, π/2].
Eigen::Matrix<double, 6, 1> PoseComponents(Dim dim, const Isometry3d& X);
/// The pose with these components, built as the scene file builds `position` + `angle`
/// (planar) or `position` + `rpy` (spatial), bit for bit.
Isometry3d PoseFromComponents(Dim dim, const Eigen::Matrix<double, 6, 1>& components);

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
  SupportPlane plane;  ///< the table under a planar scene (2.5D support friction)

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
  /// The value of a parameter of the table in this scene (for a scene returned by ApplyParams,
  /// the applied value; `scale` is relative to this scene's vertices, so always 1).
  double ParamValue(const ParamInfo& info) const;
  /// A copy of this scene with `params` written into the fields they name, and what Finalize
  /// derives from them recomputed the way Finalize computes it: the inertia of a dynamic body
  /// whose inertia comes from its shapes (inertia_from_shapes) after a size, shape-pose, scale or
  /// mass change (a given inertia is scaled with the mass), a polyhedron's hull after a scale.
  /// So the result equals, bit for bit, the scene loaded from a file with those values written
  /// in it (a pose's rotation as `angle` / `rpy`; scaled vertices). Entries equal to this scene's
  /// values change nothing (an unchanged rotation keeps its bits). Support load fractions
  /// depend only on the support points and need no update; joint frames are body-fixed, so a
  /// pose parameter moves a body's joint frames with it. Cost: one scene copy plus the
  /// recomputation for changed bodies (Simulator::Resolve caches the result per workspace).
  /// Throws std::invalid_argument if params has the wrong size, a value is out of range, or the
  /// changed scene is invalid (e.g. a shape pose that moves a body's centroid off its origin, a
  /// tilt without a frequency).
  Scene ApplyParams(const Params& params) const;

 private:
  void BuildParamTable();
  const Isometry3d& PoseOf(const ParamInfo& info) const;  // kPose: X_WB0 or X_BS

  int nq_ = 0, nv_ = 0;
  std::vector<BodyIndex> index_;
  std::vector<int> dynamic_;
  ParamTable params_;
};

}  // namespace vinci::sim
