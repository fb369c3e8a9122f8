#include "vinci/planning/plan.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <ostream>
#include <stdexcept>

#include "vinci/planning/plan_ompl.h"
#include "vinci/sim/model/motion_input.h"
#include "vinci/sim/model/scene_file.h"
#include "vinci/sim/model/state_util.h"

namespace vinci::planning {
namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

std::string Where(const PlanSpec& spec, int line) {
  return spec.path + ":" + std::to_string(line) + ": ";
}

double Yaw(const sim::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

sim::Matrix3d Rz(double a) {
  return Eigen::AngleAxisd(a, sim::Vector3d::UnitZ()).toRotationMatrix();
}

void AppendNumber(double v, std::string* s) {
  char buf[32];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  s->append(buf, res.ptr);
}

}  // namespace

PlanProblem::PlanProblem(const PlanSpec& spec) : spec_(spec) {
  if (spec.primitives.empty() || spec.goals.empty() || spec.min_cycles < 1 ||
      spec.min_cycles > spec.max_cycles || spec.settle_cycles < 0 || !(spec.x_min < spec.x_max) ||
      !(spec.y_min < spec.y_max))
    throw std::invalid_argument(spec.path +
                                ": expected primitives, goals, 1 <= cycles min <= max, "
                                "settle_cycles >= 0 and a plate extent with lo < hi");
  sim::Scene scene = sim::LoadSceneFile(spec.scene_path);
  if (scene.dim != sim::Dim::kSpatial)
    throw std::invalid_argument(
        spec.path + ": scene: expected a spatial (dimension: 3) plate scene, got a planar one '" +
        spec.scene_path + "'");
  // The plate.
  if (!spec.plate.empty()) {
    try {
      plate_ = sim::BodyIndexByName(scene, spec.plate);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(Where(spec, spec.plate_line) + "plate: " + e.what());
    }
    if (scene.bodies[plate_].kind != sim::BodyKind::kPrescribed)
      throw std::invalid_argument(Where(spec, spec.plate_line) +
                                  "plate: expected a prescribed body, got '" + spec.plate + "'");
  } else {
    for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
      if (scene.bodies[b].kind != sim::BodyKind::kPrescribed) continue;
      if (plate_ >= 0)
        throw std::invalid_argument(spec.path +
                                    ": plate: expected the name of the plate (the scene has "
                                    "several prescribed bodies), got nothing");
      plate_ = static_cast<int>(b);
    }
    if (plate_ < 0)
      throw std::invalid_argument(spec.path + ": scene: expected a prescribed plate body in '" +
                                  spec.scene_path + "', got none");
  }
  // The parts: every dynamic body, each with a goal.
  for (const PartGoal& g : spec.goals) {
    int b = -1;
    try {
      b = sim::BodyIndexByName(scene, g.part);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(Where(spec, g.line) + "goal." + g.part + ": " + e.what());
    }
    if (scene.bodies[b].kind != sim::BodyKind::kDynamic)
      throw std::invalid_argument(
          Where(spec, g.line) + "goal." + g.part + ": expected a dynamic body (a part), got a " +
          (scene.bodies[b].kind == sim::BodyKind::kStatic ? "static" : "prescribed") + " one");
    parts_.push_back(b);
  }
  for (std::size_t b = 0; b < scene.bodies.size(); ++b) {
    if (scene.bodies[b].kind != sim::BodyKind::kDynamic) continue;
    bool found = false;
    for (int p : parts_) found = found || p == static_cast<int>(b);
    if (!found)
      throw std::invalid_argument(Where(spec, spec.goal_line) +
                                  "goal: expected a goal for every part (dynamic body), got none "
                                  "for '" +
                                  scene.bodies[b].name + "'");
  }
  X_WP_ = scene.bodies[plate_].X_WB0;
  for (int p : parts_) {
    const sim::Isometry3d X_PB = X_WP_.inverse() * scene.bodies[p].X_WB0;
    height_.push_back(X_PB.translation().z());
    const sim::Matrix3d R = X_PB.linear();
    tilt_.push_back(Rz(-Yaw(R)) * R);
  }

  // The primitives: the scene file with the plate's motion replaced, through the scene loader.
  YAML::Node root = YAML::LoadFile(spec.scene_path);
  YAML::Node bodies = root["bodies"];
  int yaml_plate = -1;
  for (std::size_t i = 0; bodies.IsSequence() && i < bodies.size(); ++i)
    if (bodies[i]["name"].IsScalar() && bodies[i]["name"].Scalar() == scene.bodies[plate_].name)
      yaml_plate = static_cast<int>(i);
  if (yaml_plate < 0)
    throw std::invalid_argument(spec.scene_path + ": cannot find the plate '" +
                                scene.bodies[plate_].name + "' in bodies");
  simulator_ = std::make_unique<sim::Simulator>(scene);
  const sim::Scene& s = simulator_->scene();
  params_ = simulator_->DefaultParams();
  const sim::StepInput none;
  const sim::Isometry3d X_start = sim::PrescribedKinematicsAt(s, plate_, none, 0.0).X_WB;
  for (std::size_t i = 0; i < spec.primitives.size(); ++i) {
    const PlanPrimitive& prim = spec.primitives[i];
    const std::string where = Where(spec, prim.line) + "primitives[" + std::to_string(i) +
                              "].motion ('" + prim.name + "'): ";
    sim::PrescribedMotion motion;
    try {
      YAML::Node copy = YAML::Clone(root);
      copy["bodies"][yaml_plate]["motion"] = YAML::Load(prim.motion_yaml);
      YAML::Emitter out;
      out << copy;
      const sim::Scene ps = sim::ParseScene(out.c_str(), "the scene with this motion");
      motion = ps.bodies[plate_].motion;
    } catch (const std::exception& e) {
      throw std::invalid_argument(where +
                                  "expected a valid plate motion (scene format), got: " + e.what());
    }
    sim::MotionSegment seg;
    try {
      seg = sim::PhaseLockedSegment(s, plate_, motion, 0.0, X_start, 1, s.options.dt);
    } catch (const std::exception& e) {
      throw std::invalid_argument(where + e.what());
    }
    const long long spc = static_cast<long long>(seg.inputs.size());
    const long long cycles = std::max(spec.max_cycles, spec.settle_cycles);
    if (cycles * spc > PlanLimits::kMaxStepsPerApplication)
      throw std::invalid_argument(
          where + "expected at most " + std::to_string(PlanLimits::kMaxStepsPerApplication) +
          " time steps per application (max(cycles max, settle_cycles) × steps per cycle), got " +
          std::to_string(cycles) + " × " + std::to_string(spc) + " (the motion's frequency is " +
          "too low for the scene's dt)");
    motions_.push_back(motion);
    steps_per_cycle_.push_back(static_cast<int>(seg.inputs.size()));
    inputs_.push_back(seg.inputs.front());
  }
  initial_ = simulator_->InitialState();
}

PartPoses PlanProblem::PosesOf(const sim::State& x) const {
  const sim::Scene& s = simulator_->scene();
  PartPoses out;
  const sim::Isometry3d X_PW = X_WP_.inverse();
  for (int p : parts_) {
    const double* q = x.q.data() + s.index(p).q;
    const sim::Vector3d pos = X_PW * sim::Vector3d(q[0], q[1], q[2]);
    const sim::Matrix3d R =
        X_PW.linear() * sim::Quaterniond(q[3], q[4], q[5], q[6]).normalized().toRotationMatrix();
    out.push_back({pos.x(), pos.y(), Yaw(R)});
  }
  return out;
}

sim::State PlanProblem::StateAt(const PartPoses& poses) const {
  if (poses.size() != parts_.size())
    throw std::invalid_argument("PlanProblem::StateAt: expected " + std::to_string(parts_.size()) +
                                " poses, got " + std::to_string(poses.size()));
  const sim::Scene& s = simulator_->scene();
  sim::State x = initial_;
  x.t = 0.0;
  for (std::size_t i = 0; i < parts_.size(); ++i) {
    sim::Isometry3d X_PB = sim::Isometry3d::Identity();
    X_PB.translation() = sim::Vector3d(poses[i].x, poses[i].y, height_[i]);
    X_PB.linear() = Rz(poses[i].theta) * tilt_[i];
    const std::string& name = s.bodies[parts_[i]].name;
    sim::SetBodyPose(s, name, X_WP_ * X_PB, &x);
    sim::SetBodyVelocity(s, name, sim::Vector3d::Zero(), sim::Vector3d::Zero(), &x);
  }
  return x;
}

bool PlanProblem::OnPlate(const PartPoses& poses) const {
  for (const PartPose& p : poses)
    if (!(p.x >= spec_.x_min && p.x <= spec_.x_max && p.y >= spec_.y_min && p.y <= spec_.y_max))
      return false;
  return true;
}

Propagation PlanProblem::Propagate(const PartPoses& from, int primitive, int cycles,
                                   sim::Workspace* ws) const {
  if (primitive < 0 || primitive >= num_primitives() || cycles < 0)
    throw std::invalid_argument("PlanProblem::Propagate: expected a primitive in [0, " +
                                std::to_string(num_primitives() - 1) + "] and cycles >= 0, got " +
                                std::to_string(primitive) + ", " + std::to_string(cycles));
  Propagation r;
  r.poses = from;
  sim::State x = StateAt(from), next;
  // Steps x n times with input v, the poses after each step into r; false at a failed step or a
  // part leaving the plate.
  const auto advance = [&](const sim::StepInput& v, long long n) {
    for (long long k = 0; k < n; ++k) {
      const sim::StepInfo info = simulator_->Step(params_, x, v, ws, &next);
      if (!info.ok) {
        r.failure = info.failure;
        return false;
      }
      std::swap(x, next);
      PartPoses poses = PosesOf(x);
      if (!OnPlate(poses)) {
        r.left_plate = true;
        return false;
      }
      r.poses = std::move(poses);
    }
    return true;
  };
  const sim::StepInput& u = inputs_[primitive];
  if (!advance(u, static_cast<long long>(cycles) * steps_per_cycle_[primitive])) return r;
  // The plate rests at its pose while the parts come to rest.
  sim::StepInput rest;
  rest.motions.push_back({plate_, sim::PrescribedMotion{},
                          sim::PrescribedKinematicsAt(simulator_->scene(), plate_, u, x.t).X_WB});
  if (!advance(rest, static_cast<long long>(spec_.settle_cycles) * steps_per_cycle_[primitive]))
    return r;
  r.valid = true;
  return r;
}

double PlanProblem::GoalDistance(const PartPoses& poses) const {
  double d = 0.0;
  const std::vector<double> pe = PositionErrors(poses), ae = AngleErrors(poses);
  for (std::size_t i = 0; i < spec_.goals.size(); ++i) {
    const PartGoal& g = spec_.goals[i];
    d = std::max(d, pe[i] / g.tolerance);
    if (g.has_angle) d = std::max(d, ae[i] / g.angle_tolerance);
  }
  return d;
}

std::vector<double> PlanProblem::PositionErrors(const PartPoses& poses) const {
  std::vector<double> e;
  for (std::size_t i = 0; i < spec_.goals.size(); ++i)
    e.push_back(std::hypot(poses.at(i).x - spec_.goals[i].position.x(),
                           poses.at(i).y - spec_.goals[i].position.y()));
  return e;
}

std::vector<double> PlanProblem::AngleErrors(const PartPoses& poses) const {
  std::vector<double> e;
  for (std::size_t i = 0; i < spec_.goals.size(); ++i) {
    const PartGoal& g = spec_.goals[i];
    e.push_back(g.has_angle ? std::abs(std::remainder(poses.at(i).theta - g.angle, kTwoPi)) : 0.0);
  }
  return e;
}

void Resimulate(const PlanProblem& problem, const std::vector<PlanStep>& steps, Resimulation* out) {
  const sim::Simulator& sim = problem.simulator();
  const sim::Scene& s = sim.scene();
  if (out->states.empty()) out->states.push_back(sim.InitialState());
  if (!out->ok || out->left_plate) return;
  sim::State x = out->states.back(), next;
  sim::StepInput previous;
  if (!out->segments.empty()) previous.motions = {out->segments.back()};
  sim::Isometry3d X_start = sim::PrescribedKinematicsAt(s, problem.plate(), previous, x.t).X_WB;
  sim::Workspace ws;
  const sim::Params params = sim.DefaultParams();
  for (const PlanStep& step : steps) {
    const sim::MotionSegment seg =
        sim::PhaseLockedSegment(s, problem.plate(), problem.primitive_motion(step.primitive), x.t,
                                X_start, step.cycles, s.options.dt);
    if (seg.inputs.empty()) continue;
    out->segments.push_back(seg.inputs.front().motions.front());
    const int index = static_cast<int>(out->segments.size()) - 1;
    for (const sim::StepInput& u : seg.inputs) {
      const sim::StepInfo info = sim.Step(params, x, u, &ws, &next);
      if (!info.ok) {
        out->ok = false;
        out->failure = info.failure;
        out->infos.push_back(info);
        out->segment_of_step.push_back(index);
        return;
      }
      std::swap(x, next);
      out->states.push_back(x);
      out->infos.push_back(info);
      out->segment_of_step.push_back(index);
      if (!problem.OnPlate(problem.PosesOf(x))) {
        out->left_plate = true;
        return;
      }
    }
    X_start = seg.X_end;
    // The plate rests at X_end for settle_cycles (PlanSpec::settle_cycles).
    const int m = problem.spec().settle_cycles * problem.steps_per_cycle(step.primitive);
    if (m == 0) continue;
    sim::StepInput rest;
    rest.motions.push_back({problem.plate(), sim::PrescribedMotion{}, X_start});
    out->segments.push_back(rest.motions.front());
    const int rest_index = static_cast<int>(out->segments.size()) - 1;
    for (int k = 0; k < m; ++k) {
      const sim::StepInfo info = sim.Step(params, x, rest, &ws, &next);
      out->infos.push_back(info);
      out->segment_of_step.push_back(rest_index);
      if (!info.ok) {
        out->ok = false;
        out->failure = info.failure;
        return;
      }
      std::swap(x, next);
      out->states.push_back(x);
      if (!problem.OnPlate(problem.PosesOf(x))) {
        out->left_plate = true;
        return;
      }
    }
  }
}

void WriteResimulationCsv(const PlanProblem& problem, const Resimulation& r, std::ostream& out) {
  const sim::Scene& s = problem.simulator().scene();
  static const char* const kCols[] = {"x",  "y",  "z",  "qw", "qx", "qy", "qz",
                                      "vx", "vy", "vz", "wx", "wy", "wz"};
  std::string h = "step,t";
  for (const sim::Body& b : s.bodies)
    for (const char* c : kCols) h += "," + b.name + "." + c;
  h += ",contacts,solver_iterations,residual,min_gap,status\n";
  out << h;
  std::vector<sim::Quaterniond> last(s.bodies.size(), sim::Quaterniond::Identity());
  for (std::size_t b = 0; b < s.bodies.size(); ++b) {
    last[b] = sim::Quaterniond(s.bodies[b].X_WB0.linear());
    if (last[b].w() < 0) last[b].coeffs() *= -1.0;
  }
  for (std::size_t k = 0; k < r.states.size(); ++k) {
    const sim::State& x = r.states[k];
    sim::StepInput u;
    if (!r.segments.empty()) {
      const std::size_t step = k == 0 ? 0 : k - 1;
      if (step < r.segment_of_step.size()) u.motions = {r.segments[r.segment_of_step[step]]};
    }
    std::string row = std::to_string(k) + ",";
    AppendNumber(x.t, &row);
    for (std::size_t b = 0; b < s.bodies.size(); ++b) {
      const sim::Body& body = s.bodies[b];
      sim::BodyKinematics kin;
      sim::Quaterniond q;
      if (body.kind == sim::BodyKind::kDynamic) {
        kin = sim::GetBodyKinematics(s, x, body.name);
        const double* qq = x.q.data() + s.index(static_cast<int>(b)).q;
        q = sim::Quaterniond(qq[3], qq[4], qq[5], qq[6]);
      } else {
        kin = sim::PrescribedKinematicsAt(s, static_cast<int>(b), u, x.t);
        q = sim::Quaterniond(kin.X_WB.linear());
        if (q.coeffs().dot(last[b].coeffs()) < 0) q.coeffs() *= -1.0;
        last[b] = q;
      }
      const sim::Vector3d p = kin.X_WB.translation();
      for (double v : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z(), kin.v_WB.x(), kin.v_WB.y(),
                       kin.v_WB.z(), kin.w_WB.x(), kin.w_WB.y(), kin.w_WB.z()}) {
        row += ',';
        AppendNumber(v, &row);
      }
    }
    if (k == 0) {
      row += ",0,0,0,0,initial";
    } else {
      const sim::StepInfo& info = r.infos[k - 1];
      row +=
          "," + std::to_string(info.contacts) + "," + std::to_string(info.solver.iterations) + ",";
      AppendNumber(info.solver.residual, &row);
      row += ',';
      AppendNumber(info.min_gap, &row);
      row += ",";
      row += sim::ToString(info.solver.status);
    }
    out << row << "\n";
  }
}

PlanResult RunPlan(const PlanProblem& problem, const PlanRunOptions& options) {
  if (options.replan < 0)
    throw std::invalid_argument("RunPlan: expected replan >= 0, got " +
                                std::to_string(options.replan));
  PlanResult result;
  PartPoses start = problem.StartPoses();
  result.resimulation.states.push_back(problem.simulator().InitialState());
  for (int round = 0; round <= options.replan; ++round) {
    PlanAttempt a =
        PlanOnce(problem, start, options.planner, options.time_limit, options.max_propagations);
    for (PlanStep& s : a.steps) s.round = round;
    result.solve_time_s += a.solve_time_s;
    result.attempts.push_back(a);
    Resimulate(problem, a.steps, &result.resimulation);
    result.steps.insert(result.steps.end(), a.steps.begin(), a.steps.end());
    const PartPoses poses = problem.PosesOf(result.resimulation.states.back());
    if (options.on_attempt) options.on_attempt(a, poses);
    if (a.steps.empty() || !result.resimulation.ok || result.resimulation.left_plate) break;
    if (problem.GoalDistance(poses) <= 1.0) break;
    start = poses;
  }
  result.final_poses = problem.PosesOf(result.resimulation.states.back());
  result.final_position_errors = problem.PositionErrors(result.final_poses);
  result.final_angle_errors = problem.AngleErrors(result.final_poses);
  result.final_goal_distance = problem.GoalDistance(result.final_poses);
  result.reached = result.resimulation.ok && !result.resimulation.left_plate &&
                   result.final_goal_distance <= 1.0;
  result.solved = result.reached && result.attempts.back().exact;
  return result;
}

}  // namespace vinci::planning
