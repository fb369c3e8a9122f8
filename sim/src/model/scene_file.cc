// The YAML scene-file loader (format: docs/scene-format.md).
//
// Every value is read through a `Field` that knows its path in the document (`bodies[1].mass`)
// and the 1-based line to report, so each rejection names the file, the line, the field, what
// was expected and what was found. Nothing is silently corrected: unknown keys, duplicate keys,
// keys that do not apply (a mass on a static body) and keys given without a value are errors.
#include "vinci/sim/model/scene_file.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "vinci/sim/solvers/input_file.h"
#include "vinci/sim/solvers/text_format.h"
#include "yaml_load.h"

namespace vinci::sim {
namespace {

// Relative tolerance for "strictly convex" (cross products of polygon edges) and for the
// volume spanned by polyhedron vertices, scaled by the shape's size.
constexpr double kRelativeDegeneracy = 1e-12;
// Relative tolerance on the symmetry of a full 3x3 inertia.
constexpr double kInertiaSymmetryTol = 1e-9;

const std::vector<std::string> kTopKeys = {"name",      "dimension", "gravity", "stepper",
                                           "materials", "friction",  "bodies",  "joints",
                                           "field",     "plane"};
// 2.5D model (support.h): the table under a planar scene and a body's support points.
const std::vector<std::string> kPlaneKeys = {"tilt", "g"};
const std::vector<std::string> kSupportKeys = {"points", "normal_forces", "mu", "directions"};
const std::vector<std::string> kStepperKeys = {"formulation",
                                               "dt",
                                               "duration",
                                               "friction_directions",
                                               "envelope",
                                               "solver",
                                               "joint_stabilization",
                                               "max_penetration",
                                               "prescribed_velocity",
                                               "nonconvex_corners"};
const std::vector<std::string> kFrictionKeys = {"default", "pairs"};
const std::vector<std::string> kBodyKeys = {
    "name",  "kind",   "pose",   "velocity", "mass",       "inertia", "gravity",
    "force", "torque", "shapes", "motion",   "compliance", "damping", "support"};
const std::vector<std::string> kComplianceKeys = {"law", "stiffness", "damping", "alpha",
                                                  "min_overlap"};
const std::vector<std::string> kPlanarPoseKeys = {"position", "angle"};
const std::vector<std::string> kSpatialPoseKeys = {"position", "rotation", "quaternion", "rpy"};
const std::vector<std::string> kAxisAngleKeys = {"axis", "angle"};
const std::vector<std::string> kVelocityKeys = {"linear", "angular"};
const std::vector<std::string> kDofMotionKeys = {"velocity", "harmonics", "keyframes"};
const std::vector<std::string> kHarmonicKeys = {"amplitude", "frequency", "phase", "order"};
// Motion-level keys besides the dof names.
const std::vector<std::string> kMotionExtraKeys = {"frequency", "tilt", "pose"};
const std::vector<std::string> kTiltKeys = {"amplitude", "frequency", "phase", "depth", "axis"};
const std::vector<std::string> kJointKeys = {"name",   "type",    "body_a",
                                             "body_b", "frame_a", "frame_b"};
const std::vector<std::string> kPlanarDofs = {"x", "y", "theta"};
const std::vector<std::string> kSpatialDofs = {"x", "y", "z", "roll", "pitch", "yaw"};
// Keys that only make sense on a dynamic body.
const std::vector<std::string> kDynamicOnlyKeys = {"mass",  "inertia", "velocity", "gravity",
                                                   "force", "torque",  "damping",  "support"};

std::string Join(const std::vector<std::string>& items) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + items[i];
  return s;
}

std::string Truncated(const std::string& s) {
  constexpr std::size_t kMax = 40;
  return s.size() <= kMax ? s : s.substr(0, kMax) + "...";
}

// v / ‖v‖ without overflow or underflow in the norm: v is first divided by max |v_i|, so any
// finite v ≠ 0 gives a unit vector, and v and c·v (c > 0) give the same one. nullopt for v = 0.
template <typename V>
std::optional<V> UnitDirection(const V& v) {
  const double scale = v.cwiseAbs().maxCoeff();
  if (!(scale > 0.0) || !std::isfinite(scale)) return std::nullopt;
  const V u = v / scale;
  return V(u / u.norm());
}

// What a node is, for the "got ..." half of a message.
std::string Describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null:
      return "null (a key without a value)";
    case YAML::NodeType::Scalar:
      return "'" + Truncated(n.Scalar()) + "'";
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(n.size()) + (n.size() == 1 ? " item" : " items");
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Undefined:
      break;
  }
  return "nothing";
}

// A plain scalar or one explicitly tagged with one of `tags`; quoted scalars are strings.
bool IsPlainOrTagged(const YAML::Node& n, std::initializer_list<const char*> tags) {
  if (n.Tag() == "?") return true;
  for (const char* t : tags)
    if (n.Tag() == t) return true;
  return false;
}

const char* KindName(BodyKind k) {
  switch (k) {
    case BodyKind::kDynamic:
      return "dynamic";
    case BodyKind::kStatic:
      return "static";
    case BodyKind::kPrescribed:
      return "prescribed";
  }
  return "?";
}

struct ShapeSpec {
  const char* name;
  ShapeType type;
  Dim dim;
  std::vector<std::string> size_keys;
};

const std::vector<ShapeSpec>& ShapeSpecs() {
  static const std::vector<ShapeSpec> specs = {
      {"halfspace", ShapeType::kHalfSpace, Dim::kSpatial, {}},
      {"sphere", ShapeType::kSphere, Dim::kSpatial, {"radius"}},
      {"box", ShapeType::kBox, Dim::kSpatial, {"half_extents"}},
      {"capsule", ShapeType::kCapsule, Dim::kSpatial, {"radius", "half_length"}},
      {"polyhedron", ShapeType::kPolyhedron, Dim::kSpatial, {"vertices"}},
      {"halfplane", ShapeType::kHalfPlane, Dim::kPlanar, {}},
      {"disc", ShapeType::kDisc, Dim::kPlanar, {"radius"}},
      {"polygon", ShapeType::kPolygon, Dim::kPlanar, {"vertices"}},
      {"segment", ShapeType::kSegment, Dim::kPlanar, {"radius", "half_length"}},
      {"concave_polygon", ShapeType::kConcavePolygon, Dim::kPlanar, {"vertices"}},
      {"ellipsoid", ShapeType::kEllipsoid, Dim::kSpatial, {"semi_axes"}},
      {"superquadric", ShapeType::kSuperquadric, Dim::kSpatial, {"semi_axes", "exponent"}},
      {"cylinder", ShapeType::kCylinder, Dim::kSpatial, {"radius", "half_length"}},
      {"lens", ShapeType::kLens, Dim::kSpatial, {"radius", "half_length"}},
      {"ellipse", ShapeType::kEllipse, Dim::kPlanar, {"semi_axes"}},
      {"superellipse", ShapeType::kSuperellipse, Dim::kPlanar, {"semi_axes", "exponent"}},
  };
  return specs;
}

std::vector<std::string> ShapeNames(Dim dim, bool bounded_only) {
  std::vector<std::string> names;
  for (const ShapeSpec& s : ShapeSpecs())
    if (s.dim == dim && !(bounded_only && s.size_keys.empty())) names.push_back(s.name);
  return names;
}

// One value in the document: the node, its path and the line to report (1-based).
struct Field {
  YAML::Node node;
  std::string path;
  int line = 1;
};

int LineOf(const YAML::Node& n, int fallback) {
  const YAML::Mark m = n.Mark();
  return m.is_null() ? fallback : m.line + 1;
}

class Parser {
 public:
  explicit Parser(std::string source) : src_(std::move(source)) {}

  Scene Parse(const YAML::Node& root);

 private:
  // ----- errors -------------------------------------------------------------------------------
  [[noreturn]] void Fail(const Field& f, const std::string& expected,
                         const std::string& got) const {
    // Escaped: names, keys and values quoted from the file must not carry raw bytes or terminal
    // escape sequences to the user's terminal.
    throw std::invalid_argument(EscapeText(src_ + ":" + std::to_string(f.line) + ": " +
                                           (f.path.empty() ? "(document)" : f.path) +
                                           ": expected " + expected + ", got " + got));
  }
  [[noreturn]] void Fail(const Field& f, const std::string& expected) const {
    Fail(f, expected, Describe(f.node));
  }

  // ----- structure ----------------------------------------------------------------------------
  // Checks that f is a map whose keys are unique scalars from `allowed`.
  void CheckMap(const Field& f, const std::vector<std::string>& allowed,
                const std::string& what) const {
    if (!f.node.IsMap()) Fail(f, what + " with keys {" + Join(allowed) + "}");
    std::map<std::string, int> seen;
    for (const auto& kv : f.node) {  // kv is a value: yaml-cpp's it->first would dangle
      const YAML::Node key = kv.first;
      const Field kf{key, f.path, LineOf(key, f.line)};
      if (!key.IsScalar()) Fail(kf, "a plain key (one of " + Join(allowed) + ")");
      const std::string k = key.Scalar();
      const Field named{key, Child(f.path, k), kf.line};
      bool known = false;
      for (const std::string& a : allowed) known = known || a == k;
      if (!known) Fail(named, "one of the keys {" + Join(allowed) + "}", "unknown key '" + k + "'");
      const auto [prev, inserted] = seen.emplace(k, kf.line);
      if (!inserted)
        Fail(named, "each key once",
             "'" + k + "' again (first on line " + std::to_string(prev->second) + ")");
    }
  }

  static std::string Child(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }

  // The value of `key` in the (checked) map f, if present.
  std::optional<Field> Get(const Field& f, const std::string& key) const {
    for (const auto& kv : f.node) {
      if (kv.first.Scalar() != key) continue;
      const int key_line = LineOf(kv.first, f.line);
      // A null value is marked where the next token starts; report the key's line instead.
      const int line = kv.second.IsNull() ? key_line : LineOf(kv.second, key_line);
      return Field{kv.second, Child(f.path, key), line};
    }
    return std::nullopt;
  }

  Field Require(const Field& f, const std::string& key, const std::string& expected) const {
    std::optional<Field> v = Get(f, key);
    if (!v) Fail(Field{f.node, Child(f.path, key), f.line}, expected, "nothing (missing key)");
    return *v;
  }

  // The items of a list.
  std::vector<Field> Items(const Field& f, const std::string& expected) const {
    if (!f.node.IsSequence()) Fail(f, expected);
    std::vector<Field> items;
    for (std::size_t i = 0; i < f.node.size(); ++i) {
      const YAML::Node item = f.node[i];
      items.push_back(Field{item, f.path + "[" + std::to_string(i) + "]",
                            item.IsNull() ? f.line : LineOf(item, f.line)});
    }
    return items;
  }

  // ----- scalars ------------------------------------------------------------------------------
  // kSize: a length or mass the parameter table bounds below by SceneLimits::kMinSize
  // (Scene::Finalize), so that every accepted value also passes Scene::ApplyParams.
  enum class Bound { kAny, kPositive, kNonNegative, kSize };

  double Number(const Field& f, Bound bound = Bound::kAny) const {
    static const std::string kSizeWhat =
        "a finite number >= " + FormatNumber(SceneLimits::kMinSize);
    const std::string what = bound == Bound::kPositive      ? "a finite number > 0"
                             : bound == Bound::kNonNegative ? "a finite number >= 0"
                             : bound == Bound::kSize        ? kSizeWhat
                                                            : "a finite number";
    if (!f.node.IsScalar()) Fail(f, what);
    if (!IsPlainOrTagged(f.node, {"tag:yaml.org,2002:float", "tag:yaml.org,2002:int"}))
      Fail(f, what, Describe(f.node) + " (a quoted string)");
    double x = 0.0;
    if (!YAML::convert<double>::decode(f.node, x) || !std::isfinite(x)) Fail(f, what);
    if ((bound == Bound::kPositive && !(x > 0.0)) || (bound == Bound::kNonNegative && x < 0.0) ||
        (bound == Bound::kSize && !(x >= SceneLimits::kMinSize)))
      Fail(f, what);
    return x;
  }

  long long Integer(const Field& f, const std::string& what) const {
    if (!f.node.IsScalar() || !IsPlainOrTagged(f.node, {"tag:yaml.org,2002:int"})) Fail(f, what);
    long long x = 0;
    if (!YAML::convert<long long>::decode(f.node, x)) Fail(f, what);
    return x;
  }

  bool Bool(const Field& f) const {
    static const std::set<std::string> kTrue = {"true", "True", "TRUE"};
    static const std::set<std::string> kFalse = {"false", "False", "FALSE"};
    if (f.node.IsScalar() && IsPlainOrTagged(f.node, {"tag:yaml.org,2002:bool"})) {
      if (kTrue.count(f.node.Scalar())) return true;
      if (kFalse.count(f.node.Scalar())) return false;
    }
    Fail(f, "true or false");
  }

  std::string String(const Field& f, const std::string& what = "a string") const {
    if (!f.node.IsScalar()) Fail(f, what);
    return f.node.Scalar();
  }

  // Names end up in CSV headers and messages: printable text (UTF-8 allowed) without ',' or '"'.
  std::string Name(const Field& f) const {
    const std::string what = "a non-empty name of printable characters without ',' or '\"'";
    const std::string s = String(f, what);
    if (!IsPrintableName(s)) Fail(f, what);
    return s;
  }

  // One of `choices` (by name).
  template <typename T>
  T Choice(const Field& f, const std::vector<std::pair<std::string, T>>& choices,
           const std::string& what) const {
    std::vector<std::string> names;
    for (const auto& c : choices) names.push_back(c.first);
    const std::string expected = what + " (" + Join(names) + ")";
    const std::string s = String(f, expected);
    for (const auto& c : choices)
      if (c.first == s) return c.second;
    Fail(f, expected);
  }

  // A list of exactly n finite numbers.
  VectorXd Numbers(const Field& f, int n, Bound bound = Bound::kAny) const {
    const std::string what = "a list of " + std::to_string(n) + " numbers";
    const std::vector<Field> items = Items(f, what);
    if (static_cast<int>(items.size()) != n) Fail(f, what);
    VectorXd v(n);
    for (int i = 0; i < n; ++i) v[i] = Number(items[i], bound);
    return v;
  }

  // Planar: 2 numbers into (x, y, 0); spatial: 3 numbers.
  Vector3d Vector(const Field& f) const {
    const VectorXd v = Numbers(f, planar() ? 2 : 3);
    return planar() ? Vector3d(v[0], v[1], 0.0) : Vector3d(v[0], v[1], v[2]);
  }

  // Planar: a scalar about z; spatial: 3 numbers.
  Vector3d AngularVector(const Field& f) const {
    return planar() ? Vector3d(0.0, 0.0, Number(f)) : Vector3d(Numbers(f, 3));
  }

  // ----- composite values ---------------------------------------------------------------------
  Isometry3d Pose(const Field& f) const;
  Matrix3d Inertia(const Field& f) const;
  MatrixXd Damping(const Field& f) const;
  Shape ParseShape(const Field& f, BodyKind kind) const;
  void CheckPolygon(const Field& vertices_field, const std::vector<Field>& items,
                    const std::vector<Vector3d>& v) const;
  void CheckPolyhedron(const Field& vertices_field, const std::vector<Vector3d>& v) const;
  void CheckVertexCount(const Field& vertices_field, std::size_t n, int limit) const {
    if (n > static_cast<std::size_t>(limit))
      Fail(vertices_field, "at most " + std::to_string(limit) + " vertices",
           std::to_string(n) + " vertices");
  }
  PrescribedMotion Motion(const Field& f) const;
  DofMotion ParseDofMotion(const Field& f, std::optional<double> base_frequency) const;
  Body ParseBody(const Field& f) const;
  ContactCompliance ParseCompliance(const Field& f) const;
  Support ParseSupport(const Field& f) const;
  Joint ParseJoint(const Field& f, const Scene& scene) const;
  void ParseStepper(const Field& f, StepperOptions* options) const;
  void ParseFriction(const Field& f, Scene* scene) const;

  int MaterialIndex(const Field& f) const {
    const std::string name = Name(f);
    const auto it = material_index_.find(name);
    if (it == material_index_.end())
      Fail(f, "a material listed in 'materials' (" + Join(material_names_) + ")");
    return it->second;
  }

  bool planar() const { return dim_ == Dim::kPlanar; }

  std::string src_;
  Dim dim_ = Dim::kSpatial;
  std::vector<std::string> material_names_;
  std::map<std::string, int> material_index_;
};

Isometry3d Parser::Pose(const Field& f) const {
  Isometry3d X = Isometry3d::Identity();
  if (planar()) {
    CheckMap(f, kPlanarPoseKeys, "a planar pose: a map");
    Vector3d p = Vector3d::Zero();
    double angle = 0.0;
    if (auto pos = Get(f, "position")) p = Vector(*pos);
    if (auto a = Get(f, "angle")) angle = Number(*a);
    return PlanarPose(p.x(), p.y(), angle);
  }
  CheckMap(f, kSpatialPoseKeys, "a spatial pose: a map");
  if (auto pos = Get(f, "position")) X.translation() = Vector(*pos);
  std::optional<Field> first_rotation;
  for (const char* key : {"rotation", "quaternion", "rpy"}) {
    std::optional<Field> r = Get(f, key);
    if (!r) continue;
    if (first_rotation)
      Fail(*r, "at most one of rotation, quaternion, rpy",
           "'" + std::string(key) + "' after '" +
               first_rotation->path.substr(first_rotation->path.rfind('.') + 1) + "'");
    first_rotation = r;
    const std::string k = key;
    if (k == "rotation") {
      CheckMap(*r, kAxisAngleKeys, "an axis-angle rotation: a map");
      const Field axis_field = Require(*r, "axis", "a list of 3 numbers");
      const Vector3d axis = Numbers(axis_field, 3);
      const double angle = Number(Require(*r, "angle", "a finite number"));
      const std::optional<Vector3d> u = UnitDirection(axis);
      if (!u) Fail(axis_field, "a rotation axis of non-zero length");
      X.linear() = Eigen::AngleAxisd(angle, *u).toRotationMatrix();
    } else if (k == "quaternion") {
      const std::optional<VectorXd> q = UnitDirection(Numbers(*r, 4));
      if (!q) Fail(*r, "a quaternion [w, x, y, z] of non-zero norm");
      X.linear() = Quaterniond((*q)[0], (*q)[1], (*q)[2], (*q)[3]).toRotationMatrix();
    } else {
      const VectorXd rpy = Numbers(*r, 3);
      X.linear() = (Eigen::AngleAxisd(rpy[2], Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(rpy[1], Vector3d::UnitY()) *
                    Eigen::AngleAxisd(rpy[0], Vector3d::UnitX()))
                       .toRotationMatrix();
    }
  }
  return X;
}

Matrix3d Parser::Inertia(const Field& f) const {
  if (planar()) {
    Matrix3d I = Matrix3d::Zero();  // planar bodies use only (2, 2)
    I(2, 2) = Number(f, Bound::kPositive);
    return I;
  }
  const std::string what = "[Ixx, Iyy, Izz] or a 3x3 list of lists";
  const std::vector<Field> rows = Items(f, what);
  if (rows.size() != 3) Fail(f, what);
  if (!rows[0].node.IsSequence()) {
    return Numbers(f, 3, Bound::kPositive).asDiagonal();
  }
  Matrix3d I;
  for (int r = 0; r < 3; ++r) I.row(r) = Numbers(rows[r], 3).transpose();
  if (!((I - I.transpose()).cwiseAbs().maxCoeff() <= kInertiaSymmetryTol * I.cwiseAbs().maxCoeff()))
    Fail(f, "a symmetric 3x3 inertia", "an asymmetric matrix");
  if (Eigen::LLT<Matrix3d>(I).info() != Eigen::Success || !(I.diagonal().array() > 0.0).all())
    Fail(f, "a positive definite 3x3 inertia", "a matrix that is not positive definite");
  return I;
}

void Parser::CheckPolygon(const Field& vf, const std::vector<Field>& items,
                          const std::vector<Vector3d>& v) const {
  const int n = static_cast<int>(v.size());
  double scale = 0.0;
  for (const Vector3d& p : v) scale = std::max(scale, (p - v[0]).norm());
  for (int i = 0; i < n; ++i)
    if (!((v[(i + 1) % n] - v[i]).norm() > kRelativeDegeneracy * scale))
      Fail(items[(i + 1) % n], "distinct consecutive vertices",
           "a repeat of vertex " + std::to_string(i));
  const double eps = kRelativeDegeneracy * scale * scale;
  int left = 0, right = 0, degenerate = -1;
  double turning = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vector2d e0 = (v[(i + 1) % n] - v[i]).head<2>();
    const Vector2d e1 = (v[(i + 2) % n] - v[(i + 1) % n]).head<2>();
    const double c = Cross2(e0, e1);
    if (c > eps) {
      ++left;
    } else if (c < -eps) {
      ++right;
    } else if (degenerate < 0) {
      degenerate = (i + 1) % n;
    }
    turning += std::atan2(c, e0.dot(e1));
  }
  if (degenerate >= 0)
    Fail(items[degenerate], "a strictly convex polygon (no three consecutive vertices collinear)",
         "a straight corner at vertex " + std::to_string(degenerate));
  if (right == n) Fail(vf, "counter-clockwise vertices", "clockwise vertices");
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  if (right > 0 || std::abs(turning - kTwoPi) > 1e-6)
    Fail(vf, "a convex polygon with counter-clockwise vertices",
         right > 0 ? "a non-convex polygon" : "a self-intersecting polygon");
}

void Parser::CheckPolyhedron(const Field& vf, const std::vector<Vector3d>& v) const {
  // Pick a far point, the point farthest from the line through both, then from their plane.
  double scale = 0.0;
  std::size_t i1 = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if ((v[i] - v[0]).norm() > scale) scale = (v[i] - v[0]).norm(), i1 = i;
  const double eps = kRelativeDegeneracy * scale;
  const Vector3d u = (v[i1] - v[0]).normalized();
  double best = 0.0;
  Vector3d normal = Vector3d::Zero();
  for (const Vector3d& p : v) {
    const Vector3d c = u.cross(p - v[0]);
    if (c.norm() > best) best = c.norm(), normal = c.normalized();
  }
  double height = 0.0;
  if (best > eps)
    for (const Vector3d& p : v) height = std::max(height, std::abs(normal.dot(p - v[0])));
  if (!(scale > 0.0) || !(best > eps) || !(height > eps))
    Fail(vf, "vertices spanning a volume", "coplanar vertices");
}

Shape Parser::ParseShape(const Field& f, BodyKind kind) const {
  if (!f.node.IsMap()) Fail(f, "a shape: a map with a 'type'");
  const std::vector<std::string> types = ShapeNames(dim_, false);
  const Field type_field = Require(f, "type", "a shape type (" + Join(types) + ")");
  const std::string type_name = String(type_field, "a shape type (" + Join(types) + ")");
  const ShapeSpec* spec = nullptr;
  for (const ShapeSpec& s : ShapeSpecs())
    if (type_name == s.name) spec = &s;
  if (!spec) Fail(type_field, "a shape type (" + Join(types) + ")");
  if (spec->dim != dim_)
    Fail(
        type_field,
        std::string("a ") + (planar() ? "planar" : "spatial") + " shape type (" + Join(types) + ")",
        "'" + type_name + "' (a " + (planar() ? "spatial" : "planar") + " shape)");
  if (kind == BodyKind::kDynamic && spec->size_keys.empty())
    Fail(type_field, "a bounded shape on a dynamic body (" + Join(ShapeNames(dim_, true)) + ")");

  std::vector<std::string> keys = {"type", "name", "pose", "material"};
  keys.insert(keys.end(), spec->size_keys.begin(), spec->size_keys.end());
  CheckMap(f, keys, std::string("a ") + spec->name + ": a map");

  Shape s;
  s.type = spec->type;
  if (auto name = Get(f, "name")) s.name = Name(*name);
  if (auto pose = Get(f, "pose")) s.X_BS = Pose(*pose);
  if (auto material = Get(f, "material")) s.material = MaterialIndex(*material);
  switch (s.type) {
    case ShapeType::kSphere:
    case ShapeType::kDisc:
      s.radius = Number(Require(f, "radius", "a finite number > 0"), Bound::kSize);
      break;
    case ShapeType::kCapsule:
      s.radius = Number(Require(f, "radius", "a finite number > 0"), Bound::kPositive);
      s.half_length =
          Number(Require(f, "half_length", "a finite number >= 0"), Bound::kNonNegative);
      break;
    case ShapeType::kSegment: {
      // A bare segment (radius 0) is allowed, but not a point.
      if (auto r = Get(f, "radius")) s.radius = Number(*r, Bound::kNonNegative);
      const Field hl = Require(f, "half_length", "a finite number >= 0");
      s.half_length = Number(hl, Bound::kNonNegative);
      if (s.radius == 0.0 && s.half_length == 0.0)
        Fail(hl, "a half_length > 0 for a segment of radius 0");
      break;
    }
    case ShapeType::kBox:
      s.half_extents = Numbers(Require(f, "half_extents", "a list of 3 numbers"), 3, Bound::kSize);
      break;
    case ShapeType::kConcavePolygon: {
      const std::string what = "a list of at least 3 points of 2 numbers";
      const Field vf = Require(f, "vertices", what);
      const std::vector<Field> items = Items(vf, what);
      if (items.size() < 3) Fail(vf, what);
      CheckVertexCount(vf, items.size(), SceneLimits::kMaxPolygonVertices);
      for (const Field& item : items) {
        const VectorXd p = Numbers(item, 2);
        s.vertices.push_back(Vector3d(p[0], p[1], 0.0));
      }
      try {
        PrepareShape(&s);  // checks: simple, counter-clockwise
      } catch (const std::invalid_argument& e) {
        Fail(vf, "a simple polygon with counter-clockwise vertices", e.what());
      }
      break;
    }
    case ShapeType::kPolyhedron:
    case ShapeType::kPolygon: {
      const int n_coords = planar() ? 2 : 3;
      const int n_min = planar() ? 3 : 4;
      const std::string what = "a list of at least " + std::to_string(n_min) + " points of " +
                               std::to_string(n_coords) + " numbers";
      const Field vf = Require(f, "vertices", what);
      const std::vector<Field> items = Items(vf, what);
      if (static_cast<int>(items.size()) < n_min) Fail(vf, what);
      CheckVertexCount(
          vf, items.size(),
          planar() ? SceneLimits::kMaxPolygonVertices : SceneLimits::kMaxPolyhedronVertices);
      for (const Field& item : items) {
        const VectorXd p = Numbers(item, n_coords);
        s.vertices.push_back(planar() ? Vector3d(p[0], p[1], 0.0) : Vector3d(p));
      }
      if (planar()) {
        CheckPolygon(vf, items, s.vertices);
      } else {
        CheckPolyhedron(vf, s.vertices);
      }
      break;
    }
    case ShapeType::kEllipsoid:
    case ShapeType::kSuperquadric:
    case ShapeType::kEllipse:
    case ShapeType::kSuperellipse: {
      const int n = planar() ? 2 : 3;
      const VectorXd a = Numbers(
          Require(f, "semi_axes", "a list of " + std::to_string(n) + " numbers"), n, Bound::kSize);
      s.half_extents.head(n) = a;
      if (s.type == ShapeType::kSuperquadric || s.type == ShapeType::kSuperellipse) {
        const Field ef = Require(f, "exponent", "a finite number >= 2");
        s.exponent = Number(ef, Bound::kPositive);
        if (s.exponent < 2.0) Fail(ef, "a finite number >= 2");
      }
      break;
    }
    case ShapeType::kCylinder:
      s.radius = Number(Require(f, "radius", "a finite number > 0"), Bound::kSize);
      s.half_length = Number(Require(f, "half_length", "a finite number > 0"), Bound::kSize);
      break;
    case ShapeType::kLens: {
      s.radius = Number(Require(f, "radius", "a finite number > 0"), Bound::kSize);
      const Field hl = Require(f, "half_length", "a finite number > 0 and <= radius");
      s.half_length = Number(hl, Bound::kSize);
      if (s.half_length > s.radius) Fail(hl, "a finite number > 0 and <= radius");
      break;
    }
    case ShapeType::kHalfSpace:
    case ShapeType::kHalfPlane:
      break;
  }
  return s;
}

DofMotion Parser::ParseDofMotion(const Field& f, std::optional<double> base_frequency) const {
  CheckMap(f, kDofMotionKeys, "a dof motion: a map");
  DofMotion m;
  if (auto k = Get(f, "keyframes")) {
    for (const char* other : {"velocity", "harmonics"})
      if (Get(f, other))
        Fail(*k, "keyframes alone (not combined with velocity or harmonics)",
             "keyframes together with '" + std::string(other) + "'");
    const std::string what = "a non-empty list of [t, value] pairs";
    const std::vector<Field> items = Items(*k, what);
    if (items.empty()) Fail(*k, what);
    for (std::size_t i = 0; i < items.size(); ++i) {
      const VectorXd kv = Numbers(items[i], 2);
      if (i > 0 && !(kv[0] > m.keyframes.back().t))
        Fail(items[i],
             "strictly increasing times (t > " + Truncated(items[i - 1].node[0].Scalar()) + ")",
             "t = '" + Truncated(items[i].node[0].Scalar()) + "'");
      m.keyframes.push_back({kv[0], kv[1]});
    }
  }
  if (auto v = Get(f, "velocity")) m.velocity = Number(*v);
  if (auto h = Get(f, "harmonics")) {
    for (const Field& item : Items(*h, "a list of harmonics {amplitude, frequency, phase}")) {
      CheckMap(item, kHarmonicKeys, "a harmonic: a map");
      Harmonic harmonic;
      if (auto a = Get(item, "amplitude")) harmonic.amplitude = Number(*a);
      if (auto fr = Get(item, "frequency")) harmonic.frequency = Number(*fr, Bound::kNonNegative);
      if (auto ord = Get(item, "order")) {
        // The k-th harmonic of the motion's base frequency.
        const std::string what = "an integer >= 1 (harmonic of the motion's base 'frequency')";
        if (Get(item, "frequency")) Fail(*ord, "'order' or 'frequency', not both", "both");
        if (!base_frequency)
          Fail(*ord, "'order' only with a base 'frequency' on the motion", "no base frequency");
        const long long k = Integer(*ord, what);
        if (k < 1 || k > 1000000) Fail(*ord, what);
        harmonic.frequency = static_cast<double>(k) * *base_frequency;
      }
      if (auto p = Get(item, "phase")) harmonic.phase = Number(*p);
      m.harmonics.push_back(harmonic);
    }
  }
  return m;
}

PrescribedMotion Parser::Motion(const Field& f) const {
  const std::vector<std::string>& dofs = planar() ? kPlanarDofs : kSpatialDofs;
  std::vector<std::string> keys = dofs;
  keys.insert(keys.end(), kMotionExtraKeys.begin(), kMotionExtraKeys.end());
  CheckMap(f, keys, "a motion: a map keyed by dof name, frequency, tilt or pose");
  PrescribedMotion motion;
  std::optional<double> base;
  if (auto fr = Get(f, "frequency")) base = motion.base_frequency = Number(*fr, Bound::kPositive);
  motion.dofs.resize(dofs.size());
  for (std::size_t d = 0; d < dofs.size(); ++d)
    if (auto m = Get(f, dofs[d])) motion.dofs[d] = ParseDofMotion(*m, base);
  if (auto t = Get(f, "tilt")) {
    CheckMap(*t, kTiltKeys, "a tilt: a map {amplitude, frequency, phase, depth, axis}");
    TiltMotion& tilt = motion.tilt;
    tilt.amplitude = Number(Require(*t, "amplitude", "a finite number (rad)"));
    if (auto fr = Get(*t, "frequency")) {
      tilt.frequency = Number(*fr, Bound::kPositive);
    } else if (base) {
      tilt.frequency = *base;
    } else {
      Fail(Field{t->node, Child(t->path, "frequency"), t->line},
           "a frequency > 0 (Hz) on the tilt or on the motion", "nothing (missing key)");
    }
    if (auto p = Get(*t, "phase")) tilt.phase = Number(*p);
    if (auto d = Get(*t, "depth")) tilt.depth = Number(*d);
    if (auto ax = Get(*t, "axis")) {
      if (planar()) Fail(*ax, "no axis in a planar scene (the tilt turns about z)");
      const std::optional<Vector3d> a = UnitDirection(Vector(*ax));
      if (!a || std::abs(a->z()) > 1e-9)
        Fail(*ax, "a non-zero axis in the plate plane (z component 0, body frame)");
      tilt.axis_B = *a;
    }
  }
  if (auto p = Get(f, "pose"))
    motion.pose = Choice<PoseRule>(
        *p, {{"exact", PoseRule::kExact}, {"integrated", PoseRule::kIntegrated}}, "a pose rule");
  return motion;
}

Body Parser::ParseBody(const Field& f) const {
  CheckMap(f, kBodyKeys, "a body: a map");
  Body b;
  const Field name_field = Require(f, "name", "a non-empty name");
  b.name = Name(name_field);
  if (b.name == "world") Fail(name_field, "a body name other than 'world' (it is reserved)");
  if (auto k = Get(f, "kind"))
    b.kind = Choice<BodyKind>(*k,
                              {{"dynamic", BodyKind::kDynamic},
                               {"static", BodyKind::kStatic},
                               {"prescribed", BodyKind::kPrescribed}},
                              "a body kind");
  const bool dynamic = b.kind == BodyKind::kDynamic;
  if (!dynamic) {
    for (const std::string& key : kDynamicOnlyKeys)
      if (auto v = Get(f, key))
        Fail(*v, "no '" + key + "' on a " + KindName(b.kind) +
                     " body (only dynamic bodies are integrated)");
  }
  if (auto m = Get(f, "motion"); m && b.kind != BodyKind::kPrescribed)
    Fail(*m, std::string("no motion on a ") + KindName(b.kind) +
                 " body (only prescribed bodies follow a motion)");

  if (auto pose = Get(f, "pose")) b.X_WB0 = Pose(*pose);
  if (auto v = Get(f, "velocity")) {
    CheckMap(*v, kVelocityKeys, "a velocity: a map");
    if (auto lin = Get(*v, "linear")) b.v0_W = Vector(*lin);
    if (auto ang = Get(*v, "angular")) b.w0_W = AngularVector(*ang);
  }
  if (dynamic) b.mass = Number(Require(f, "mass", "a finite number > 0"), Bound::kSize);
  if (auto g = Get(f, "gravity")) b.gravity = Bool(*g);
  if (auto force = Get(f, "force")) b.applied_force_W = Vector(*force);
  if (auto torque = Get(f, "torque")) b.applied_torque_W = AngularVector(*torque);
  if (auto shapes = Get(f, "shapes")) {
    std::map<std::string, int> names;
    const std::vector<Field> items = Items(*shapes, "a list of shapes");
    for (std::size_t i = 0; i < items.size(); ++i) {
      Shape s = ParseShape(items[i], b.kind);
      // Unnamed shapes get the name Scene::Finalize would give them.
      if (s.name.empty()) s.name = "s" + std::to_string(i);
      const auto [prev, inserted] = names.emplace(s.name, items[i].line);
      if (!inserted) {
        const std::optional<Field> nf = Get(items[i], "name");
        Fail(nf ? *nf : items[i], "shape names unique within the body (unnamed shape i is 's<i>')",
             "'" + s.name + "' again (first on line " + std::to_string(prev->second) + ")");
      }
      b.shapes.push_back(std::move(s));
    }
  }
  if (auto inertia = Get(f, "inertia")) {
    b.inertia = Inertia(*inertia);
    b.inertia_from_shapes = false;
  } else if (dynamic && b.shapes.empty()) {
    Fail(Field{f.node, Child(f.path, "inertia"), f.line},
         "an inertia (the body has no shapes to compute it from)", "nothing (missing key)");
  }
  if (auto m = Get(f, "motion")) b.motion = Motion(*m);
  if (auto c = Get(f, "compliance")) b.compliance = ParseCompliance(*c);
  if (auto d = Get(f, "damping")) b.damping = Damping(*d);
  if (auto s = Get(f, "support")) {
    if (!planar()) Fail(*s, "no support in a spatial scene (the 2.5D model is planar)");
    b.support = ParseSupport(*s);
  }
  return b;
}

ContactCompliance Parser::ParseCompliance(const Field& f) const {
  CheckMap(f, kComplianceKeys, "a compliance: a map");
  ContactCompliance c;
  c.law = Choice<ComplianceLaw>(Require(f, "law", "a compliance law"),
                                {{"rigid", ComplianceLaw::kRigid},
                                 {"kelvin-voigt", ComplianceLaw::kKelvinVoigt},
                                 {"hertz", ComplianceLaw::kHertz},
                                 {"hunt-crossley", ComplianceLaw::kHuntCrossley}},
                                "a compliance law");
  const auto only = [&](const char* key, bool allowed, const std::string& why) {
    std::optional<Field> v = Get(f, key);
    if (v && !allowed) Fail(*v, "no '" + std::string(key) + "' " + why);
    return v;
  };
  const bool rigid = c.law == ComplianceLaw::kRigid;
  const bool hc = c.law == ComplianceLaw::kHuntCrossley;
  if (rigid) {
    c.stiffness = 0.0;
  } else {
    c.stiffness = Number(Require(f, "stiffness", "a finite number > 0"), Bound::kPositive);
  }
  only("stiffness", !rigid, "for a rigid law");
  if (auto v = only("damping", !rigid && !hc,
                    rigid ? "for a rigid law" : "for hunt-crossley (it damps through alpha)"))
    c.damping = Number(*v, Bound::kNonNegative);
  if (auto v = only("alpha", hc, "(only hunt-crossley uses alpha; use damping)"))
    c.alpha = Number(*v, Bound::kNonNegative);
  if (auto v = only("min_overlap", !rigid, "for a rigid law"))
    c.min_overlap = Number(*v, Bound::kPositive);
  return c;
}

// First-order damping matrix C: a list of n positive numbers (diagonal) or n lists of n numbers
// (symmetric positive definite), n = 3 planar (vx, vy, ω), 6 spatial (v, ω).
MatrixXd Parser::Damping(const Field& f) const {
  const int n = planar() ? 3 : 6;
  const std::string what = "a list of " + std::to_string(n) + " numbers > 0 (diagonal) or " +
                           std::to_string(n) + " lists of " + std::to_string(n) + " numbers";
  const std::vector<Field> rows = Items(f, what);
  if (static_cast<int>(rows.size()) != n) Fail(f, what);
  if (!rows[0].node.IsSequence()) return Numbers(f, n, Bound::kPositive).asDiagonal();
  MatrixXd C(n, n);
  for (int r = 0; r < n; ++r) C.row(r) = Numbers(rows[r], n).transpose();
  if (!((C - C.transpose()).cwiseAbs().maxCoeff() <= kInertiaSymmetryTol * C.cwiseAbs().maxCoeff()))
    Fail(f, "a symmetric damping matrix", "an asymmetric matrix");
  if (Eigen::LLT<MatrixXd>(C).info() != Eigen::Success)
    Fail(f, "a positive definite damping matrix", "a matrix that is not positive definite");
  return C;
}

Support Parser::ParseSupport(const Field& f) const {
  CheckMap(f, kSupportKeys, "a support: a map");
  Support s;
  const std::string what = "a non-empty list of points [x, y]";
  const Field pf = Require(f, "points", what);
  const std::vector<Field> items = Items(pf, what);
  if (items.empty()) Fail(pf, what);
  for (const Field& item : items) {
    const VectorXd p = Numbers(item, 2);
    s.points_B.push_back(Vector3d(p[0], p[1], 0.0));
  }
  s.static_distribution = true;
  if (auto n = Get(f, "normal_forces")) {
    const std::string nwhat =
        "'static' or a list of " + std::to_string(items.size()) + " numbers >= 0 (one per point)";
    if (n->node.IsScalar()) {
      if (n->node.Scalar() != "static") Fail(*n, nwhat);
    } else {
      const VectorXd N = Numbers(*n, static_cast<int>(items.size()), Bound::kNonNegative);
      s.static_distribution = false;
      s.normal_forces.assign(N.data(), N.data() + N.size());
    }
  }
  if (auto m = Get(f, "mu")) s.mu = Number(*m, Bound::kNonNegative);
  if (auto d = Get(f, "directions")) {
    const std::string dwhat = "an integer >= 3";
    const long long n = Integer(*d, dwhat);
    if (n < 3 || n > SceneLimits::kMaxSupportDirections)
      Fail(*d, dwhat + " and <= " + std::to_string(SceneLimits::kMaxSupportDirections));
    s.directions = static_cast<int>(n);
  }
  return s;
}

Joint Parser::ParseJoint(const Field& f, const Scene& scene) const {
  CheckMap(f, kJointKeys, "a joint: a map");
  Joint j;
  j.name = Name(Require(f, "name", "a non-empty name"));
  if (auto t = Get(f, "type")) {
    if (planar()) {
      j.type = Choice<JointType>(*t,
                                 {{"revolute", JointType::kRevolute},
                                  {"prismatic", JointType::kPrismatic},
                                  {"weld", JointType::kWeld}},
                                 "a planar joint type");
    } else {
      j.type = Choice<JointType>(*t,
                                 {{"revolute", JointType::kRevolute},
                                  {"prismatic", JointType::kPrismatic},
                                  {"spherical", JointType::kSpherical},
                                  {"fixed", JointType::kFixed}},
                                 "a spatial joint type");
    }
  }
  std::vector<std::string> body_names;
  for (const Body& b : scene.bodies) body_names.push_back(b.name);
  const Field a_field = Require(f, "body_a", "a body name");
  const std::string a_name = Name(a_field);
  j.body_a = scene.FindBody(a_name);
  if (j.body_a < 0)
    Fail(a_field, "a body name (" + Join(body_names) + "; body_a cannot be 'world')");
  std::optional<Field> b_field = Get(f, "body_b");
  if (b_field) {
    const std::string b_name = Name(*b_field);
    j.body_b = b_name == "world" ? -1 : scene.FindBody(b_name);
    if (b_name != "world" && j.body_b < 0)
      Fail(*b_field, "a body name or 'world' (" + Join(body_names) + ")");
    if (j.body_b == j.body_a) Fail(*b_field, "a body other than body_a '" + a_name + "'");
  }
  if (auto fa = Get(f, "frame_a")) j.X_AJ = Pose(*fa);
  if (auto fb = Get(f, "frame_b")) {
    j.X_BJ = Pose(*fb);
  } else {
    // The joint starts satisfied: frame B is frame A's initial world pose seen from B.
    const Isometry3d X_WJ = scene.bodies[j.body_a].X_WB0 * j.X_AJ;
    j.X_BJ = j.body_b < 0 ? X_WJ : scene.bodies[j.body_b].X_WB0.inverse() * X_WJ;
  }
  return j;
}

void Parser::ParseStepper(const Field& f, StepperOptions* o) const {
  CheckMap(f, kStepperKeys, "stepper options: a map");
  if (auto v = Get(f, "formulation"))
    o->formulation = Choice<FormulationType>(*v, FormulationTable(), "a formulation");
  if (auto v = Get(f, "dt")) o->dt = Number(*v, Bound::kPositive);
  if (auto v = Get(f, "duration")) o->duration = Number(*v, Bound::kPositive);
  if (auto v = Get(f, "friction_directions")) {
    const std::string what =
        "an even integer in [2, " + std::to_string(SceneLimits::kMaxFrictionDirections) + "]";
    const long long n = Integer(*v, what);
    if (n < 2 || n % 2 != 0 || n > SceneLimits::kMaxFrictionDirections) Fail(*v, what);
    o->friction_directions = static_cast<int>(n);
  }
  if (auto v = Get(f, "envelope")) o->envelope = Number(*v, Bound::kNonNegative);
  if (auto v = Get(f, "solver")) {
    o->solver = Name(*v);
    const std::vector<std::string> names = SolverNames(o->formulation);
    if (std::find(names.begin(), names.end(), o->solver) == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      Fail(*v, "a solver of this formulation (" + list + ")", Describe(v->node));
    }
  }
  if (auto v = Get(f, "joint_stabilization")) o->joint_stabilization = Bool(*v);
  if (auto v = Get(f, "max_penetration")) o->max_penetration = Number(*v, Bound::kPositive);
  if (auto v = Get(f, "prescribed_velocity"))
    o->prescribed_velocity = Choice<PrescribedVelocity>(
        *v, {{"secant", PrescribedVelocity::kSecant}, {"exact", PrescribedVelocity::kExact}},
        "a prescribed-velocity rule");
  if (auto v = Get(f, "nonconvex_corners")) o->nonconvex_corners = Bool(*v);
}

void Parser::ParseFriction(const Field& f, Scene* scene) const {
  CheckMap(f, kFrictionKeys, "friction: a map");
  if (auto d = Get(f, "default")) scene->default_mu = Number(*d, Bound::kNonNegative);
  const auto pairs = Get(f, "pairs");
  if (!pairs) return;
  const std::string what = "a list [material, material, mu]";
  std::map<std::pair<int, int>, int> lines;
  for (const Field& item : Items(*pairs, "a list of [material, material, mu] entries")) {
    const std::vector<Field> parts = Items(item, what);
    if (parts.size() != 3) Fail(item, what);
    const int a = MaterialIndex(parts[0]);
    const int b = MaterialIndex(parts[1]);
    const double mu = Number(parts[2], Bound::kNonNegative);
    const std::pair<int, int> key(std::min(a, b), std::max(a, b));
    const auto [prev, inserted] = lines.emplace(key, item.line);
    if (!inserted)
      Fail(item, "each material pair once (in either order)",
           "[" + material_names_[a] + ", " + material_names_[b] + "] again (first on line " +
               std::to_string(prev->second) + ")");
    scene->mu[key] = mu;
  }
}

Scene Parser::Parse(const YAML::Node& root) {
  const Field top{root, "", LineOf(root, 1)};
  CheckMap(top, kTopKeys, "a scene: a map");
  Scene scene;
  if (auto n = Get(top, "name")) {
    scene.name = String(*n);
    if (!scene.name.empty() && !IsPrintableName(scene.name))
      Fail(*n, "a name of printable characters without ',' or '\"'");
  }

  const Field dim_field = Require(top, "dimension", "2 or 3");
  const long long dim = Integer(dim_field, "2 or 3");
  if (dim != 2 && dim != 3) Fail(dim_field, "2 or 3");
  dim_ = dim == 2 ? Dim::kPlanar : Dim::kSpatial;
  scene.dim = dim_;
  scene.gravity_W = planar() ? Vector3d(0, -9.81, 0) : Vector3d(0, 0, -9.81);
  if (auto g = Get(top, "gravity")) scene.gravity_W = Vector(*g);
  if (auto p = Get(top, "plane")) {
    if (!planar()) Fail(*p, "no plane in a spatial scene (the 2.5D model is planar)");
    if (auto g = Get(top, "gravity"))
      Fail(*g, "no gravity together with 'plane' (the plane sets the in-plane gravity)");
    CheckMap(*p, kPlaneKeys, "a plane: a map");
    if (auto t = Get(*p, "tilt")) {
      scene.plane.tilt = Number(*t, Bound::kNonNegative);
      if (scene.plane.tilt > 1.5707963267948966) Fail(*t, "a tilt in [0, pi/2] rad");
    }
    if (auto g = Get(*p, "g")) scene.plane.g = Number(*g, Bound::kPositive);
    scene.gravity_W = Vector3d(0.0, -scene.plane.g * std::sin(scene.plane.tilt), 0.0);
  }

  if (auto s = Get(top, "stepper")) ParseStepper(*s, &scene.options);

  // 'default' is material 0, as Scene::Finalize would make it; listed materials follow.
  material_names_ = {"default"};
  material_index_ = {{"default", 0}};
  std::map<std::string, int> material_lines;
  if (auto m = Get(top, "materials")) {
    for (const Field& item : Items(*m, "a list of material names")) {
      const std::string name = Name(item);
      if (name == "default")
        Fail(item, "a material name other than 'default' (it is predefined as material 0)");
      const auto [prev, inserted] = material_lines.emplace(name, item.line);
      if (!inserted)
        Fail(item, "unique material names",
             "'" + name + "' again (first on line " + std::to_string(prev->second) + ")");
      material_index_[name] = static_cast<int>(material_names_.size());
      material_names_.push_back(name);
    }
  }
  for (const std::string& name : material_names_) scene.materials.push_back(Material{name});

  if (auto fr = Get(top, "friction")) ParseFriction(*fr, &scene);

  const Field bodies = Require(top, "bodies", "a non-empty list of bodies");
  const std::vector<Field> body_items = Items(bodies, "a non-empty list of bodies");
  if (body_items.empty()) Fail(bodies, "a non-empty list of bodies");
  if (body_items.size() > static_cast<std::size_t>(SceneLimits::kMaxBodies))
    Fail(bodies, "at most " + std::to_string(SceneLimits::kMaxBodies) + " bodies",
         std::to_string(body_items.size()) + " bodies");
  std::map<std::string, int> body_lines;
  for (const Field& item : body_items) {
    Body b = ParseBody(item);
    const auto [prev, inserted] = body_lines.emplace(b.name, item.line);
    if (!inserted)
      Fail(*Get(item, "name"), "unique body names",
           "'" + b.name + "' again (first on line " + std::to_string(prev->second) + ")");
    if (!b.support.empty() && !Get(top, "plane"))
      Fail(*Get(item, "support"),
           "a support only in a scene with a top-level 'plane' (the table it rests on)",
           "a support without 'plane'");
    scene.bodies.push_back(std::move(b));
  }

  if (auto joints = Get(top, "joints")) {
    std::map<std::string, int> joint_lines;
    for (const Field& item : Items(*joints, "a list of joints")) {
      Joint j = ParseJoint(item, scene);
      const auto [prev, inserted] = joint_lines.emplace(j.name, item.line);
      if (!inserted)
        Fail(*Get(item, "name"), "unique joint names",
             "'" + j.name + "' again (first on line " + std::to_string(prev->second) + ")");
      scene.joints.push_back(std::move(j));
    }
  }

  try {
    scene.Finalize();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(src_ + ": " + e.what());
  }
  return scene;
}

}  // namespace

Scene ParseScene(const std::string& yaml_text, const std::string& source_name) {
  const std::vector<YAML::Node> docs = internal::LoadYamlDocuments(yaml_text, source_name);
  if (docs.empty() || docs[0].IsNull())
    throw std::invalid_argument(source_name +
                                ":1: (document): expected a scene: a map, got an empty document");
  if (docs.size() > 1)
    throw std::invalid_argument(source_name + ":" + std::to_string(LineOf(docs[1], 1)) +
                                ": (document): expected a single YAML document, got " +
                                std::to_string(docs.size()) + " documents");
  try {
    return Parser(source_name).Parse(docs[0]);
  } catch (const YAML::Exception& e) {
    // Defensive: every access above is checked, so this indicates a loader bug.
    const std::string line = e.mark.is_null() ? "" : std::to_string(e.mark.line + 1) + ":";
    throw std::invalid_argument(source_name + ":" + line + " " + e.msg);
  }
}

std::vector<std::string> SceneWarnings(const Scene& scene) {
  std::vector<std::string> warnings;
  // The bounding radius of each bounded shape about its frame origin.
  double smallest = std::numeric_limits<double>::infinity();
  std::string smallest_name;
  for (const Body& b : scene.bodies)
    for (const Shape& sh : b.shapes) {
      double r = 0.0;
      switch (sh.type) {
        case ShapeType::kHalfSpace:
        case ShapeType::kHalfPlane:
          continue;
        case ShapeType::kPolyhedron:
        case ShapeType::kPolygon:
        case ShapeType::kConcavePolygon:
          for (const Vector3d& v : sh.vertices) r = std::max(r, v.norm());
          break;
        default:
          r = std::max({sh.radius + sh.half_length, sh.half_extents.norm()});
          break;
      }
      if (r < smallest) smallest = r, smallest_name = b.name + "." + sh.name;
    }
  if (scene.options.envelope > smallest)
    warnings.push_back("stepper.envelope = " + FormatNumber(scene.options.envelope) +
                       " m is larger than the smallest shape ('" + smallest_name +
                       "', bounding radius " + FormatNumber(smallest) +
                       " m): every pair of shapes closer than that is a contact in every step, "
                       "which can make steps very slow");
  return warnings;
}

Scene LoadSceneFile(const std::string& path) {
  return ParseScene(ReadInputFile(path, "scene file"), path);
}

}  // namespace vinci::sim
