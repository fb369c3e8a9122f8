#include "vinci/design/best_scene.h"

#include <yaml-cpp/yaml.h>

#include <cstdio>
#include <stdexcept>

namespace vinci::design {
namespace {

// Numbers are written with 17 significant digits so that the scene reproduces the design.
YAML::Node Number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return YAML::Node(std::string(buf));
}

YAML::Node BodyNode(const YAML::Node& root, const sim::Scene& scene, int body) {
  YAML::Node bodies = root["bodies"];
  if (!bodies.IsSequence() || static_cast<int>(bodies.size()) <= body ||
      !bodies[body]["name"].IsScalar() || bodies[body]["name"].Scalar() != scene.bodies[body].name)
    throw std::invalid_argument("best scene: cannot find body '" + scene.bodies[body].name +
                                "' at bodies[" + std::to_string(body) + "] of the scene file");
  return bodies[body];
}

// Multiplies every vertex of a shape by `scale` (the kShapeScale parameter's meaning).
void ScaleVertices(YAML::Node shape, double scale) {
  YAML::Node vertices = shape["vertices"];
  for (std::size_t i = 0; i < vertices.size(); ++i)
    for (std::size_t k = 0; k < vertices[i].size(); ++k)
      vertices[i][k] = Number(vertices[i][k].as<double>() * scale);
}

// Writes pose component c (params.h: planar x, y, θ; spatial x, y, z, roll, pitch, yaw) of the
// pose whose components are `c0[0..n)`: a translation component writes the whole `position`, a
// rotation component the whole `angle` (planar) or `rpy` (spatial; the node's other rotation
// keys are dropped so that rpy is its one rotation). The values are the Params entries
// themselves, so the scene loader rebuilds the pose ApplyParams builds, bit for bit.
void WritePose(YAML::Node node, sim::Dim dim, const double* c0, int c) {
  const bool planar = dim == sim::Dim::kPlanar;
  const int nt = planar ? 2 : 3;
  YAML::Node list(YAML::NodeType::Sequence);
  list.SetStyle(YAML::EmitterStyle::Flow);
  if (c < nt) {
    for (int k = 0; k < nt; ++k) list.push_back(Number(c0[k]));
    node["position"] = list;
  } else if (planar) {
    node["angle"] = Number(c0[2]);
  } else {
    for (const char* key : {"rotation", "quaternion"}) node.remove(key);
    for (int k = 3; k < 6; ++k) list.push_back(Number(c0[k]));
    node["rpy"] = list;
  }
}

// `params` is the full parameter vector of the design and `index` p's entry in it (pose
// components are consecutive in the table: p.c of them precede p).
void WriteParam(YAML::Node root, const sim::Scene& scene, const sim::Params& params, int index,
                const sim::ParamInfo& p, double v) {
  switch (p.kind) {
    case sim::ParamKind::kPose: {
      const double* c0 = params.values.data() + (index - p.c);
      if (p.b < 0)
        WritePose(BodyNode(root, scene, p.a)["pose"], scene.dim, c0, p.c);
      else
        WritePose(BodyNode(root, scene, p.a)["shapes"][p.b]["pose"], scene.dim, c0, p.c);
      return;
    }
    case sim::ParamKind::kTiltAmplitude:
      BodyNode(root, scene, p.a)["motion"]["tilt"]["amplitude"] = Number(v);
      return;
    case sim::ParamKind::kTiltFrequency:
      BodyNode(root, scene, p.a)["motion"]["tilt"]["frequency"] = Number(v);
      return;
    case sim::ParamKind::kTiltPhase:
      BodyNode(root, scene, p.a)["motion"]["tilt"]["phase"] = Number(v);
      return;
    case sim::ParamKind::kTiltDepth:
      BodyNode(root, scene, p.a)["motion"]["tilt"]["depth"] = Number(v);
      return;
    case sim::ParamKind::kDefaultFriction:
      root["friction"]["default"] = Number(v);
      return;
    case sim::ParamKind::kFriction: {
      const std::string a = scene.materials[p.a].name, b = scene.materials[p.b].name;
      YAML::Node pairs = root["friction"]["pairs"];
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        const std::string x = pairs[i][0].as<std::string>(), y = pairs[i][1].as<std::string>();
        if ((x == a && y == b) || (x == b && y == a)) {
          pairs[i][2] = Number(v);
          return;
        }
      }
      break;
    }
    case sim::ParamKind::kMass:
      BodyNode(root, scene, p.a)["mass"] = Number(v);
      return;
    case sim::ParamKind::kSupportFriction:
      BodyNode(root, scene, p.a)["support"]["mu"] = Number(v);
      return;
    case sim::ParamKind::kShapeRadius:
      BodyNode(root, scene, p.a)["shapes"][p.b]["radius"] = Number(v);
      return;
    case sim::ParamKind::kShapeHalfLength:
      BodyNode(root, scene, p.a)["shapes"][p.b]["half_length"] = Number(v);
      return;
    case sim::ParamKind::kShapeHalfExtent: {
      YAML::Node shape = BodyNode(root, scene, p.a)["shapes"][p.b];
      const char* key = shape["semi_axes"].IsDefined() ? "semi_axes" : "half_extents";
      shape[key][p.c] = Number(v);
      return;
    }
    case sim::ParamKind::kShapeScale:
      ScaleVertices(BodyNode(root, scene, p.a)["shapes"][p.b], v);
      return;
    case sim::ParamKind::kMotionVelocity:
    case sim::ParamKind::kMotionAmplitude:
    case sim::ParamKind::kMotionFrequency:
    case sim::ParamKind::kMotionPhase: {
      // motion.<body>.<dof>.<field>[k]
      const std::string& n = p.name;
      const std::size_t last = n.rfind('.'), dof_dot = n.rfind('.', last - 1);
      const std::string dof = n.substr(dof_dot + 1, last - dof_dot - 1);
      YAML::Node m = BodyNode(root, scene, p.a)["motion"][dof];
      if (p.kind == sim::ParamKind::kMotionVelocity) {
        m["velocity"] = Number(v);
        return;
      }
      const char* field = p.kind == sim::ParamKind::kMotionAmplitude   ? "amplitude"
                          : p.kind == sim::ParamKind::kMotionFrequency ? "frequency"
                                                                       : "phase";
      m["harmonics"][p.c][field] = Number(v);
      return;
    }
  }
  throw std::invalid_argument("best scene: cannot write parameter '" + p.name +
                              "' into the scene file");
}

}  // namespace

std::string BestSceneYaml(const DesignSpec& spec, const VectorXd& x) {
  if (x.size() != static_cast<Eigen::Index>(spec.parameters.size()))
    throw std::invalid_argument("best scene: design vector of the wrong size");
  YAML::Node root = YAML::Load(spec.scene_text);
  const sim::Scene& scene = spec.scene;
  sim::Params params = scene.DefaultParams();
  for (std::size_t k = 0; k < spec.parameters.size(); ++k)
    if (spec.parameters[k].target.kind == TargetKind::kParam)
      params.values[spec.parameters[k].target.index] = x[k];
  // Shape scales multiply the file's vertices: apply each once, after the other values.
  for (std::size_t k = 0; k < spec.parameters.size(); ++k) {
    const DesignParameter& p = spec.parameters[k];
    if (p.target.kind == TargetKind::kParam) {
      WriteParam(root, scene, params, p.target.index, scene.param_table().info(p.target.index),
                 x[k]);
    }
  }
  root["stepper"]["duration"] = Number(spec.duration);
  YAML::Emitter out;
  out << root;
  return "# " + spec.scene_path + " with the design found by `vinci design " + spec.source +
         "`:\n#" +
         [&] {
           std::string s;
           char buf[64];
           for (std::size_t k = 0; k < spec.parameters.size(); ++k) {
             std::snprintf(buf, sizeof buf, " = %.9g", x[k]);
             s += " " + spec.parameters[k].name + buf + (k + 1 < spec.parameters.size() ? "," : "");
           }
           return s;
         }() +
         "\n" + out.c_str() + "\n";
}

}  // namespace vinci::design
