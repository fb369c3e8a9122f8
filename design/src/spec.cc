// The design-spec loader (format: docs/design.md). Errors follow the scene loader:
// "<file>:<line>: <field>: expected <what>, got <what was found>".
#include "vinci/design/spec.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/yaml_documents.h"
#include "vinci/sim/simulator/simulator.h"
#include "vinci/sim/solvers/input_file.h"

namespace vinci::design {
namespace {

const std::vector<std::string> kTopKeys = {
    "scene",    "parameters", "uncertain", "samples", "validation_samples", "seed",
    "duration", "objective",  "optimizer", "budget",  "screening"};
const std::vector<std::string> kParameterKeys = {"name", "lower", "upper", "start"};
const std::vector<std::string> kUncertainKeys = {"name", "uniform", "normal", "choice", "truncate"};
const std::vector<std::string> kObjectiveKeys = {"type",  "body",   "region",      "angle",
                                                 "until", "target", "angle_scale", "grip"};
const std::vector<std::string> kGripKeys = {"jaws", "min_overlap", "max_overlap"};
const std::vector<std::string> kGeometricKeys = {"type", "tolerance", "samples"};
const std::vector<std::string> kShortKeys = {"type",        "duration",    "samples", "objective",
                                             "min_success", "formulation", "dt"};
const std::vector<std::string> kRegionKeys = {"min", "max"};
const std::vector<std::string> kAngleKeys = {"target", "tolerance", "symmetry"};

std::string Join(const std::vector<std::string>& items) {
  std::string s;
  for (std::size_t i = 0; i < items.size(); ++i) s += (i ? ", " : "") + items[i];
  return s;
}

std::string Describe(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Null:
      return "null (a key without a value)";
    case YAML::NodeType::Scalar: {
      std::string s = n.Scalar();
      if (s.size() > 40) s = s.substr(0, 40) + "...";
      return "'" + s + "'";
    }
    case YAML::NodeType::Sequence:
      return "a list of " + std::to_string(n.size()) + (n.size() == 1 ? " item" : " items");
    case YAML::NodeType::Map:
      return "a map";
    case YAML::NodeType::Undefined:
      break;
  }
  return "nothing";
}

// A node with its field path and the file it came from.
class Field {
 public:
  Field(const std::string* source, YAML::Node node, std::string path, int fallback_line)
      : source_(source), node_(node), path_(std::move(path)), line_(fallback_line) {
    if (node_.IsDefined() && node_.Mark().line >= 0) line_ = node_.Mark().line + 1;
  }
  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  int line() const { return line_; }

  [[noreturn]] void Fail(const std::string& expected) const {
    throw std::invalid_argument(*source_ + ":" + std::to_string(line_) + ": " + path_ +
                                ": expected " + expected + ", got " + Describe(node_));
  }
  [[noreturn]] void FailMessage(const std::string& message) const {
    throw std::invalid_argument(*source_ + ":" + std::to_string(line_) + ": " + path_ + ": " +
                                message);
  }

  bool Has(const std::string& key) const { return node_.IsMap() && node_[key].IsDefined(); }
  Field operator[](const std::string& key) const {
    return Field(source_, node_[key], path_.empty() ? key : path_ + "." + key, line_);
  }
  Field At(std::size_t i) const {
    return Field(source_, node_[i], path_ + "[" + std::to_string(i) + "]", line_);
  }
  Field Required(const std::string& key) const {
    if (!Has(key))
      throw std::invalid_argument(*source_ + ":" + std::to_string(line_) + ": " +
                                  (path_.empty() ? key : path_ + "." + key) +
                                  ": expected a value (required), got nothing");
    return (*this)[key];
  }

  void ExpectMap(const std::vector<std::string>& keys) const {
    if (!node_.IsMap()) Fail("a map with keys {" + Join(keys) + "}");
    std::set<std::string> seen;
    for (auto it = node_.begin(); it != node_.end(); ++it) {
      const std::string key = it->first.Scalar();
      Field k(source_, it->first, path_.empty() ? key : path_ + "." + key, line_);
      bool known = false;
      for (const std::string& a : keys) known = known || a == key;
      if (!known)
        k.FailMessage("expected one of the keys {" + Join(keys) + "}, got unknown key '" + key +
                      "'");
      if (!seen.insert(key).second) k.FailMessage("key given twice");
      if (it->second.IsNull()) Field(source_, it->second, k.path(), k.line()).Fail("a value");
    }
  }
  void ExpectList() const {
    if (!node_.IsSequence()) Fail("a list");
  }

  double Number() const {
    if (!node_.IsScalar() || node_.Tag() != "?") Fail("a finite number");
    double v = 0.0;
    std::istringstream in(node_.Scalar());
    in >> v;
    if (in.fail() || !in.eof() || !std::isfinite(v)) Fail("a finite number");
    return v;
  }
  double Positive() const {
    const double v = Number();
    if (!(v > 0.0)) Fail("a finite number > 0");
    return v;
  }
  // An integer in [min, max] written as [-]digits (no sign inside, no fraction, no exponent).
  long long Integer(long long min, long long max = std::numeric_limits<long long>::max()) const {
    const std::string what =
        max == std::numeric_limits<long long>::max()
            ? "an integer >= " + std::to_string(min)
            : "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
    if (!node_.IsScalar() || node_.Tag() != "?") Fail(what);
    const std::string& s = node_.Scalar();
    const std::size_t digits = !s.empty() && s[0] == '-' ? 1 : 0;
    if (s.size() <= digits || s.size() > 18 ||
        s.find_first_not_of("0123456789", digits) != std::string::npos)
      Fail(what);
    const long long v = std::stoll(s);
    if (v < min || v > max) Fail(what);
    return v;
  }
  bool Bool() const {
    if (node_.IsScalar() && node_.Tag() == "?") {
      const std::string& s = node_.Scalar();
      if (s == "true" || s == "True" || s == "TRUE") return true;
      if (s == "false" || s == "False" || s == "FALSE") return false;
    }
    Fail("true or false");
  }
  std::string String() const {
    if (!node_.IsScalar() || node_.Scalar().empty()) Fail("a non-empty string");
    return node_.Scalar();
  }
  std::vector<double> Numbers(std::size_t min_size, std::size_t max_size) const {
    const std::string what = min_size == max_size
                                 ? "a list of " + std::to_string(min_size) + " numbers"
                                 : "a list of " + std::to_string(min_size) + " to " +
                                       std::to_string(max_size) + " numbers";
    if (!node_.IsSequence() || node_.size() < min_size || node_.size() > max_size) Fail(what);
    std::vector<double> v;
    for (std::size_t i = 0; i < node_.size(); ++i) v.push_back(At(i).Number());
    return v;
  }

 private:
  const std::string* source_;
  YAML::Node node_;
  std::string path_;
  int line_;
};

const std::vector<std::string> kInitialPlanar = {"x", "y", "theta", "vx", "vy", "omega"};
const std::vector<std::string> kInitialSpatial = {"x", "y", "z", "vx", "vy", "vz"};

// "prefix.<body>.<coord>" → (body, coord). The body name may contain dots.
bool SplitBodyCoord(const std::string& name, const std::string& prefix, std::string* body,
                    std::string* coord) {
  if (name.compare(0, prefix.size(), prefix) != 0) return false;
  const std::size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot <= prefix.size()) return false;
  *body = name.substr(prefix.size(), dot - prefix.size());
  *coord = name.substr(dot + 1);
  return true;
}

int IndexOf(const std::vector<std::string>& list, const std::string& s) {
  for (std::size_t i = 0; i < list.size(); ++i)
    if (list[i] == s) return static_cast<int>(i);
  return -1;
}

// The whole file, bounded (sim::ReadInputFile: no directories or devices, at most 64 MiB).
std::string ReadFile(const std::string& path, const std::string& what) {
  return sim::ReadInputFile(path, what);
}

// A rollout of `duration` s at step `dt` must have at most kMaxRolloutSteps steps.
void CheckRolloutSteps(const Field& f, double duration, double dt) {
  const double steps = duration / dt;
  if (!(steps <= DesignLimits::kMaxRolloutSteps)) {
    std::ostringstream s;
    s << "expected duration / dt <= " << DesignLimits::kMaxRolloutSteps
      << " steps per rollout, got " << duration << " / " << dt << " = " << steps;
    f.FailMessage(s.str());
  }
}

// objective.grip (success only): jaws (bodies other than the objective body) and the overlap
// window (grip.h).
void ParseGrip(const Field& g, const sim::Scene& scene, Objective& o) {
  if (o.type != ObjectiveType::kSuccess) g.FailMessage("applies to type success only");
  g.ExpectMap(kGripKeys);
  const Field jf = g.Required("jaws");
  jf.ExpectList();
  if (jf.node().size() == 0) jf.Fail("a non-empty list of body names");
  for (std::size_t i = 0; i < jf.node().size(); ++i) {
    const Field f = jf.At(i);
    const std::string name = f.String();
    const int b = scene.FindBody(name);
    if (b < 0) f.Fail("the name of a body of the scene");
    if (b == o.body_index) f.Fail("a body other than the objective's body '" + o.body + "'");
    if (IndexOf(o.grip.jaws, name) >= 0) f.FailMessage("jaw given twice");
    o.grip.jaws.push_back(name);
    o.grip.jaw_indices.push_back(b);
  }
  if (g.Has("min_overlap")) {
    o.grip.min_overlap = g["min_overlap"].Number();
    if (o.grip.min_overlap < 0.0) g["min_overlap"].Fail("a number >= 0");
  }
  if (g.Has("max_overlap")) {
    o.grip.max_overlap = g["max_overlap"].Positive();
    if (!(o.grip.max_overlap > o.grip.min_overlap))
      g["max_overlap"].Fail("a number > min_overlap (" + std::to_string(o.grip.min_overlap) + ")");
  }
  o.has_grip = true;
}

// An objective map (the spec's `objective:` or a screening stage's).
void ParseObjective(const Field& of, const sim::Scene& scene, Objective* out) {
  const bool planar = scene.dim == sim::Dim::kPlanar;
  const std::size_t pos_size = planar ? 2 : 3;
  Objective& o = *out;
  of.ExpectMap(kObjectiveKeys);
  const Field tf = of.Required("type");
  const std::string type = tf.String();
  if (type == "success")
    o.type = ObjectiveType::kSuccess;
  else if (type == "distance")
    o.type = ObjectiveType::kDistance;
  else if (type == "margin")
    o.type = ObjectiveType::kMargin;
  else
    tf.Fail("one of success, distance, margin");
  o.body = of.Required("body").String();
  o.body_index = scene.FindBody(o.body);
  if (o.body_index < 0) of["body"].Fail("the name of a body of the scene");
  if (scene.bodies[o.body_index].kind != sim::BodyKind::kDynamic) of["body"].Fail("a dynamic body");
  const auto vec = [](const std::vector<double>& v) {
    return Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  };
  if (o.type == ObjectiveType::kDistance) {
    for (const char* k : {"region", "angle", "until", "angle_scale", "grip"})
      if (of.Has(k)) of[k].FailMessage("does not apply to type distance");
    o.target = vec(of.Required("target").Numbers(pos_size, pos_size));
  } else {
    if (of.Has("target")) of["target"].FailMessage("applies to type distance only");
    if (of.Has("region")) {
      const Field r = of["region"];
      r.ExpectMap(kRegionKeys);
      o.region_min = vec(r.Required("min").Numbers(pos_size, pos_size));
      o.region_max = vec(r.Required("max").Numbers(pos_size, pos_size));
      for (std::size_t k = 0; k < pos_size; ++k)
        if (!(o.region_max[k] >= o.region_min[k])) r["max"].Fail("max >= min in every coordinate");
      o.has_region = true;
    }
    if (of.Has("angle")) {
      const Field a = of["angle"];
      if (!planar) a.FailMessage("angle: applies to planar scenes only");
      a.ExpectMap(kAngleKeys);
      o.angle_target = a.Required("target").Number();
      o.angle_tolerance = a.Required("tolerance").Positive();
      if (a.Has("symmetry")) o.angle_symmetry = a["symmetry"].Positive();
      o.has_angle = true;
    }
    if (of.Has("grip")) ParseGrip(of["grip"], scene, o);
    if (!o.has_region && !o.has_angle && !o.has_grip)
      of.FailMessage("expected region: and/or angle: (what success means), or grip:");
    if (of.Has("until")) o.until = of["until"].Bool();
    if (of.Has("angle_scale")) o.angle_scale = of["angle_scale"].Positive();
  }
}

// `screening:` (after the objective, the samples and the duration it refers to).
void ParseScreening(const Field& list, DesignSpec* spec) {
  list.ExpectList();
  if (spec->objective.type != ObjectiveType::kSuccess)
    list.FailMessage(
        "applies to objectives of type success only (a rejected design gets the "
        "worst success rate, 0)");
  if (list.node().size() > static_cast<std::size_t>(DesignLimits::kMaxScreeningStages))
    list.Fail("at most " + std::to_string(DesignLimits::kMaxScreeningStages) + " stages");
  for (std::size_t i = 0; i < list.node().size(); ++i) {
    const Field f = list.At(i);
    if (!f.node().IsMap()) f.Fail("a map with a type (geometric or short)");
    ScreeningStage st;
    st.line = f.line();
    const Field tf = f.Required("type");
    const std::string type = tf.String();
    if (type == "geometric") {
      f.ExpectMap(kGeometricKeys);
      st.type = StageType::kGeometric;
      if (f.Has("tolerance")) {
        st.tolerance = f["tolerance"].Number();
        if (st.tolerance < 0.0) f["tolerance"].Fail("a number >= 0 (m)");
      }
      if (f.Has("samples"))
        st.samples = static_cast<int>(f["samples"].Integer(0, DesignLimits::kMaxSamples));
    } else if (type == "short") {
      f.ExpectMap(kShortKeys);
      st.type = StageType::kShort;
      st.duration = f.Required("duration").Positive();
      st.samples = spec->samples;
      if (f.Has("samples"))
        st.samples = static_cast<int>(f["samples"].Integer(1, DesignLimits::kMaxSamples));
      st.min_success = f.Required("min_success").Number();
      if (st.min_success < 0.0 || st.min_success > 1.0)
        f["min_success"].Fail("a number in [0, 1] (a success rate)");
      st.objective = spec->objective;
      if (f.Has("objective")) {
        ParseObjective(f["objective"], spec->scene, &st.objective);
        if (st.objective.type != ObjectiveType::kSuccess)
          f["objective"]["type"].Fail("success (a stage passes on its success rate)");
      }
      st.options = sim::SimulatorOptions::FromScene(spec->scene);
      if (f.Has("dt")) st.options.dt = f["dt"].Positive();
      if (f.Has("formulation")) {
        const Field ff = f["formulation"];
        const std::string name = ff.String();
        try {
          st.options.formulation = sim::ParseFormulation(name);
        } catch (const std::invalid_argument& e) {
          ff.FailMessage(e.what());
        }
      }
      CheckRolloutSteps(f.Has("dt") ? f["dt"] : f["duration"], st.duration, st.options.dt);
      // The stage's simulator must take the scene: build it once here.
      if (f.Has("formulation") || f.Has("dt")) {
        try {
          (void)sim::Simulator(spec->scene, st.options);
        } catch (const std::invalid_argument& e) {
          f[f.Has("formulation") ? "formulation" : "dt"].FailMessage(
              std::string("the scene cannot run with it: ") + e.what());
        }
      }
    } else {
      tf.Fail("one of geometric, short");
    }
    spec->screening.push_back(st);
  }
}

}  // namespace

bool ResolveDesignName(const sim::Scene& scene, const std::string& name, Target* target) {
  const int p = scene.param_table().Find(name);
  if (p < 0) return false;
  *target = Target{TargetKind::kParam, p, -1, -1, false};
  return true;
}

bool ResolveUncertainName(const sim::Scene& scene, const std::string& name, Target* target) {
  const int p = scene.param_table().Find(name);
  if (p >= 0) {
    *target = Target{TargetKind::kParam, p, -1, -1, false};
    return true;
  }
  std::string body, coord;
  if (!SplitBodyCoord(name, "initial.", &body, &coord)) return false;
  const int b = scene.FindBody(body);
  const bool planar = scene.dim == sim::Dim::kPlanar;
  const int c = IndexOf(planar ? kInitialPlanar : kInitialSpatial, coord);
  if (b < 0 || c < 0 || scene.bodies[b].kind != sim::BodyKind::kDynamic) return false;
  *target = Target{TargetKind::kInitial, -1, b, c % 3, c >= 3};
  return true;
}

DesignSpec ParseDesignSpec(const std::string& yaml_text, const std::string& source_name,
                           const std::string& base_dir) {
  DesignSpec spec;
  spec.source = source_name;
  const YAML::Node root = sim::LoadYamlDocument(yaml_text, source_name);
  const Field top(&spec.source, root, "", 1);
  top.ExpectMap(kTopKeys);

  // The scene.
  const Field scene_field = top.Required("scene");
  const std::string scene_name = scene_field.String();
  spec.scene_path =
      (scene_name.front() == '/' || base_dir.empty()) ? scene_name : base_dir + "/" + scene_name;
  try {
    spec.scene_text = ReadFile(spec.scene_path, "scene file");
  } catch (const std::invalid_argument& e) {
    scene_field.Fail("a readable scene file (resolved to '" + spec.scene_path + "': " + e.what() +
                     ")");
  }
  spec.scene = sim::ParseScene(spec.scene_text, spec.scene_path);
  const sim::Scene& scene = spec.scene;
  const bool planar = scene.dim == sim::Dim::kPlanar;

  std::set<std::string> names;
  // Design parameters.
  const Field params = top.Required("parameters");
  params.ExpectList();
  if (params.node().size() == 0) params.Fail("a non-empty list of parameters");
  for (std::size_t i = 0; i < params.node().size(); ++i) {
    const Field f = params.At(i);
    f.ExpectMap(kParameterKeys);
    DesignParameter p;
    p.line = f.line();
    p.name = f.Required("name").String();
    if (!ResolveDesignName(scene, p.name, &p.target))
      f["name"].Fail(
          std::string("a scene parameter (e.g. mu.default, mass.<body>, "
                      "size.<body>.<shape>.radius, support_mu.<body>, "
                      "pose.<static or prescribed body>.<d>, pose.<body>.<shape>.<d> with <d> ") +
          (planar ? "x|y|theta)" : "x|y|z|roll|pitch|yaw)"));
    if (!names.insert(p.name).second) f["name"].FailMessage("parameter listed twice");
    p.lower = f.Required("lower").Number();
    p.upper = f.Required("upper").Number();
    if (!(p.upper > p.lower)) f["upper"].Fail("a number > lower (" + std::to_string(p.lower) + ")");
    const sim::ParamInfo& info = scene.param_table().info(p.target.index);
    if (p.lower < info.lower)
      f["lower"].Fail("a number >= " + std::to_string(info.lower) + " (the range of " + p.name +
                      ")");
    if (p.upper > info.upper)
      f["upper"].Fail("a number <= " + std::to_string(info.upper) + " (the range of " + p.name +
                      ")");
    // The scene must accept both bounds (e.g. a shape pose of a dynamic body whose inertia comes
    // from its shapes cannot move the shapes' centroid off the body origin).
    for (const char* bound : {"lower", "upper"}) {
      sim::Params values = scene.DefaultParams();
      values.values[p.target.index] = bound[0] == 'l' ? p.lower : p.upper;
      try {
        (void)scene.ApplyParams(values);
      } catch (const std::invalid_argument& e) {
        f[bound].FailMessage(std::string("the scene rejects this value: ") + e.what());
      }
    }
    if (f.Has("start")) {
      p.start = f["start"].Number();
      if (p.start < p.lower || p.start > p.upper)
        f["start"].Fail("a number in [lower, upper] = [" + std::to_string(p.lower) + ", " +
                        std::to_string(p.upper) + "]");
    } else {
      p.start = std::min(std::max(info.default_value, p.lower), p.upper);
    }
    spec.parameters.push_back(p);
  }

  // Uncertain numbers.
  if (top.Has("uncertain")) {
    const Field list = top["uncertain"];
    list.ExpectList();
    for (std::size_t i = 0; i < list.node().size(); ++i) {
      const Field f = list.At(i);
      f.ExpectMap(kUncertainKeys);
      Uncertain u;
      u.name = f.Required("name").String();
      if (!ResolveUncertainName(scene, u.name, &u.target))
        f["name"].Fail(std::string("a scene parameter or initial.<dynamic body>.") +
                       (planar ? "x|y|theta|vx|vy|omega" : "x|y|z|vx|vy|vz"));
      if (!names.insert(u.name).second)
        f["name"].FailMessage("already a design parameter or an uncertain entry");
      const int kinds = f.Has("uniform") + f.Has("normal") + f.Has("choice");
      if (kinds != 1)
        f.FailMessage(
            "expected exactly one of uniform: [a, b], normal: [mean, std], "
            "choice: [v1, v2, ...]");
      if (f.Has("uniform")) {
        const std::vector<double> v = f["uniform"].Numbers(2, 2);
        if (!(v[1] >= v[0])) f["uniform"].Fail("[a, b] with a <= b");
        u.type = DistributionType::kUniform;
        u.a = v[0];
        u.b = v[1];
      } else if (f.Has("normal")) {
        const std::vector<double> v = f["normal"].Numbers(2, 2);
        if (!(v[1] >= 0.0)) f["normal"].Fail("[mean, std] with std >= 0");
        u.type = DistributionType::kNormal;
        u.a = v[0];
        u.b = v[1];
      } else {
        const Field c = f["choice"];
        if (!c.node().IsSequence() || c.node().size() < 1) c.Fail("a non-empty list of numbers");
        u.choices = c.Numbers(1, DesignLimits::kMaxChoices);
        u.type = DistributionType::kChoice;
      }
      if (f.Has("truncate")) {
        if (u.type != DistributionType::kNormal)
          f["truncate"].FailMessage("applies to normal distributions only");
        const std::vector<double> v = f["truncate"].Numbers(2, 2);
        if (!(v[1] > v[0])) f["truncate"].Fail("[lo, hi] with lo < hi");
        if (u.b == 0.0 && (u.a < v[0] || u.a > v[1]))
          f["truncate"].Fail("an interval containing the mean when std = 0");
        // Redrawing must terminate: the interval must carry some probability mass.
        if (u.b > 0.0 && (std::max(std::abs(v[0] - u.a), std::abs(v[1] - u.a)) / u.b < 1e-3 ||
                          (v[0] - u.a) / u.b > 5.0 || (u.a - v[1]) / u.b > 5.0))
          f["truncate"].Fail("an interval within 5 std of the mean");
        u.truncated = true;
        u.lo = v[0];
        u.hi = v[1];
      }
      // A parameter drawn outside its admissible range would make ApplyParams throw.
      if (u.target.kind == TargetKind::kParam) {
        const sim::ParamInfo& info = scene.param_table().info(u.target.index);
        double lo = u.a, hi = u.b;
        if (u.type == DistributionType::kNormal)
          lo = u.truncated ? u.lo : -std::numeric_limits<double>::infinity(),
          hi = u.truncated ? u.hi : std::numeric_limits<double>::infinity();
        if (u.type == DistributionType::kNormal && u.b == 0.0) lo = hi = u.a;
        if (u.type == DistributionType::kChoice) {
          lo = *std::min_element(u.choices.begin(), u.choices.end());
          hi = *std::max_element(u.choices.begin(), u.choices.end());
        }
        if (lo < info.lower || hi > info.upper)
          f.FailMessage("expected values within the range of " + u.name + " [" +
                        std::to_string(info.lower) + ", " + std::to_string(info.upper) +
                        "] (truncate a normal distribution)");
      }
      spec.uncertain.push_back(u);
    }
  }

  if (top.Has("samples"))
    spec.samples = static_cast<int>(top["samples"].Integer(1, DesignLimits::kMaxSamples));
  if (top.Has("validation_samples"))
    spec.validation_samples =
        static_cast<int>(top["validation_samples"].Integer(1, DesignLimits::kMaxSamples));
  if (top.Has("seed")) spec.seed = static_cast<std::uint64_t>(top["seed"].Integer(0));
  spec.duration = top.Required("duration").Positive();
  CheckRolloutSteps(top["duration"], spec.duration, scene.options.dt);
  if (top.Has("optimizer")) spec.optimizer = top["optimizer"].String();
  if (top.Has("budget"))
    spec.budget = static_cast<int>(top["budget"].Integer(1, DesignLimits::kMaxBudget));

  ParseObjective(top.Required("objective"), scene, &spec.objective);
  if (top.Has("screening")) ParseScreening(top["screening"], &spec);
  return spec;
}

DesignSpec LoadDesignSpec(const std::string& path) {
  const std::string text = ReadFile(path, "design spec file");
  const std::size_t slash = path.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash);
  return ParseDesignSpec(text, path, dir);
}

}  // namespace vinci::design
