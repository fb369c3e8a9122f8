#include "vinci/sim/model/scene.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/support.h"
#include "vinci/sim/solvers/lcp.h"
#include "vinci/sim/solvers/text_format.h"

namespace vinci::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
const char* const kPlanarDofNames[] = {"x", "y", "theta"};
const char* const kSpatialDofNames[] = {"x", "y", "z", "roll", "pitch", "yaw"};

std::string BodyContext(const Body& b) { return "body '" + b.name + "'"; }

// Inertia about the body origin (its centre of mass) from the shapes, uniform density.
Matrix3d InertiaFromShapes(const Body& body) {
  double volume = 0.0;
  for (const Shape& s : body.shapes) volume += ComputeUnitMassProperties(s).volume;
  if (!(volume > 0.0))
    throw std::invalid_argument(BodyContext(body) +
                                ": cannot compute an inertia from shapes of zero volume; give "
                                "'inertia' explicitly");
  // The body origin is its centre of mass (docs/formulations.md); shapes must be placed
  // accordingly.
  Vector3d centroid = Vector3d::Zero();
  double extent = 0.0;
  for (const Shape& s : body.shapes) {
    const UnitMassProperties mp = ComputeUnitMassProperties(s);
    centroid += mp.volume / volume * (s.X_BS * mp.centroid_S);
    const Aabb box = ComputeAabb(s, s.X_BS);
    extent = std::max(extent, (box.hi - box.lo).norm());
  }
  if (centroid.norm() > 1e-6 * std::max(extent, 1e-3)) {
    std::ostringstream msg;
    msg << BodyContext(body) << ": the shapes' centroid is at (" << centroid.transpose()
        << ") in the body frame, but the body origin must be the centre of mass; shift the "
           "shape poses by the negative of that offset (and the body pose by it)";
    throw std::invalid_argument(msg.str());
  }
  Matrix3d I = Matrix3d::Zero();
  for (const Shape& s : body.shapes) {
    const UnitMassProperties mp = ComputeUnitMassProperties(s);
    const double m = body.mass * mp.volume / volume;
    const Matrix3d R = s.X_BS.linear();
    const Vector3d c = s.X_BS * mp.centroid_S;  // shape centroid in body frame
    I += m * (R * mp.inertia_per_mass_S * R.transpose()) +
         m * (c.squaredNorm() * Matrix3d::Identity() - c * c.transpose());
  }
  return I;
}

}  // namespace

std::vector<std::string> SolverNames(FormulationType formulation) {
  if (formulation == FormulationType::kGeometricallyImplicit) return {"lemke", "semismooth-newton"};
  return LcpSolverNames();
}

const std::vector<std::pair<std::string, FormulationType>>& FormulationTable() {
  static const std::vector<std::pair<std::string, FormulationType>> kTable = {
      {"stewart-trinkle", FormulationType::kStewartTrinkle},
      {"anitescu-potra", FormulationType::kAnitescuPotra},
      {"ncp", FormulationType::kNcp},
      {"first-order", FormulationType::kFirstOrder},
      {"quasistatic-dlc", FormulationType::kQuasistaticDlc},
      {"quasistatic-dqc", FormulationType::kQuasistaticDqc},
      {"dynamic-dqc", FormulationType::kDynamicDqc},
      {"gi", FormulationType::kGeometricallyImplicit}};
  return kTable;
}

std::vector<std::string> FormulationNames() {
  std::vector<std::string> names;
  for (const auto& entry : FormulationTable()) names.push_back(entry.first);
  return names;
}

std::string_view ToString(FormulationType formulation) {
  for (const auto& entry : FormulationTable())
    if (entry.second == formulation) return entry.first;
  throw std::logic_error("ToString: FormulationType " +
                         std::to_string(static_cast<int>(formulation)) + " has no name");
}

FormulationType ParseFormulation(const std::string& name) {
  for (const auto& entry : FormulationTable())
    if (entry.first == name) return entry.second;
  std::string list;
  for (const std::string& n : FormulationNames()) list += (list.empty() ? "" : ", ") + n;
  throw std::invalid_argument("unknown formulation '" + name + "'; expected one of: " + list);
}

int Scene::FindBody(const std::string& body_name) const {
  for (std::size_t i = 0; i < bodies.size(); ++i)
    if (bodies[i].name == body_name) return static_cast<int>(i);
  return -1;
}

int Scene::FindMaterial(const std::string& material_name) const {
  for (std::size_t i = 0; i < materials.size(); ++i)
    if (materials[i].name == material_name) return static_cast<int>(i);
  return -1;
}

double Scene::Mu(int a, int b) const {
  const auto it = mu.find({std::min(a, b), std::max(a, b)});
  return it == mu.end() ? default_mu : it->second;
}

void Scene::Finalize() {
  if (materials.empty() || materials[0].name != "default")
    materials.insert(materials.begin(), Material{"default"});
  // Re-index friction pairs keyed by material name consistency is the builder's job; here we
  // only check ranges.
  for (const auto& [pair, value] : mu) {
    if (pair.first < 0 || pair.second >= static_cast<int>(materials.size()) ||
        pair.first > pair.second)
      throw std::invalid_argument("friction pair refers to an unknown material index");
    if (!(value >= 0.0)) throw std::invalid_argument("friction coefficient must be ≥ 0");
  }
  if (!(options.dt > 0.0) || !std::isfinite(options.dt))
    throw std::invalid_argument("stepper dt must be a finite number > 0");
  if (options.friction_directions < 2 || options.friction_directions % 2 != 0)
    throw std::invalid_argument("friction_directions must be an even number ≥ 2");

  const bool planar = dim == Dim::kPlanar;
  index_.assign(bodies.size(), BodyIndex{});
  dynamic_.clear();
  nq_ = nv_ = 0;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    Body& b = bodies[i];
    for (std::size_t j = i + 1; j < bodies.size(); ++j)
      if (bodies[j].name == b.name)
        throw std::invalid_argument("duplicate body name '" + b.name + "'");
    CheckCompliance(b.compliance, BodyContext(b));
    for (std::size_t j = 0; j < i; ++j) {
      const std::string why = CheckCompliancePair(bodies[j].compliance, b.compliance);
      if (!why.empty())
        throw std::invalid_argument(BodyContext(b) + " and body '" + bodies[j].name + "': " + why);
    }
    for (std::size_t s = 0; s < b.shapes.size(); ++s) {
      Shape& sh = b.shapes[s];
      if (sh.name.empty()) sh.name = "s" + std::to_string(s);
      if (sh.type == ShapeType::kPolyhedron && sh.faces.empty()) PrepareShape(&sh);
      if (sh.type == ShapeType::kConcavePolygon) PrepareShape(&sh);  // validates
      if (IsPlanar(sh.type) != planar)
        throw std::invalid_argument(BodyContext(b) + ": shape '" + sh.name + "' is " +
                                    (planar ? "spatial" : "planar") + " in a " +
                                    (planar ? "planar" : "spatial") + " scene");
      if (sh.material < 0 || sh.material >= static_cast<int>(materials.size()))
        throw std::invalid_argument(BodyContext(b) + ": shape '" + sh.name +
                                    "' has an unknown material");
    }
    if (b.kind == BodyKind::kDynamic) {
      if (!(b.mass > 0.0) || !std::isfinite(b.mass))
        throw std::invalid_argument(BodyContext(b) + ": mass must be a finite number > 0");
      for (const Shape& sh : b.shapes)
        if (sh.type == ShapeType::kHalfSpace || sh.type == ShapeType::kHalfPlane)
          throw std::invalid_argument(BodyContext(b) +
                                      ": a dynamic body cannot carry an unbounded half-space");
      if (b.inertia_from_shapes) b.inertia = InertiaFromShapes(b);
      if (!b.inertia.allFinite() ||
          (planar ? b.inertia(2, 2) <= 0.0 : b.inertia.determinant() <= 0.0))
        throw std::invalid_argument(BodyContext(b) + ": inertia must be positive definite");
      if (options.formulation == FormulationType::kFirstOrder) {
        const int n = VelocitySize(dim);
        if (b.damping.rows() != n || b.damping.cols() != n || !b.damping.allFinite() ||
            Eigen::LLT<MatrixXd>(b.damping).info() != Eigen::Success) {
          throw std::invalid_argument(
              BodyContext(b) +
              ": the first-order formulation needs a symmetric positive definite " +
              std::to_string(n) + "x" + std::to_string(n) + " damping matrix, got " +
              std::to_string(b.damping.rows()) + "x" + std::to_string(b.damping.cols()));
        }
      }
      index_[i] = {nq_, nv_};
      nq_ += PositionSize(dim);
      nv_ += VelocitySize(dim);
      dynamic_.push_back(static_cast<int>(i));
    }
    if (b.kind == BodyKind::kPrescribed && !b.motion.dofs.empty() &&
        b.motion.dofs.size() != static_cast<std::size_t>(planar ? 3 : 6))
      throw std::invalid_argument(BodyContext(b) + ": motion needs " + (planar ? "3" : "6") +
                                  " dofs");
    if (b.kind == BodyKind::kPrescribed && !b.motion.tilt.IsZero()) {
      const TiltMotion& t = b.motion.tilt;
      if (!std::isfinite(t.amplitude) || !(t.frequency > 0.0) || !std::isfinite(t.frequency) ||
          !std::isfinite(t.phase) || !std::isfinite(t.depth))
        throw std::invalid_argument(
            BodyContext(b) + ": tilt needs finite amplitude, phase, depth and frequency > 0");
      if (!planar && (std::abs(t.axis_B.norm() - 1.0) > 1e-9 || std::abs(t.axis_B.z()) > 1e-9))
        throw std::invalid_argument(BodyContext(b) +
                                    ": tilt axis must be a unit vector in the body's x-y plane");
    }
  }
  for (const Joint& j : joints) {
    const int n = static_cast<int>(bodies.size());
    if (j.body_a < 0 || j.body_a >= n || j.body_b < -1 || j.body_b >= n || j.body_a == j.body_b)
      throw std::invalid_argument("joint '" + j.name + "' refers to invalid bodies");
  }
  FinalizeSupports(this);  // 2.5D support friction (support.h)

  // The parameter table.
  params_ = ParamTable();
  params_.Add({"mu.default", ParamKind::kDefaultFriction, -1, -1, -1, default_mu, 0.0, kInf});
  for (const auto& [pair, value] : mu)
    params_.Add({"mu." + materials[pair.first].name + "." + materials[pair.second].name,
                 ParamKind::kFriction, pair.first, pair.second, -1, value, 0.0, kInf});
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    const Body& b = bodies[i];
    const int bi = static_cast<int>(i);
    if (b.kind == BodyKind::kDynamic)
      params_.Add({"mass." + b.name, ParamKind::kMass, bi, -1, -1, b.mass, 1e-12, kInf});
    if (b.kind == BodyKind::kDynamic && !b.support.empty())
      params_.Add({"support_mu." + b.name, ParamKind::kSupportFriction, bi, -1, -1, b.support.mu,
                   0.0, kInf});
    for (std::size_t s = 0; s < b.shapes.size(); ++s) {
      const Shape& sh = b.shapes[s];
      const int si = static_cast<int>(s);
      const std::string pre = "size." + b.name + "." + sh.name + ".";
      switch (sh.type) {
        case ShapeType::kSphere:
        case ShapeType::kDisc:
          params_.Add(
              {pre + "radius", ParamKind::kShapeRadius, bi, si, -1, sh.radius, 1e-12, kInf});
          break;
        case ShapeType::kCylinder:
        case ShapeType::kLens:
          params_.Add(
              {pre + "radius", ParamKind::kShapeRadius, bi, si, -1, sh.radius, 1e-12, kInf});
          params_.Add({pre + "half_length", ParamKind::kShapeHalfLength, bi, si, -1, sh.half_length,
                       1e-12, kInf});
          break;
        case ShapeType::kEllipsoid:
        case ShapeType::kSuperquadric:
        case ShapeType::kEllipse:
        case ShapeType::kSuperellipse:
          for (int c = 0; c < (IsPlanar(sh.type) ? 2 : 3); ++c)
            params_.Add({pre + "half_extents." + "xyz"[c], ParamKind::kShapeHalfExtent, bi, si, c,
                         sh.half_extents[c], 1e-12, kInf});
          break;
        case ShapeType::kCapsule:
        case ShapeType::kSegment:
          params_.Add({pre + "radius", ParamKind::kShapeRadius, bi, si, -1, sh.radius, 0.0, kInf});
          params_.Add({pre + "half_length", ParamKind::kShapeHalfLength, bi, si, -1, sh.half_length,
                       0.0, kInf});
          break;
        case ShapeType::kBox:
          for (int c = 0; c < 3; ++c)
            params_.Add({pre + "half_extents." + "xyz"[c], ParamKind::kShapeHalfExtent, bi, si, c,
                         sh.half_extents[c], 1e-12, kInf});
          break;
        case ShapeType::kPolygon:
        case ShapeType::kConcavePolygon:
        case ShapeType::kPolyhedron:
          params_.Add({pre + "scale", ParamKind::kShapeScale, bi, si, -1, 1.0, 1e-12, kInf});
          break;
        case ShapeType::kHalfSpace:
        case ShapeType::kHalfPlane:
          break;
      }
    }
    if (b.kind == BodyKind::kPrescribed) {
      for (std::size_t d = 0; d < b.motion.dofs.size(); ++d) {
        const DofMotion& m = b.motion.dofs[d];
        const int di = static_cast<int>(d);
        const std::string pre =
            "motion." + b.name + "." + (planar ? kPlanarDofNames[d] : kSpatialDofNames[d]) + ".";
        if (!m.keyframes.empty()) continue;
        params_.Add(
            {pre + "velocity", ParamKind::kMotionVelocity, bi, di, -1, m.velocity, -kInf, kInf});
        for (std::size_t k = 0; k < m.harmonics.size(); ++k) {
          const int ki = static_cast<int>(k);
          const Harmonic& h = m.harmonics[k];
          params_.Add({pre + "amplitude" + std::to_string(k), ParamKind::kMotionAmplitude, bi, di,
                       ki, h.amplitude, -kInf, kInf});
          params_.Add({pre + "frequency" + std::to_string(k), ParamKind::kMotionFrequency, bi, di,
                       ki, h.frequency, 0.0, kInf});
          params_.Add({pre + "phase" + std::to_string(k), ParamKind::kMotionPhase, bi, di, ki,
                       h.phase, -kInf, kInf});
        }
      }
    }
  }
}

Scene Scene::ApplyParams(const Params& params) const {
  if (params.values.size() != params_.size())
    throw std::invalid_argument("parameter vector has " + std::to_string(params.values.size()) +
                                " entries; the scene has " + std::to_string(params_.size()));
  Scene s = *this;
  for (int i = 0; i < params_.size(); ++i) {
    const ParamInfo& p = params_.info(i);
    const double x = params.values[i];
    if (!std::isfinite(x) || x < p.lower || x > p.upper)
      throw std::invalid_argument("parameter '" + p.name + "' = " + FormatNumber(x) +
                                  " is outside [" + FormatNumber(p.lower) + ", " +
                                  FormatNumber(p.upper) + "]");
    switch (p.kind) {
      case ParamKind::kDefaultFriction:
        s.default_mu = x;
        break;
      case ParamKind::kFriction:
        s.mu[{p.a, p.b}] = x;
        break;
      case ParamKind::kSupportFriction:
        s.bodies[p.a].support.mu = x;
        break;
      case ParamKind::kMass: {
        Body& b = s.bodies[p.a];
        b.inertia *= x / b.mass;  // same shape, new density
        b.mass = x;
        break;
      }
      case ParamKind::kShapeRadius:
        s.bodies[p.a].shapes[p.b].radius = x;
        break;
      case ParamKind::kShapeHalfExtent:
        s.bodies[p.a].shapes[p.b].half_extents[p.c] = x;
        break;
      case ParamKind::kShapeHalfLength:
        s.bodies[p.a].shapes[p.b].half_length = x;
        break;
      case ParamKind::kShapeScale:
        if (x != 1.0) {
          Shape& sh = s.bodies[p.a].shapes[p.b];
          for (Vector3d& v : sh.vertices) v *= x;
          for (HullFace& f : sh.faces) f.offset *= x;  // scaling about the origin keeps normals
        }
        break;
      case ParamKind::kMotionVelocity:
        s.bodies[p.a].motion.dofs[p.b].velocity = x;
        break;
      case ParamKind::kMotionAmplitude:
        s.bodies[p.a].motion.dofs[p.b].harmonics[p.c].amplitude = x;
        break;
      case ParamKind::kMotionFrequency:
        s.bodies[p.a].motion.dofs[p.b].harmonics[p.c].frequency = x;
        break;
      case ParamKind::kMotionPhase:
        s.bodies[p.a].motion.dofs[p.b].harmonics[p.c].phase = x;
        break;
    }
  }
  return s;
}

}  // namespace vinci::sim
