#include "vinci/planning/field_design.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <nlopt.hpp>
#include <sstream>
#include <stdexcept>

#include "vinci/sim/model/scene_file.h"

namespace vinci::planning {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

// Numbers are written with 17 significant digits so that the scene reproduces the design.
YAML::Node Number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return YAML::Node(std::string(buf));
}

YAML::Node FlowPair(double a, double b) {
  YAML::Node n(YAML::NodeType::Sequence);
  n.push_back(Number(a));
  n.push_back(Number(b));
  n.SetStyle(YAML::EmitterStyle::Flow);
  return n;
}

// The harmonic node `index` of `dof` in the plate body's motion.
YAML::Node Harmonic(YAML::Node plate, const std::string& dof, int index) {
  return plate["motion"][dof]["harmonics"][index];
}

}  // namespace

namespace {

// The field error over the points `idx` alone (their own RMS speeds); adds their bad points.
double SubsetError(const sim::VelocityField& field, const std::vector<Vector2d>& target,
                   const std::vector<std::size_t>& idx, bool absolute, int* bad) {
  const double m = static_cast<double>(idx.size());
  double st2 = 0.0, sv2 = 0.0;
  for (std::size_t i : idx) {
    st2 += target[i].squaredNorm();
    const sim::FieldPoint& p = field.points[i];
    if (p.left_plate || p.failed)
      ++*bad;
    else
      sv2 += p.vx * p.vx + p.vy * p.vy;
  }
  const double st = std::sqrt(st2 / m), sv = std::sqrt(sv2 / m);
  if (!(st > 0.0))
    throw std::invalid_argument(
        "FieldError: expected a target field not zero everywhere (in every region)");
  double sum = 0.0;
  for (std::size_t i : idx) {
    const sim::FieldPoint& p = field.points[i];
    if (p.left_plate || p.failed) {
      sum += kBadPointMismatch * kBadPointMismatch;
      continue;
    }
    const Vector2d v(p.vx, p.vy);
    if (absolute)
      sum += (v - target[i]).squaredNorm() / st2 * m;  // (v − t)²/s_t²
    else
      sum += ((sv > 0.0 ? 1.0 / sv : 0.0) * v - target[i] / st).squaredNorm();
  }
  return sum / m;
}

}  // namespace

double FieldError(const sim::VelocityField& field, const std::vector<Vector2d>& target,
                  bool absolute, int* bad_points, const std::vector<int>& regions) {
  const std::size_t m = target.size();
  if (field.points.size() != m || m == 0)
    throw std::invalid_argument("FieldError: expected a field of " + std::to_string(m) +
                                " points (the target's), got " +
                                std::to_string(field.points.size()));
  if (!regions.empty() && regions.size() != m)
    throw std::invalid_argument("FieldError: expected a region label per point (" +
                                std::to_string(m) + "), got " + std::to_string(regions.size()));
  std::map<int, std::vector<std::size_t>> groups;  // region label -> its points
  for (std::size_t i = 0; i < m; ++i) groups[regions.empty() ? 0 : regions[i]].push_back(i);
  int bad = 0;
  double mean_square = 0.0;
  for (const auto& [label, idx] : groups)
    mean_square += SubsetError(field, target, idx, absolute, &bad);
  if (bad_points) *bad_points = bad;
  return std::sqrt(mean_square / static_cast<double>(groups.size()));
}

FieldDesignProblem::FieldDesignProblem(const FieldDesignSpec& spec) : spec_(spec) {
  const sim::Scene base = sim::LoadSceneFile(spec.scene_path);
  if (base.dim != sim::Dim::kSpatial)
    throw std::invalid_argument(spec.path +
                                ": scene: expected a spatial (dimension: 3) plate "
                                "scene, got a planar one '" +
                                spec.scene_path + "'");
  const sim::FieldSpec base_field = sim::LoadFieldSpec(spec.scene_path, base);
  const int plate = base_field.plate;

  // The scene file with the plate's motion replaced by the spec's DOFs.
  YAML::Node root = YAML::LoadFile(spec.scene_path);
  YAML::Node bodies = root["bodies"];
  if (!bodies.IsSequence() || static_cast<int>(bodies.size()) <= plate ||
      !bodies[plate]["name"].IsScalar() ||
      bodies[plate]["name"].Scalar() != base.bodies[plate].name)
    throw std::invalid_argument(spec.scene_path + ": cannot find the plate '" +
                                base.bodies[plate].name + "' at bodies[" + std::to_string(plate) +
                                "]");
  YAML::Node old_motion = bodies[plate]["motion"];
  YAML::Node motion(YAML::NodeType::Map);
  if (old_motion && old_motion["pose"]) motion["pose"] = old_motion["pose"];
  motion["frequency"] = Number(spec.frequency);
  for (const DofRange& d : spec.dofs) {
    YAML::Node h(YAML::NodeType::Map);
    h["order"] = d.order;
    h["amplitude"] = Number(0.5 * (d.amplitude_lo + d.amplitude_hi));
    h["phase"] = Number(0.5 * (d.phase_lo + d.phase_hi));
    h.SetStyle(YAML::EmitterStyle::Flow);
    if (!motion[d.dof]) motion[d.dof]["harmonics"] = YAML::Node(YAML::NodeType::Sequence);
    YAML::Node list = motion[d.dof]["harmonics"];
    harmonic_index_.push_back(static_cast<int>(list.size()));
    list.push_back(h);
  }
  bodies[plate]["motion"] = motion;
  YAML::Node field = root["field"];
  field.remove("frequency");
  YAML::Node grid(YAML::NodeType::Map);
  grid["x"] = FlowPair(spec.x_min, spec.x_max);
  grid["y"] = FlowPair(spec.y_min, spec.y_max);
  YAML::Node points(YAML::NodeType::Sequence);
  points.push_back(spec.nx);
  points.push_back(spec.ny);
  points.SetStyle(YAML::EmitterStyle::Flow);
  grid["points"] = points;
  field["grid"] = grid;
  field["cycles"] = spec.cycles;
  field["average_cycles"] = spec.average_cycles;
  YAML::Emitter out;
  out << root;
  scene_yaml_ = std::string(out.c_str()) + "\n";

  simulator_ = std::make_unique<sim::Simulator>(
      sim::ParseScene(scene_yaml_, spec.scene_path + " (with the field-design motion)"));
  const sim::Scene& scene = simulator_->scene();
  field_spec_ = base_field;
  field_spec_.frequency = spec.frequency;
  field_spec_.x_min = spec.x_min;
  field_spec_.x_max = spec.x_max;
  field_spec_.y_min = spec.y_min;
  field_spec_.y_max = spec.y_max;
  field_spec_.nx = spec.nx;
  field_spec_.ny = spec.ny;
  field_spec_.cycles = spec.cycles;
  field_spec_.average_cycles = spec.average_cycles;
  try {
    field_spec_.Validate(scene);  // grid points, steps per cycle and per point (limits)
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(spec.path + ": motion.frequency, grid, cycles: " + e.what());
  }

  const int m = spec.nx * spec.ny;
  if (spec.target.type == TargetType::kCsv) {
    target_ = spec.target.velocities;
    if (static_cast<int>(target_.size()) != m)
      throw std::invalid_argument(spec.path + ": target.csv: expected " + std::to_string(m) +
                                  " velocities, got " + std::to_string(target_.size()));
  } else {
    for (int k = 0; k < m; ++k) {
      target_.push_back(spec.target.At(GridPoint(spec, k)));
      regions_.push_back(spec.target.Region(GridPoint(spec, k)));
    }
    // one region only: the plain error (no labels)
    if (std::all_of(regions_.begin(), regions_.end(), [&](int r) { return r == regions_[0]; }))
      regions_.clear();
    std::map<int, double> region_t2;
    for (std::size_t k = 0; k < regions_.size(); ++k)
      region_t2[regions_[k]] += target_[k].squaredNorm();
    for (const auto& [label, t2] : region_t2)
      if (!(t2 > 0.0))
        throw std::invalid_argument(spec.path + ": target: expected grid points with a nonzero " +
                                    "target velocity on both sides of the circle (radius " +
                                    std::to_string(spec.target.radius) + "), got none " +
                                    (label == 0 ? "inside" : "outside"));
  }
  double t2 = 0.0;
  for (const Vector2d& t : target_) t2 += t.squaredNorm();
  if (!(t2 > 0.0))
    throw std::invalid_argument(spec.path +
                                ": target: expected a field not zero on the whole "
                                "grid, got zero everywhere");

  const sim::ParamTable& table = scene.param_table();
  defaults_ = table.Defaults();
  std::vector<double> lo, hi;
  const std::string& name = scene.bodies[plate].name;
  for (std::size_t r = 0; r < spec.dofs.size(); ++r) {
    const DofRange& d = spec.dofs[r];
    const std::string pre = "motion." + name + "." + d.dof + ".";
    const std::string k = std::to_string(harmonic_index_[r]);
    if (d.amplitude_lo < d.amplitude_hi) {
      names_.push_back(pre + "amplitude" + k);
      lo.push_back(d.amplitude_lo);
      hi.push_back(d.amplitude_hi);
    }
    if (d.phase_lo < d.phase_hi) {
      names_.push_back(pre + "phase" + k);
      lo.push_back(d.phase_lo);
      hi.push_back(d.phase_hi);
    }
  }
  for (const std::string& n : names_) indices_.push_back(table.Index(n));
  lower_ = Eigen::Map<const VectorXd>(lo.data(), static_cast<Eigen::Index>(lo.size()));
  upper_ = Eigen::Map<const VectorXd>(hi.data(), static_cast<Eigen::Index>(hi.size()));
}

sim::Params FieldDesignProblem::ParamsFor(const VectorXd& x) const {
  if (x.size() != static_cast<Eigen::Index>(indices_.size()))
    throw std::invalid_argument("FieldDesignProblem: expected " + std::to_string(indices_.size()) +
                                " free variables, got " + std::to_string(x.size()));
  sim::Params p = defaults_;
  for (std::size_t k = 0; k < indices_.size(); ++k) p.values[indices_[k]] = x[k];
  return p;
}

std::vector<FieldDesignProblem::DofValue> FieldDesignProblem::DofValues(const VectorXd& x) const {
  const sim::Params p = ParamsFor(x);
  const sim::ParamTable& table = simulator_->scene().param_table();
  const std::string& name = simulator_->scene().bodies[field_spec_.plate].name;
  std::vector<DofValue> out;
  for (std::size_t r = 0; r < spec_.dofs.size(); ++r) {
    const DofRange& d = spec_.dofs[r];
    const std::string pre = "motion." + name + "." + d.dof + ".";
    const std::string k = std::to_string(harmonic_index_[r]);
    out.push_back({d.dof, d.order, harmonic_index_[r], p.values[table.Index(pre + "amplitude" + k)],
                   p.values[table.Index(pre + "phase" + k)]});
  }
  return out;
}

VectorXd FieldDesignProblem::ParametersFromScene(const std::string& path) const {
  const sim::Scene scene = sim::LoadSceneFile(path);
  const std::string& name = simulator_->scene().bodies[field_spec_.plate].name;
  const std::string where = path + ": bodies." + name + ".motion: ";
  int plate = -1;
  for (std::size_t b = 0; b < scene.bodies.size(); ++b)
    if (scene.bodies[b].name == name) plate = static_cast<int>(b);
  if (plate < 0 || scene.bodies[plate].kind != sim::BodyKind::kPrescribed)
    throw std::invalid_argument(path + ": expected a prescribed body '" + name +
                                "' (the plate of " + spec_.path + "), got none");
  const sim::PrescribedMotion& motion = scene.bodies[plate].motion;
  if (!motion.tilt.IsZero())
    throw std::invalid_argument(where + "expected no tilt (the spec has none), got one");
  static const char* kDofs[] = {"x", "y", "z", "roll", "pitch", "yaw"};
  VectorXd x(static_cast<Eigen::Index>(names_.size()));
  Eigen::Index k = 0;
  const auto check = [&](const std::string& what, double value, double lo, double hi) {
    const double slack = 1e-12 * std::max({1.0, std::abs(lo), std::abs(hi)});
    if (!(value >= lo - slack && value <= hi + slack)) {
      std::ostringstream m;
      m.precision(17);
      m << where << what << ": expected ";
      if (lo == hi)
        m << lo << " (fixed by " << spec_.path << ")";
      else
        m << "a value in [" << lo << ", " << hi << "] (the bounds of " << spec_.path << ")";
      m << ", got " << value;
      throw std::invalid_argument(m.str());
    }
    if (lo < hi) x[k++] = std::clamp(value, lo, hi);
  };
  for (int d = 0; d < 6; ++d) {
    const std::string dof = kDofs[d];
    const sim::DofMotion none;
    const sim::DofMotion& m = d < static_cast<int>(motion.dofs.size()) ? motion.dofs[d] : none;
    std::vector<const DofRange*> ranges;
    for (const DofRange& r : spec_.dofs)
      if (r.dof == dof) ranges.push_back(&r);
    if (ranges.empty()) {
      bool zero = m.velocity == 0.0 && m.keyframes.empty();
      for (const sim::Harmonic& h : m.harmonics) zero = zero && h.amplitude == 0.0;
      if (!zero)
        throw std::invalid_argument(where + dof + ": expected no motion (the spec does not move " +
                                    dof + "), got one");
      continue;
    }
    std::ostringstream orders;
    for (std::size_t i = 0; i < ranges.size(); ++i)
      orders << (i ? ", " : "") << ranges[i]->order * spec_.frequency;
    bool family = m.velocity == 0.0 && m.keyframes.empty() && m.harmonics.size() == ranges.size();
    for (std::size_t i = 0; family && i < ranges.size(); ++i)
      family = std::abs(m.harmonics[i].frequency - ranges[i]->order * spec_.frequency) <=
               1e-12 * ranges[i]->order * spec_.frequency;
    if (!family)
      throw std::invalid_argument(where + dof + ": expected " + std::to_string(ranges.size()) +
                                  " harmonic(s) at the spec's " + orders.str() +
                                  " Hz in that order and no velocity or keyframes");
    for (std::size_t i = 0; i < ranges.size(); ++i) {
      const std::string h = ranges.size() > 1 ? "[" + std::to_string(i) + "]" : "";
      check(dof + h + ".amplitude", m.harmonics[i].amplitude, ranges[i]->amplitude_lo,
            ranges[i]->amplitude_hi);
      check(dof + h + ".phase", m.harmonics[i].phase, ranges[i]->phase_lo, ranges[i]->phase_hi);
    }
  }
  return x;
}

double FieldDesignProblem::PeakVerticalAcceleration(const VectorXd& x) const {
  const double w2 = std::pow(2.0 * kPi * spec_.frequency, 2);
  if (spec_.exact_vertical_peak) {
    // a_n(t, p) = Σ −(2πkf)² A sin(2πkft + φ) c, c = 1 (z), y (roll), −x (pitch): affine in p,
    // so its extremes over the grid's rectangle are at the corners; one base period sampled
    // finely (the samples miss at most a relative 1 − cos(π k_max / kSamples) of a peak).
    constexpr int kSamples = 4096;
    const std::vector<DofValue> values = DofValues(x);
    double peak = 0.0;
    for (const double px : {spec_.x_min, spec_.x_max})
      for (const double py : {spec_.y_min, spec_.y_max})
        for (int i = 0; i < kSamples; ++i) {
          const double phase = 2.0 * kPi * i / kSamples;  // 2πft over one base period
          double a = 0.0;
          for (const DofValue& d : values) {
            const double c = d.dof == "z" ? 1.0 : d.dof == "roll" ? py : d.dof == "pitch" ? -px : 0;
            a -= static_cast<double>(d.order) * d.order * d.amplitude * c *
                 std::sin(d.order * phase + d.phase);
          }
          peak = std::max(peak, std::abs(a));
        }
    return w2 * peak;
  }
  const double max_x = std::max(std::abs(spec_.x_min), std::abs(spec_.x_max));
  const double max_y = std::max(std::abs(spec_.y_min), std::abs(spec_.y_max));
  double a = 0.0;
  for (const DofValue& d : DofValues(x)) {
    const double k2 = static_cast<double>(d.order) * d.order;  // (2πkf)² for the k-th harmonic
    if (d.dof == "z") a += k2 * std::abs(d.amplitude);
    if (d.dof == "roll") a += k2 * std::abs(d.amplitude) * max_y;
    if (d.dof == "pitch") a += k2 * std::abs(d.amplitude) * max_x;
  }
  return w2 * a;
}

namespace {

// max over `dofs` of Σ over that DOF's harmonics (2πkf)² |A|.
double PeakDofAcceleration(const std::vector<FieldDesignProblem::DofValue>& values,
                           std::initializer_list<const char*> dofs, double frequency) {
  double peak = 0.0;
  for (const char* dof : dofs) {
    double a = 0.0;
    for (const FieldDesignProblem::DofValue& d : values)
      if (d.dof == dof) a += std::pow(2.0 * kPi * d.order * frequency, 2) * std::abs(d.amplitude);
    peak = std::max(peak, a);
  }
  return peak;
}

}  // namespace

double FieldDesignProblem::PeakLinearAcceleration(const VectorXd& x) const {
  return PeakDofAcceleration(DofValues(x), {"x", "y"}, spec_.frequency);
}

double FieldDesignProblem::PeakAngularAcceleration(const VectorXd& x) const {
  return PeakDofAcceleration(DofValues(x), {"roll", "pitch", "yaw"}, spec_.frequency);
}

FieldEvaluation FieldDesignProblem::Evaluate(const VectorXd& x, int threads) const {
  const Clock::time_point start = Clock::now();
  FieldEvaluation e;
  e.x = x;
  e.peak_vertical_acceleration = PeakVerticalAcceleration(x);
  e.peak_linear_acceleration = PeakLinearAcceleration(x);
  e.peak_angular_acceleration = PeakAngularAcceleration(x);
  double excess = 0.0;  // the largest relative excess over a limit
  const std::pair<double, double> limits[] = {
      {e.peak_vertical_acceleration, spec_.max_vertical_acceleration},
      {e.peak_linear_acceleration, spec_.max_linear_acceleration},
      {e.peak_angular_acceleration, spec_.max_angular_acceleration}};
  for (const auto& [peak, limit] : limits)
    if (peak > limit) {
      e.feasible = false;
      excess = std::max(excess, (peak - limit) / limit);
    }
  if (!e.feasible) {
    e.error = kInfeasibleError + excess;
  } else {
    sim::FieldOptions options;
    options.threads = threads;
    e.field = sim::ComputeVelocityField(*simulator_, ParamsFor(x), field_spec_, options);
    e.error = FieldError(e.field, target_, spec_.absolute, &e.bad_points, regions_);
  }
  e.time_s = Seconds(Clock::now() - start);
  return e;
}

std::string FieldDesignProblem::SceneYaml(const VectorXd& x) const {
  YAML::Node root = YAML::Load(scene_yaml_);
  YAML::Node plate = root["bodies"][field_spec_.plate];
  for (const DofValue& d : DofValues(x)) {
    YAML::Node h = Harmonic(plate, d.dof, d.index);
    h["amplitude"] = Number(d.amplitude);
    h["phase"] = Number(d.phase);
  }
  YAML::Emitter out;
  out << root;
  return "# Written by vinci field-design from " + spec_.path + "\n" + out.c_str() + "\n";
}

namespace {

// The search state shared by the NLopt callbacks.
struct Search {
  const FieldDesignProblem* problem = nullptr;
  const FieldDesignOptions* options = nullptr;
  FieldDesignResult* result = nullptr;
  std::string phase;
  int left = 0;        // evaluations left in the whole budget
  int phase_left = 0;  // in this phase
  bool stop = false;
  bool have_best = false;

  // Variables are searched in the unit box; x = lower + u (upper − lower). A phase whose range
  // is the whole circle is periodic: u is taken modulo 1, so the local phase may step across its
  // bounds (BOBYQA would otherwise move a start point closer than its initial step to a bound).
  VectorXd FromUnit(const double* u) const {
    const VectorXd& lo = problem->lower();
    VectorXd x = lo;
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double uk = Periodic(k) ? u[k] - std::floor(u[k]) : std::clamp(u[k], 0.0, 1.0);
      x[k] = lo[k] + uk * (problem->upper()[k] - lo[k]);
    }
    return x;
  }
  bool Periodic(Eigen::Index k) const {
    const std::string& name = problem->names()[k];
    return name.size() > 6 && name.compare(name.size() - 6, 6, "phase0") == 0 &&
           problem->upper()[k] - problem->lower()[k] >= 2.0 * kPi - 1e-6;
  }

  double Evaluate(const VectorXd& x) {
    FieldEvaluation e = problem->Evaluate(x, options->threads);
    e.index = ++result->evaluations;
    e.phase = phase;
    --left;
    --phase_left;
    const double error = e.error;
    if (!have_best || e.error < result->best.error) {
      result->best = e;
      have_best = true;
    }
    if (options->on_evaluation) options->on_evaluation(e);
    if (result->best.error <= problem->spec().tolerance) stop = true;
    return error;
  }
};

double NloptObjective(unsigned n, const double* u, double* grad, void* data) {
  auto* d = static_cast<std::pair<nlopt::opt*, Search*>*>(data);
  Search* s = d->second;
  if (grad) std::fill(grad, grad + n, 0.0);             // derivative-free algorithms only
  if (s->stop || s->left <= 0 || s->phase_left <= 0) {  // some algorithms overrun maxeval
    d->first->set_force_stop(1);
    return HUGE_VAL;
  }
  try {
    const double error = s->Evaluate(s->FromUnit(u));
    if (s->stop) d->first->set_force_stop(1);
    return std::isfinite(error) ? error : HUGE_VAL;
  } catch (const std::exception& e) {
    s->result->errors.push_back(s->phase + ": " + e.what());
  } catch (...) {
    s->result->errors.push_back(s->phase + ": unknown exception");
  }
  s->stop = true;
  d->first->set_force_stop(1);
  return HUGE_VAL;
}

void RunPhase(nlopt::algorithm algorithm, const std::string& phase, int evals, const VectorXd& u0,
              Search* s) {
  if (evals < 1 || s->stop || s->left <= 0) return;
  const unsigned n = static_cast<unsigned>(u0.size());
  s->phase = phase;
  s->phase_left = std::min(evals, s->left);
  nlopt::opt opt(algorithm, n);
  std::vector<double> lo(n, 0.0), hi(n, 1.0);
  if (phase == "local")
    for (unsigned k = 0; k < n; ++k)
      if (s->Periodic(k)) {
        lo[k] = -1.0;
        hi[k] = 2.0;
      }
  opt.set_lower_bounds(lo);
  opt.set_upper_bounds(hi);
  opt.set_maxeval(s->phase_left);
  opt.set_stopval(s->problem->spec().tolerance);
  if (phase == "local") {
    opt.set_initial_step(std::vector<double>(n, 0.1));
    opt.set_xtol_rel(1e-6);
  }
  std::pair<nlopt::opt*, Search*> data(&opt, s);
  opt.set_min_objective(NloptObjective, &data);
  std::vector<double> u(u0.data(), u0.data() + n);
  double f = 0.0;
  try {
    opt.optimize(u, f);
  } catch (const nlopt::roundoff_limited&) {
    // Converged as far as floating point allows; the best point is kept by Search.
  } catch (const nlopt::forced_stop&) {
    // Tolerance reached, budget spent or a callback failed (recorded by the callback).
  } catch (const std::exception& e) {
    s->result->errors.push_back(phase + ": nlopt: " + e.what());
  }
}

}  // namespace

FieldDesignResult DesignField(const FieldDesignProblem& problem,
                              const FieldDesignOptions& options) {
  if (options.budget < 1)
    throw std::invalid_argument("budget: expected an integer >= 1, got " +
                                std::to_string(options.budget));
  if (options.threads < 1)
    throw std::invalid_argument("threads: expected an integer >= 1, got " +
                                std::to_string(options.threads));
  if (!(options.global_fraction >= 0.0 && options.global_fraction <= 1.0))
    throw std::invalid_argument("global_fraction: expected a number in [0, 1]");
  const Clock::time_point start = Clock::now();
  FieldDesignResult result;
  Search s;
  s.problem = &problem;
  s.options = &options;
  s.result = &result;
  s.left = options.budget;
  const int n = static_cast<int>(problem.names().size());
  // The start point: options.start or the middle of the box (the only point when nothing is free).
  const VectorXd x0 = options.start.size() ? options.start : problem.Start();
  if (x0.size() != static_cast<Eigen::Index>(n) ||
      !((x0.array() >= problem.lower().array()).all() &&
        (x0.array() <= problem.upper().array()).all()))
    throw std::invalid_argument("start: expected " + std::to_string(n) +
                                " free variables within their bounds");
  s.phase = "start";
  s.phase_left = 1;
  try {
    s.Evaluate(x0);
  } catch (const std::exception& e) {
    result.errors.push_back(std::string("start: ") + e.what());
    s.stop = true;
  }
  if (n > 0 && !s.stop) {
    nlopt::srand(options.seed);
    const int global = static_cast<int>(std::lround(options.global_fraction * (s.left)));
    VectorXd u0(n);
    for (int k = 0; k < n; ++k)
      u0[k] = (x0[k] - problem.lower()[k]) / (problem.upper()[k] - problem.lower()[k]);
    RunPhase(nlopt::GN_CRS2_LM, "global", global, u0, &s);
    VectorXd u_best = u0;
    for (int k = 0; k < n; ++k) {
      const double range = problem.upper()[k] - problem.lower()[k];
      u_best[k] = (result.best.x[k] - problem.lower()[k]) / range;
    }
    RunPhase(n >= 2 ? nlopt::LN_BOBYQA : nlopt::LN_SBPLX, "local", s.left, u_best, &s);
  }
  result.time_s = Seconds(Clock::now() - start);
  result.reached_tolerance = s.have_best && result.best.error <= problem.spec().tolerance;
  return result;
}

}  // namespace vinci::planning
