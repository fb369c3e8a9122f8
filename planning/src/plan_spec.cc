#include "vinci/planning/plan_spec.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace vinci::planning {
namespace {

const std::vector<std::string> kTopKeys = {"scene",  "plate",  "plate_extent",  "primitives",
                                           "cycles", "goal",   "planner",       "time_limit",
                                           "seed",   "replan", "settle_cycles", "max_propagations"};

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

// A node with its dotted name and line, for error messages.
struct Field {
  YAML::Node node;
  std::string name;
  int line;
};

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  const std::string& source() const { return source_; }
  [[noreturn]] void Fail(const Field& f, const std::string& expected,
                         const std::string& got) const {
    throw std::invalid_argument(source_ + ":" + std::to_string(f.line) + ": " + f.name +
                                ": expected " + expected + ", got " + got);
  }
  [[noreturn]] void Fail(const Field& f, const std::string& expected) const {
    Fail(f, expected, Describe(f.node));
  }
  static std::string Describe(const YAML::Node& n) {
    if (!n || n.IsNull()) return "nothing";
    if (n.IsScalar()) return "'" + n.Scalar() + "'";
    if (n.IsSequence()) return "a list of " + std::to_string(n.size());
    return "a map";
  }
  static int LineOf(const YAML::Node& n, int fallback) {
    const YAML::Mark m = n.Mark();
    return m.line >= 0 ? m.line + 1 : fallback;
  }
  Field Child(const Field& f, const std::string& key) const {
    const YAML::Node c = f.node[key];
    return {c, f.name.empty() ? key : f.name + "." + key, c ? LineOf(c, f.line) : f.line};
  }
  Field Item(const Field& f, std::size_t i) const {
    const YAML::Node c = f.node[i];
    return {c, f.name + "[" + std::to_string(i) + "]", LineOf(c, f.line)};
  }
  // A map whose keys are all in `allowed` (empty: any key), each once.
  void Map(const Field& f, const std::vector<std::string>& allowed, const std::string& what) const {
    if (!f.node.IsMap()) Fail(f, what);
    std::set<std::string> seen;
    for (const auto& kv : f.node) {
      const std::string key = kv.first.Scalar();
      const Field kf{kv.first, f.name.empty() ? key : f.name + "." + key, LineOf(kv.first, f.line)};
      if (!seen.insert(key).second) Fail(kf, "each key once", "a duplicate");
      bool ok = allowed.empty();
      for (const auto& a : allowed) ok = ok || a == key;
      if (!ok) Fail(kf, "one of the keys (" + Join(allowed) + ")", "unknown key '" + key + "'");
    }
  }
  Field Require(const Field& f, const std::string& key, const std::string& expected) const {
    Field c = Child(f, key);
    if (!c.node) Fail(c, expected, "nothing (missing key)");
    return c;
  }
  double Number(const Field& f) const {
    if (!f.node.IsScalar()) Fail(f, "a number");
    std::istringstream s(f.node.Scalar());
    double v = 0.0;
    s >> v;
    if (!s || !s.eof() || !std::isfinite(v)) Fail(f, "a finite number");
    return v;
  }
  double Positive(const Field& f) const {
    const double v = Number(f);
    if (!(v > 0.0)) Fail(f, "a number > 0");
    return v;
  }
  long long Integer(const Field& f, long long lo, long long hi) const {
    const std::string expected =
        "an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    if (!f.node.IsScalar()) Fail(f, expected);
    const std::string& t = f.node.Scalar();
    if (t.empty() || t.size() > 18 || t == "-" ||
        t.find_first_not_of("0123456789", t[0] == '-' ? 1 : 0) != std::string::npos)
      Fail(f, expected);
    const long long v = std::stoll(t);
    if (v < lo || v > hi) Fail(f, expected);
    return v;
  }
  std::string String(const Field& f) const {
    if (!f.node.IsScalar() || f.node.Scalar().empty()) Fail(f, "a string");
    return f.node.Scalar();
  }
  // [a, b] with a < b.
  std::pair<double, double> Range(const Field& f) const {
    if (!f.node.IsSequence() || f.node.size() != 2) Fail(f, "[lo, hi]");
    const double a = Number(Item(f, 0));
    const double b = Number(Item(f, 1));
    if (!(a < b))
      Fail(f, "[lo, hi] with lo < hi", "[" + f.node[0].Scalar() + ", " + f.node[1].Scalar() + "]");
    return {a, b};
  }
  Eigen::Vector2d Vec2(const Field& f) const {
    if (!f.node.IsSequence() || f.node.size() != 2) Fail(f, "[x, y]");
    return {Number(Item(f, 0)), Number(Item(f, 1))};
  }

 private:
  std::string source_;
};

std::string Resolve(const std::string& base_dir, const std::string& p) {
  if (p.empty() || p[0] == '/' || base_dir.empty()) return p;
  return base_dir + "/" + p;
}

void ReadPrimitives(const Reader& r, const Field& f, PlanSpec* spec) {
  if (!f.node.IsSequence() || f.node.size() == 0)
    r.Fail(f, "a non-empty list of {name: ..., motion: {...}}");
  std::set<std::string> names;
  for (std::size_t i = 0; i < f.node.size(); ++i) {
    const Field p = r.Item(f, i);
    r.Map(p, {"name", "motion"}, "a map {name: ..., motion: {...}}");
    PlanPrimitive prim;
    const Field name = r.Require(p, "name", "a name");
    prim.name = r.String(name);
    if (!names.insert(prim.name).second) r.Fail(name, "a name used once", "'" + prim.name + "'");
    const Field m = r.Require(p, "motion", "a plate motion map (scene format)");
    if (!m.node.IsMap()) r.Fail(m, "a plate motion map (scene format)");
    YAML::Emitter out;
    out << m.node;
    prim.motion_yaml = out.c_str();
    prim.line = m.line;
    spec->primitives.push_back(prim);
  }
}

void ReadGoal(const Reader& r, const Field& f, PlanSpec* spec) {
  r.Map(f, {}, "a map {PART: {position: [x, y], tolerance: m, angle: rad, angle_tolerance: rad}}");
  if (f.node.size() == 0) r.Fail(f, "a goal for at least one part");
  spec->goal_line = f.line;
  for (const auto& kv : f.node) {
    PartGoal g;
    g.part = kv.first.Scalar();
    const Field p{kv.second, f.name + "." + g.part, Reader::LineOf(kv.second, f.line)};
    g.line = p.line;
    r.Map(p, {"position", "tolerance", "angle", "angle_tolerance"},
          "a map {position: [x, y], tolerance: m, angle: rad, angle_tolerance: rad}");
    g.position = r.Vec2(r.Require(p, "position", "[x, y] (m, plate frame)"));
    if (p.node["tolerance"]) g.tolerance = r.Positive(r.Child(p, "tolerance"));
    if (p.node["angle"]) {
      g.has_angle = true;
      g.angle = r.Number(r.Child(p, "angle"));
    }
    if (p.node["angle_tolerance"]) {
      if (!g.has_angle)
        r.Fail(r.Child(p, "angle_tolerance"), "an angle_tolerance only with an angle", "no angle");
      g.angle_tolerance = r.Positive(r.Child(p, "angle_tolerance"));
    }
    spec->goals.push_back(g);
  }
}

}  // namespace

const char* PlannerName(PlannerType t) {
  switch (t) {
    case PlannerType::kKpiece1:
      return "kpiece1";
    case PlannerType::kSst:
      return "sst";
    case PlannerType::kRrt:
      return "rrt";
  }
  return "?";
}

PlannerType ParsePlannerName(const std::string& name, const std::string& where) {
  for (PlannerType t : {PlannerType::kKpiece1, PlannerType::kSst, PlannerType::kRrt})
    if (name == PlannerName(t)) return t;
  throw std::invalid_argument(where + ": expected kpiece1, sst or rrt, got '" + name + "'");
}

PlanSpec ParsePlanSpec(const std::string& text, const std::string& source_name,
                       const std::string& base_dir) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument(source_name + ":" + std::to_string(e.mark.line + 1) +
                                ": invalid YAML: " + e.msg);
  }
  const Reader r(source_name);
  const Field top{root, "", 1};
  r.Map(top, kTopKeys, "a plan spec (a map of " + Join(kTopKeys) + ")");
  PlanSpec spec;
  spec.path = source_name;
  spec.scene_path = Resolve(base_dir, r.String(r.Require(top, "scene", "a scene file")));
  if (root["plate"]) {
    const Field p = r.Child(top, "plate");
    spec.plate = r.String(p);
    spec.plate_line = p.line;
  }
  const Field ext = r.Require(top, "plate_extent", "{x: [lo, hi], y: [lo, hi]} (m, plate frame)");
  r.Map(ext, {"x", "y"}, "{x: [lo, hi], y: [lo, hi]}");
  std::tie(spec.x_min, spec.x_max) = r.Range(r.Require(ext, "x", "[lo, hi] (m)"));
  std::tie(spec.y_min, spec.y_max) = r.Range(r.Require(ext, "y", "[lo, hi] (m)"));
  ReadPrimitives(r, r.Require(top, "primitives", "a list of {name, motion}"), &spec);
  if (root["cycles"]) {
    const Field c = r.Child(top, "cycles");
    if (!c.node.IsSequence() || c.node.size() != 2) r.Fail(c, "[min, max] (integers)");
    spec.min_cycles = static_cast<int>(r.Integer(r.Item(c, 0), 1, 100000));
    spec.max_cycles = static_cast<int>(r.Integer(r.Item(c, 1), 1, 100000));
    if (spec.min_cycles > spec.max_cycles)
      r.Fail(c, "[min, max] with min <= max",
             "[" + c.node[0].Scalar() + ", " + c.node[1].Scalar() + "]");
  }
  if (root["settle_cycles"])
    spec.settle_cycles = static_cast<int>(r.Integer(r.Child(top, "settle_cycles"), 0, 100000));
  ReadGoal(r, r.Require(top, "goal", "a map {PART: {position: [x, y], ...}}"), &spec);
  for (const PartGoal& g : spec.goals) {
    const bool inside = g.position.x() >= spec.x_min && g.position.x() <= spec.x_max &&
                        g.position.y() >= spec.y_min && g.position.y() <= spec.y_max;
    if (!inside)
      throw std::invalid_argument(source_name + ":" + std::to_string(g.line) + ": goal." + g.part +
                                  ".position: expected a point inside plate_extent, got [" +
                                  std::to_string(g.position.x()) + ", " +
                                  std::to_string(g.position.y()) + "]");
  }
  if (root["planner"]) {
    const Field p = r.Child(top, "planner");
    const std::string name = r.String(p);
    try {
      spec.planner =
          ParsePlannerName(name, source_name + ":" + std::to_string(p.line) + ": planner");
    } catch (const std::invalid_argument&) {
      r.Fail(p, "kpiece1, sst or rrt");
    }
  }
  if (root["max_propagations"])
    spec.max_propagations = r.Integer(r.Child(top, "max_propagations"), 0, 1000000000000LL);
  if (root["time_limit"]) spec.time_limit = r.Positive(r.Child(top, "time_limit"));
  if (root["seed"])
    spec.seed = static_cast<unsigned>(r.Integer(r.Child(top, "seed"), 0, 4294967295LL));
  if (root["replan"]) spec.replan = static_cast<int>(r.Integer(r.Child(top, "replan"), 0, 1000));
  return spec;
}

PlanSpec LoadPlanSpec(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot read the plan spec");
  std::stringstream s;
  s << in.rdbuf();
  const std::size_t slash = path.find_last_of('/');
  return ParsePlanSpec(s.str(), path, slash == std::string::npos ? "" : path.substr(0, slash));
}

}  // namespace vinci::planning
