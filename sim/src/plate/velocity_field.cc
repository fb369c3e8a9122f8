#include "vinci/sim/plate/velocity_field.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <optional>
#include <ostream>
#include <stdexcept>

#include "../model/yaml_load.h"
#include "vinci/sim/model/kinematics.h"
#include "vinci/sim/simulator/batch.h"
#include "vinci/sim/solvers/input_file.h"

namespace vinci::sim {
namespace {
std::string FormatNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}
}  // namespace

void FieldSpec::Validate(const Scene& scene) const {
  const int n = static_cast<int>(scene.bodies.size());
  if (plate < 0 || plate >= n || scene.bodies[plate].kind != BodyKind::kPrescribed)
    throw std::invalid_argument("field.plate: expected a prescribed body");
  if (part < 0 || part >= n || scene.bodies[part].kind != BodyKind::kDynamic)
    throw std::invalid_argument("field.part: expected a dynamic body");
  if (!(frequency > 0.0) || !std::isfinite(frequency))
    throw std::invalid_argument("field.frequency: expected a finite number > 0 (Hz), got " +
                                FormatNumber(frequency));
  if (!(x_min <= x_max) || !(y_min <= y_max))
    throw std::invalid_argument("field.grid: expected min <= max on each axis");
  // [-1e308, 1e308] has an infinite width: every grid point would be NaN (issue 18, finding 3).
  if (!std::isfinite(x_max - x_min) || !std::isfinite(y_max - y_min))
    throw std::invalid_argument("field.grid: expected a finite width max - min on each axis");
  if (nx < 1 || ny < 1)
    throw std::invalid_argument("field.grid.points: expected at least 1 point per axis");
  if (static_cast<long long>(nx) * ny > kMaxFieldPoints)
    throw std::invalid_argument("field.grid.points: expected at most " +
                                std::to_string(kMaxFieldPoints) + " points, got " +
                                std::to_string(nx) + " x " + std::to_string(ny) + " = " +
                                std::to_string(static_cast<long long>(nx) * ny));
  if (scene.dim == Dim::kPlanar && ny != 1)
    throw std::invalid_argument("field.grid.points: expected 1 row in a planar scene");
  if (cycles < 1) throw std::invalid_argument("field.cycles: expected an integer >= 1");
  if (average_cycles < 1 || average_cycles > cycles)
    throw std::invalid_argument(
        "field.average_cycles: expected an integer in [1, cycles = " + std::to_string(cycles) +
        "], got " + std::to_string(average_cycles));
  const long long per_cycle = StepsPerCycle(scene.options.dt);
  if (per_cycle * cycles > kMaxFieldStepsPerPoint)
    throw std::invalid_argument("field.cycles: expected at most " +
                                std::to_string(kMaxFieldStepsPerPoint) + " steps per point, got " +
                                std::to_string(cycles) + " cycles x " + std::to_string(per_cycle) +
                                " steps per cycle = " + std::to_string(per_cycle * cycles));
}

int FieldSpec::StepsPerCycle(double h) const {
  const double steps = std::round(1.0 / (frequency * h));  // T/h, in double: no int overflow
  char buf[160];
  if (!(steps >= 1.0) || !(steps <= static_cast<double>(kMaxFieldStepsPerPoint))) {
    std::snprintf(buf, sizeof buf, "T/dt = 1/(%g Hz * %g s) = %g steps per cycle", frequency, h,
                  1.0 / (frequency * h));
    throw std::invalid_argument(std::string("field.frequency: expected between 1 and ") +
                                std::to_string(kMaxFieldStepsPerPoint) +
                                " time steps per plate cycle, got " + buf);
  }
  return static_cast<int>(steps);
}

namespace {

// Running sums of the part's plate-frame velocity over a set of steps.
struct Sums {
  Vector3d v = Vector3d::Zero();  // plate-frame velocity
  Vector3d p = Vector3d::Zero();  // plate-frame position
  double w = 0.0;                 // angular velocity about the normal
  int n = 0;
  void Add(const Vector3d& vp, const Vector3d& pp, double wn) {
    v += vp;
    p += pp;
    w += wn;
    ++n;
  }
};

}  // namespace

FieldPoint ComputeFieldPoint(const Simulator& sim, const Params& params, const FieldSpec& spec,
                             double x, double y) {
  Workspace ws;
  return ComputeFieldPoint(sim, params, spec, x, y, &ws);
}

FieldPoint ComputeFieldPoint(const Simulator& sim, const Params& params, const FieldSpec& spec,
                             double x, double y, Workspace* ws) {
  if (!ws) throw std::invalid_argument("ComputeFieldPoint: null workspace");
  const Scene& scene = sim.scene();
  const bool planar = scene.dim == Dim::kPlanar;
  const Body& plate = scene.bodies[spec.plate];
  const Body& part = scene.bodies[spec.part];
  const Isometry3d& X_WP = plate.X_WB0;  // the plate's initial frame P
  const Isometry3d X_PW = X_WP.inverse();
  const Matrix3d R_PW = X_WP.linear().transpose();
  const Vector3d n_P = planar ? Vector3d::UnitY() : Vector3d::UnitZ();
  const double h = scene.options.dt;
  const int per_cycle = spec.StepsPerCycle(h);
  const int total = per_cycle * spec.cycles;
  const int window_start = per_cycle * (spec.cycles - spec.average_cycles);

  FieldPoint out;
  out.x = x;
  out.y = planar ? 0.0 : y;
  // Place the part: keep its pose relative to the plate except the in-plane position.
  Isometry3d X_PB = X_PW * part.X_WB0;
  X_PB.translation().x() = x;
  if (!planar) X_PB.translation().y() = y;
  State s = sim.InitialState();
  const BodyIndex& idx = scene.index(spec.part);
  PoseToQ(scene.dim, X_WP * X_PB, s.q.data() + idx.q);

  const StepInput u;
  Sums window, cycle, last_cycle;
  State next;
  for (int k = 0; k < total; ++k) {
    const StepInfo info = sim.Step(params, s, u, ws, &next);
    if (!info.ok) {
      out.failed = true;
      out.failure =
          "step " + std::to_string(k) + " (t = " + std::to_string(s.t) + " s): " + info.failure;
      break;
    }
    std::swap(s, next);
    const BodyKinematics kin = KinematicsFromQV(scene.dim, s.q.data() + idx.q, s.v.data() + idx.v);
    const Vector3d v_P = R_PW * kin.v_WB;
    const double w_n = (R_PW * kin.w_WB).dot(n_P);
    const Vector3d p_P = X_PW * kin.X_WB.translation();
    if (k >= window_start) window.Add(v_P, p_P, w_n);
    cycle.Add(v_P, p_P, w_n);
    if (cycle.n == per_cycle) {
      last_cycle = cycle;
      cycle = Sums{};
    }
    if (p_P.x() < spec.plate_x_min || p_P.x() > spec.plate_x_max ||
        (!planar && (p_P.y() < spec.plate_y_min || p_P.y() > spec.plate_y_max))) {
      out.left_plate = true;
      break;
    }
  }
  // The averaging window actually used (see the header).
  const Sums* use = &window;
  Sums all = window;
  if (window.n == 0) {
    if (last_cycle.n > 0) {
      use = &last_cycle;
    } else {
      all = cycle;
      use = &all;
    }
  }
  if (use->n > 0) {
    out.vx = use->v.x() / use->n;
    out.vy = use->v.y() / use->n;
    out.omega = use->w / use->n;
    out.x_mean = use->p.x() / use->n;
    out.y_mean = planar ? 0.0 : use->p.y() / use->n;
    out.averaged_time = use->n * h;
  } else {
    out.vx = out.vy = out.omega = out.x_mean = out.y_mean = std::nan("");
  }
  return out;
}

Vector2d FieldGridPoint(const FieldSpec& spec, int i) {
  const auto coord = [](double lo, double hi, int n, int k) {
    return n == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * k / (n - 1);
  };
  return Vector2d(coord(spec.x_min, spec.x_max, spec.nx, i % spec.nx),
                  coord(spec.y_min, spec.y_max, spec.ny, i / spec.nx));
}

VelocityField ComputeVelocityField(const Simulator& sim, const Params& params,
                                   const FieldSpec& spec, const FieldOptions& options) {
  spec.Validate(sim.scene());
  if (options.threads < 1)
    throw std::invalid_argument("field: threads must be >= 1, got " +
                                std::to_string(options.threads));
  VelocityField field;
  field.spec = spec;
  const int total = spec.nx * spec.ny;
  BatchOptions batch;
  batch.threads = options.threads;
  batch.progress = options.progress;
  batch.stop_on_error = true;  // an exception is bad input: report the first point's and stop
  // Each point is a pure function of (sim, params, spec, x, y); the workspace only caches the
  // resolved scene.
  auto results = BatchMap<Workspace>(
      total,
      [&](int i, Workspace& ws) {
        const Vector2d p = FieldGridPoint(spec, i);
        return ComputeFieldPoint(sim, params, spec, p.x(), p.y(), &ws);
      },
      batch);
  RethrowFirstError(results);  // the lowest-index failure, as a single thread would report it
  field.points.reserve(results.size());
  for (auto& r : results) field.points.push_back(std::move(r.value));
  for (const FieldPoint& p : field.points) {
    field.left_plate += p.left_plate ? 1 : 0;
    field.failed += p.failed ? 1 : 0;
  }
  return field;
}

void WriteFieldCsv(const VelocityField& field, std::ostream& out) {
  out << "x,y,vx,vy,omega,left_plate,failed,x_mean,y_mean\n";
  char buf[256];
  for (const FieldPoint& p : field.points) {
    std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%d,%d,%.17g,%.17g\n", p.x, p.y,
                  p.vx, p.vy, p.omega, p.left_plate ? 1 : 0, p.failed ? 1 : 0, p.x_mean, p.y_mean);
    out << buf;
  }
}

// ----- the `field:` section --------------------------------------------------------------------
namespace {

class FieldParser {
 public:
  FieldParser(std::string path, const Scene& scene) : path_(std::move(path)), scene_(scene) {}

  [[noreturn]] void Fail(const YAML::Node& n, const std::string& key, const std::string& expected,
                         const std::string& got = "") const {
    const int line = n.Mark().is_null() ? 1 : n.Mark().line + 1;
    std::string g = got;
    if (g.empty())
      g = n.IsScalar() ? "'" + n.Scalar() + "'"
          : n.IsNull() ? "nothing"
                       : "a " + std::string(n.IsMap() ? "map" : "list");
    throw std::invalid_argument(path_ + ":" + std::to_string(line) + ": " + key + ": expected " +
                                expected + ", got " + g);
  }

  void CheckKeys(const YAML::Node& n, const std::string& key,
                 const std::vector<std::string>& allowed) const {
    if (!n.IsMap()) Fail(n, key, "a map");
    for (const auto& kv : n) {
      const std::string k = kv.first.Scalar();
      bool ok = false;
      for (const std::string& a : allowed) ok = ok || a == k;
      if (!ok) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        Fail(kv.first, key + "." + k, "one of the keys " + list, "unknown key '" + k + "'");
      }
    }
  }

  double Number(const YAML::Node& n, const std::string& key, bool positive) const {
    const std::string what = positive ? "a finite number > 0" : "a finite number";
    double x = 0.0;
    if (!n.IsScalar() || !YAML::convert<double>::decode(n, x) || !std::isfinite(x) ||
        (positive && !(x > 0.0)))
      Fail(n, key, what);
    return x;
  }

  int Integer(const YAML::Node& n, const std::string& key, int lo) const {
    const std::string what = "an integer >= " + std::to_string(lo);
    long long x = 0;
    if (!n.IsScalar() || !YAML::convert<long long>::decode(n, x) || x < lo || x > 100000000)
      Fail(n, key, what);
    return static_cast<int>(x);
  }

  void Range(const YAML::Node& n, const std::string& key, double* lo, double* hi) const {
    const std::string what = "a list [min, max] with min <= max and a finite width max - min (m)";
    if (!n.IsSequence() || n.size() != 2) Fail(n, key, what);
    *lo = Number(n[0], key + "[0]", false);
    *hi = Number(n[1], key + "[1]", false);
    if (!(*lo <= *hi) || !std::isfinite(*hi - *lo))
      Fail(n, key, what, "[" + n[0].Scalar() + ", " + n[1].Scalar() + "]");
  }

  int Body(const YAML::Node& n, const std::string& key, BodyKind kind) const {
    const char* kname = kind == BodyKind::kPrescribed ? "prescribed" : "dynamic";
    std::string names;
    for (const auto& b : scene_.bodies)
      if (b.kind == kind) names += (names.empty() ? "" : ", ") + b.name;
    const std::string what = std::string("the name of a ") + kname + " body (" +
                             (names.empty() ? "the scene has none" : names) + ")";
    if (!n.IsScalar()) Fail(n, key, what);
    const int b = scene_.FindBody(n.Scalar());
    if (b < 0 || scene_.bodies[b].kind != kind) Fail(n, key, what);
    return b;
  }

  FieldSpec Parse(const YAML::Node& root) const {
    const YAML::Node f = root["field"];
    if (!f) {
      throw std::invalid_argument(path_ +
                                  ":1: field: expected a 'field:' section naming the "
                                  "plate, the part and the grid (docs/field.md), got nothing");
    }
    const bool planar = scene_.dim == Dim::kPlanar;
    CheckKeys(f, "field",
              {"plate", "part", "frequency", "grid", "plate_extent", "cycles", "average_cycles"});
    FieldSpec s;
    if (!f["plate"]) Fail(f, "field.plate", "the name of a prescribed body", "nothing");
    if (!f["part"]) Fail(f, "field.part", "the name of a dynamic body", "nothing");
    s.plate = Body(f["plate"], "field.plate", BodyKind::kPrescribed);
    s.part = Body(f["part"], "field.part", BodyKind::kDynamic);
    const PrescribedMotion& m = scene_.bodies[s.plate].motion;
    if (f["frequency"]) {
      s.frequency = Number(f["frequency"], "field.frequency", true);
    } else if (m.base_frequency > 0.0) {
      s.frequency = m.base_frequency;
    } else if (!m.tilt.IsZero() && m.tilt.frequency > 0.0) {
      s.frequency = m.tilt.frequency;
    } else {
      Fail(f, "field.frequency", "a frequency > 0 (Hz), here or as the plate motion's 'frequency'",
           "nothing");
    }
    const YAML::Node g = f["grid"];
    if (!g) Fail(f, "field.grid", "a map {x: [min, max], y: [min, max], points: ...}", "nothing");
    CheckKeys(g, "field.grid",
              planar ? std::vector<std::string>{"x", "points"}
                     : std::vector<std::string>{"x", "y", "points"});
    if (!g["x"]) Fail(g, "field.grid.x", "a list [min, max] (m)", "nothing");
    Range(g["x"], "field.grid.x", &s.x_min, &s.x_max);
    if (planar) {
      s.y_min = s.y_max = 0.0;
      s.ny = 1;
      if (g["points"]) s.nx = Integer(g["points"], "field.grid.points", 1);
    } else {
      if (!g["y"]) Fail(g, "field.grid.y", "a list [min, max] (m)", "nothing");
      Range(g["y"], "field.grid.y", &s.y_min, &s.y_max);
      if (const YAML::Node p = g["points"]) {
        if (!p.IsSequence() || p.size() != 2)
          Fail(p, "field.grid.points", "a list [nx, ny] of integers >= 1");
        s.nx = Integer(p[0], "field.grid.points[0]", 1);
        s.ny = Integer(p[1], "field.grid.points[1]", 1);
      }
    }
    if (const YAML::Node e = f["plate_extent"]) {
      CheckKeys(e, "field.plate_extent",
                planar ? std::vector<std::string>{"x"} : std::vector<std::string>{"x", "y"});
      if (e["x"]) Range(e["x"], "field.plate_extent.x", &s.plate_x_min, &s.plate_x_max);
      if (e["y"]) Range(e["y"], "field.plate_extent.y", &s.plate_y_min, &s.plate_y_max);
    }
    if (f["cycles"]) s.cycles = Integer(f["cycles"], "field.cycles", 1);
    if (f["average_cycles"]) {
      s.average_cycles = Integer(f["average_cycles"], "field.average_cycles", 1);
      if (s.average_cycles > s.cycles)
        Fail(f["average_cycles"], "field.average_cycles",
             "an integer <= cycles (" + std::to_string(s.cycles) + ")");
    } else {
      s.average_cycles = std::min(s.average_cycles, s.cycles);
    }
    return s;
  }

 private:
  std::string path_;
  const Scene& scene_;
};

}  // namespace

FieldSpec LoadFieldSpec(const std::string& path, const Scene& scene) {
  const std::vector<YAML::Node> docs =
      internal::LoadYamlDocuments(ReadInputFile(path, "scene file"), path);
  const YAML::Node root = docs.empty() ? YAML::Node() : docs[0];
  if (!root.IsMap()) throw std::invalid_argument(path + ":1: expected a scene: a map");
  return FieldParser(path, scene).Parse(root);
}

}  // namespace vinci::sim
