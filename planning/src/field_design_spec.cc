#include "vinci/planning/field_design_spec.h"

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

const std::vector<std::string> kTopKeys = {
    "scene",          "target",    "motion",    "grid",   "cycles",
    "average_cycles", "objective", "tolerance", "budget", "seed"};
const std::vector<std::string> kDofs = {"x", "y", "z", "roll", "pitch", "yaw"};

using internal::Field;
using internal::Join;
using internal::Reader;
using internal::Resolve;

void ReadTarget(const Reader& r, const Field& t, const std::string& base_dir, FieldDesignSpec* spec,
                std::string* csv_path, int* csv_line) {
  r.Map(t, {"type", "center", "radius", "direction", "speed", "clockwise", "csv"},
        "a map {type: ..., ...} or {csv: file.csv}");
  FieldTarget& g = spec->target;
  if (t.node["csv"]) {
    if (t.node["type"] && t.node["type"].Scalar() != "csv")
      r.Fail(r.Child(t, "type"), "csv (or no type) with a csv: file");
    for (const char* k : {"center", "radius", "direction", "clockwise"})
      if (t.node[k]) r.Fail(r.Child(t, k), "no such key with csv:", "'" + std::string(k) + "'");
    g.type = TargetType::kCsv;
    const Field c = r.Child(t, "csv");
    *csv_path = Resolve(base_dir, r.String(c));
    *csv_line = c.line;
    if (t.node["speed"])
      r.Fail(r.Child(t, "speed"), "no speed with csv: (its velocities are absolute)");
    return;
  }
  const Field type = r.Require(t, "type",
                               "sink, source, whirlpool, circle, saddle, line_sink, shear or "
                               "conveyor");
  const std::string name = r.String(type);
  struct Known {
    const char* name;
    TargetType type;
    bool center, radius, direction, clockwise;
  };
  const Known known[] = {{"sink", TargetType::kSink, true, true, false, false},
                         {"source", TargetType::kSource, true, true, false, false},
                         {"whirlpool", TargetType::kWhirlpool, true, true, false, true},
                         {"circle", TargetType::kCircle, true, true, false, true},
                         {"saddle", TargetType::kSaddle, true, true, true, false},
                         {"line_sink", TargetType::kLineSink, true, true, true, false},
                         {"line sink", TargetType::kLineSink, true, true, true, false},
                         {"shear", TargetType::kShear, true, true, true, false},
                         {"conveyor", TargetType::kConveyor, false, false, true, false}};
  const Known* k = nullptr;
  for (const Known& c : known)
    if (name == c.name) k = &c;
  if (!k)
    r.Fail(type,
           "sink, source, whirlpool, circle, saddle, line_sink, shear, conveyor (or csv: FILE)");
  g.type = k->type;
  const auto reject = [&](const char* key, bool allowed) {
    if (!allowed && t.node[key])
      r.Fail(r.Child(t, key), "no '" + std::string(key) + "' for a " + name + " target",
             "'" + std::string(key) + "'");
  };
  reject("center", k->center);
  reject("radius", k->radius);
  reject("direction", k->direction);
  reject("clockwise", k->clockwise);
  if (t.node["center"]) g.center = r.Vec2(r.Child(t, "center"));
  if (g.type == TargetType::kCircle)
    g.radius = r.Positive(r.Require(t, "radius", "the circle's radius (m) > 0"));
  else if (t.node["radius"])
    g.radius = r.Positive(r.Child(t, "radius"));
  if (g.type == TargetType::kConveyor) {
    const Field d = r.Require(t, "direction", "[dx, dy], not zero");
    g.direction = r.Vec2(d);
  } else if (t.node["direction"]) {
    g.direction = r.Vec2(r.Child(t, "direction"));
  }
  if (!(g.direction.norm() > 0.0)) r.Fail(r.Child(t, "direction"), "a non-zero [dx, dy]");
  g.direction.normalize();
  if (t.node["speed"]) g.speed = r.Positive(r.Child(t, "speed"));
  if (t.node["clockwise"]) g.clockwise = r.Bool(r.Child(t, "clockwise"));
}

void ReadMotion(const Reader& r, const Field& m, FieldDesignSpec* spec) {
  r.Map(m,
        {"frequency", "dofs", "max_vertical_acceleration", "vertical_peak",
         "max_linear_acceleration", "max_angular_acceleration"},
        "a map {frequency: Hz, dofs: {...}, max_vertical_acceleration: m/s^2, "
        "vertical_peak: bound|exact, max_linear_acceleration: m/s^2, "
        "max_angular_acceleration: rad/s^2}");
  spec->frequency = r.Positive(r.Require(m, "frequency", "the base frequency (Hz) > 0"));
  if (m.node["max_vertical_acceleration"])
    spec->max_vertical_acceleration = r.Positive(r.Child(m, "max_vertical_acceleration"));
  if (m.node["vertical_peak"]) {
    const Field v = r.Child(m, "vertical_peak");
    const std::string s = v.node.IsScalar() ? v.node.Scalar() : "";
    if (s != "bound" && s != "exact") r.Fail(v, "bound or exact");
    spec->exact_vertical_peak = s == "exact";
  }
  if (m.node["max_linear_acceleration"])
    spec->max_linear_acceleration = r.Positive(r.Child(m, "max_linear_acceleration"));
  if (m.node["max_angular_acceleration"])
    spec->max_angular_acceleration = r.Positive(r.Child(m, "max_angular_acceleration"));
  const Field dofs = r.Require(m, "dofs", "a map of plate DOFs (" + Join(kDofs) + ")");
  r.Map(dofs, kDofs, "a non-empty map of plate DOFs (" + Join(kDofs) + ")");
  if (dofs.node.size() == 0) r.Fail(dofs, "at least one DOF (" + Join(kDofs) + ")");
  for (const std::string& name : kDofs) {  // the scene file's order
    if (!dofs.node[name]) continue;
    const Field d = r.Child(dofs, name);
    // One harmonic (a map) or several (a list of maps with strictly increasing orders).
    std::vector<Field> items;
    if (d.node.IsSequence()) {
      if (d.node.size() == 0) r.Fail(d, "a non-empty list of harmonics {order, amplitude, phase}");
      for (std::size_t i = 0; i < d.node.size(); ++i) items.push_back(r.Item(d, i));
    } else {
      items.push_back(d);
    }
    int last_order = 0;
    for (const Field& h : items) {
      r.Map(h, {"order", "amplitude", "phase"},
            "a map {order: k, amplitude: [lo, hi], phase: [lo, hi]} or a list of them");
      DofRange range;
      range.dof = name;
      if (h.node["order"]) {
        const Field o = r.Child(h, "order");
        range.order = static_cast<int>(r.Integer(o, 1, 100));
        if (range.order <= last_order)
          r.Fail(o,
                 "harmonic orders strictly increasing within a DOF (> " +
                     std::to_string(last_order) + ")",
                 std::to_string(range.order));
      } else if (last_order >= 1) {
        r.Fail(h, "an 'order' (> " + std::to_string(last_order) + ") for a DOF's second harmonic");
      }
      last_order = range.order;
      const Field a = r.Require(h, "amplitude", "[lo, hi] (m or rad), or a number (fixed)");
      if (a.node.IsScalar())
        range.amplitude_lo = range.amplitude_hi = r.Number(a);
      else
        std::tie(range.amplitude_lo, range.amplitude_hi) = r.Range(a);
      if (h.node["phase"]) {
        const Field p = r.Child(h, "phase");
        if (p.node.IsScalar())
          range.phase_lo = range.phase_hi = r.Number(p);
        else
          std::tie(range.phase_lo, range.phase_hi) = r.Range(p);
      }
      spec->dofs.push_back(range);
    }
  }
}

void ReadGrid(const Reader& r, const Field& g, FieldDesignSpec* spec) {
  r.Map(g, {"x", "y", "points"}, "a map {x: [x0, x1], y: [y0, y1], points: [nx, ny]}");
  std::tie(spec->x_min, spec->x_max) = r.Range(r.Require(g, "x", "[x0, x1] (m)"));
  std::tie(spec->y_min, spec->y_max) = r.Range(r.Require(g, "y", "[y0, y1] (m)"));
  const Field p = r.Require(g, "points", "[nx, ny], integers >= 1");
  if (!p.node.IsSequence() || p.node.size() != 2) r.Fail(p, "[nx, ny], integers >= 1");
  spec->nx = static_cast<int>(
      r.Integer({p.node[0], p.name + "[0]", Reader::LineOf(p.node[0], p.line)}, 1, 1000));
  spec->ny = static_cast<int>(
      r.Integer({p.node[1], p.name + "[1]", Reader::LineOf(p.node[1], p.line)}, 1, 1000));
}

}  // namespace

Vector2d FieldTarget::At(const Vector2d& p) const {
  const Vector2d r = p - center;
  const auto perp = [](const Vector2d& v) { return Vector2d(-v.y(), v.x()); };  // ẑ × v
  const double sign = clockwise ? -1.0 : 1.0;
  switch (type) {
    case TargetType::kSink:
      return -speed * r / radius;
    case TargetType::kSource:
      return speed * r / radius;
    case TargetType::kWhirlpool:
      return sign * speed * perp(r) / radius;
    case TargetType::kCircle: {
      const double q = r.squaredNorm() / (radius * radius);  // (ρ/R)²
      return speed * (sign * perp(r) + (1.0 - q) / (1.0 + q) * r) / radius;
    }
    case TargetType::kSaddle: {
      const Vector2d n = perp(direction);
      return speed * (r.dot(direction) * direction - r.dot(n) * n) / radius;
    }
    case TargetType::kLineSink: {
      const Vector2d n = perp(direction);
      return -speed * r.dot(n) * n / radius;
    }
    case TargetType::kShear:
      return speed * r.dot(perp(direction)) * direction / radius;
    case TargetType::kConveyor:
      return speed * direction;
    case TargetType::kCsv:
      break;
  }
  throw std::invalid_argument("FieldTarget::At: a csv target has no formula");
}

int FieldTarget::Region(const Vector2d& p) const {
  if (type != TargetType::kCircle) return 0;
  return (p - center).squaredNorm() < radius * radius ? 0 : 1;
}

Vector2d GridPoint(const FieldDesignSpec& spec, int k) {
  const int i = k % spec.nx, j = k / spec.nx;
  const double x = spec.nx == 1 ? 0.5 * (spec.x_min + spec.x_max)
                                : spec.x_min + (spec.x_max - spec.x_min) * i / (spec.nx - 1);
  const double y = spec.ny == 1 ? 0.5 * (spec.y_min + spec.y_max)
                                : spec.y_min + (spec.y_max - spec.y_min) * j / (spec.ny - 1);
  return {x, y};
}

FieldDesignSpec ParseFieldDesignSpec(const std::string& text, const std::string& source_name,
                                     const std::string& base_dir) {
  const YAML::Node root = sim::LoadYamlDocument(text, source_name);
  const Reader r(source_name);
  const Field top{root, "", 1};
  if (!root || root.IsNull()) r.Fail({root, "(document)", 1}, "a field-design spec (a map)");
  r.Map(top, kTopKeys, "a field-design spec (a map)");
  FieldDesignSpec spec;
  spec.path = source_name;
  spec.scene_path = Resolve(base_dir, r.String(r.Require(top, "scene", "a plate scene file")));
  std::string csv_path;
  int csv_line = 0;
  ReadTarget(r, r.Require(top, "target", "a target field {type: ...} or {csv: FILE}"), base_dir,
             &spec, &csv_path, &csv_line);
  ReadMotion(r, r.Require(top, "motion", "the plate-motion parametrization"), &spec);
  ReadGrid(r, r.Require(top, "grid", "the grid {x: [x0, x1], y: [y0, y1], points: [nx, ny]}"),
           &spec);
  if (root["cycles"]) spec.cycles = static_cast<int>(r.Integer(r.Child(top, "cycles"), 1, 100000));
  spec.average_cycles = std::min(spec.average_cycles, spec.cycles);
  if (root["average_cycles"]) {
    const Field a = r.Child(top, "average_cycles");
    spec.average_cycles = static_cast<int>(r.Integer(a, 1, spec.cycles));
  }
  if (root["objective"]) {
    const Field o = r.Child(top, "objective");
    const std::string v = o.node.IsScalar() ? o.node.Scalar() : "";
    if (v != "shape" && v != "absolute") r.Fail(o, "shape or absolute");
    spec.absolute = v == "absolute";
  }
  if (root["tolerance"]) spec.tolerance = r.Positive(r.Child(top, "tolerance"));
  if (root["budget"]) spec.budget = static_cast<int>(r.Integer(r.Child(top, "budget"), 1, 1000000));
  if (root["seed"])
    spec.seed = static_cast<unsigned>(r.Integer(r.Child(top, "seed"), 0, 4294967295LL));
  if (!csv_path.empty()) {
    try {
      spec.target.velocities = ReadTargetCsv(csv_path, spec);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(source_name + ":" + std::to_string(csv_line) +
                                  ": target.csv: " + e.what());
    }
  }
  return spec;
}

FieldDesignSpec LoadFieldDesignSpec(const std::string& path) {
  const std::string text = sim::ReadInputFile(path, "the field-design spec");
  const std::size_t slash = path.find_last_of('/');
  return ParseFieldDesignSpec(text, path, slash == std::string::npos ? "." : path.substr(0, slash));
}

std::vector<Vector2d> ReadTargetCsv(const std::string& path, const FieldDesignSpec& spec) {
  std::istringstream in(sim::ReadInputFile(path, "the target CSV"));
  const auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::stringstream s(line);
    std::string c;
    while (std::getline(s, c, ',')) cells.push_back(c);
    return cells;
  };
  std::string line;
  if (!std::getline(in, line))
    throw std::invalid_argument(path + ":1: header: expected x,y,vx,vy columns, got nothing");
  const std::vector<std::string> header = split(line);
  int col[4] = {-1, -1, -1, -1};
  const char* names[4] = {"x", "y", "vx", "vy"};
  for (int c = 0; c < static_cast<int>(header.size()); ++c)
    for (int k = 0; k < 4; ++k)
      if (header[c] == names[k]) col[k] = c;
  for (int k = 0; k < 4; ++k)
    if (col[k] < 0)
      throw std::invalid_argument(path + ":1: header: expected a column '" + names[k] + "', got '" +
                                  line + "'");
  const int n = spec.nx * spec.ny;
  const double scale = std::max(spec.x_max - spec.x_min, spec.y_max - spec.y_min);
  std::vector<Vector2d> v;
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(line_no) + ": ";
    if (static_cast<int>(v.size()) == n)
      throw std::invalid_argument(where + "row: expected " + std::to_string(n) +
                                  " rows (the grid's points), got more");
    const std::vector<std::string> cells = split(line);
    double x[4];
    for (int k = 0; k < 4; ++k) {
      char* end = nullptr;
      const std::string cell = col[k] < static_cast<int>(cells.size()) ? cells[col[k]] : "";
      x[k] = std::strtod(cell.c_str(), &end);
      if (cell.empty() || *end != '\0' || !std::isfinite(x[k]))
        throw std::invalid_argument(where + names[k] + ": expected a finite number, got '" + cell +
                                    "'");
    }
    const Vector2d p = GridPoint(spec, static_cast<int>(v.size()));
    if (std::abs(x[0] - p.x()) > 1e-9 * std::max(scale, 1e-3) ||
        std::abs(x[1] - p.y()) > 1e-9 * std::max(scale, 1e-3)) {
      std::ostringstream s;
      s.precision(12);
      s << where << "x,y: expected the grid point (" << p.x() << ", " << p.y() << "), got (" << x[0]
        << ", " << x[1] << ")";
      throw std::invalid_argument(s.str());
    }
    v.emplace_back(x[2], x[3]);
  }
  if (static_cast<int>(v.size()) != n)
    throw std::invalid_argument(path + ":" + std::to_string(line_no) + ": rows: expected " +
                                std::to_string(n) + " (the grid's points), got " +
                                std::to_string(v.size()));
  return v;
}

}  // namespace vinci::planning
