#include "vinci/planning/plan_spec.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "spec_reader.h"
#include "vinci/sim/model/yaml_documents.h"
#include "vinci/sim/solvers/input_file.h"

namespace vinci::planning {
namespace {

const std::vector<std::string> kTopKeys = {"scene",  "plate",  "plate_extent",  "primitives",
                                           "cycles", "goal",   "planner",       "time_limit",
                                           "seed",   "replan", "settle_cycles", "max_propagations"};

using internal::Field;
using internal::Join;
using internal::Reader;
using internal::Resolve;

void ReadPrimitives(const Reader& r, const Field& f, PlanSpec* spec) {
  if (!f.node.IsSequence() || f.node.size() == 0)
    r.Fail(f, "a non-empty list of {name: ..., motion: {...}}");
  if (f.node.size() > static_cast<std::size_t>(PlanLimits::kMaxPrimitives))
    r.Fail(f, "at most " + std::to_string(PlanLimits::kMaxPrimitives) + " primitives");
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
  const YAML::Node root = sim::LoadYamlDocument(text, source_name);
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
  std::tie(spec.x_min, spec.x_max) = r.Range(r.Require(ext, "x", "[lo, hi] (m)"), true);
  std::tie(spec.y_min, spec.y_max) = r.Range(r.Require(ext, "y", "[lo, hi] (m)"), true);
  ReadPrimitives(r, r.Require(top, "primitives", "a list of {name, motion}"), &spec);
  if (root["cycles"]) {
    const Field c = r.Child(top, "cycles");
    if (!c.node.IsSequence() || c.node.size() != 2) r.Fail(c, "[min, max] (integers)");
    spec.min_cycles = static_cast<int>(r.Integer(r.Item(c, 0), 1, PlanLimits::kMaxCycles));
    spec.max_cycles = static_cast<int>(r.Integer(r.Item(c, 1), 1, PlanLimits::kMaxCycles));
    if (spec.min_cycles > spec.max_cycles)
      r.Fail(c, "[min, max] with min <= max",
             "[" + c.node[0].Scalar() + ", " + c.node[1].Scalar() + "]");
  }
  if (root["settle_cycles"])
    spec.settle_cycles =
        static_cast<int>(r.Integer(r.Child(top, "settle_cycles"), 0, PlanLimits::kMaxCycles));
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
  if (root["time_limit"]) {
    const Field f = r.Child(top, "time_limit");
    spec.time_limit = r.Positive(f);
    if (spec.time_limit > PlanLimits::kMaxTimeLimit) r.Fail(f, "a number of seconds in (0, 1e6]");
  }
  if (root["seed"])
    spec.seed = static_cast<unsigned>(r.Integer(r.Child(top, "seed"), 0, 4294967295LL));
  if (root["replan"])
    spec.replan = static_cast<int>(r.Integer(r.Child(top, "replan"), 0, PlanLimits::kMaxReplan));
  return spec;
}

PlanSpec LoadPlanSpec(const std::string& path) {
  const std::string text = sim::ReadInputFile(path, "the plan spec");
  const std::size_t slash = path.find_last_of('/');
  return ParsePlanSpec(text, path, slash == std::string::npos ? "" : path.substr(0, slash));
}

}  // namespace vinci::planning
