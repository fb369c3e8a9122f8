// Field design (docs/planning.md): the spec loader's errors, the field error's closed forms, and
// recovery of a field produced by known plate-motion parameters.
#include "vinci/planning/field_design.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

#include "vinci/planning/field_design_spec.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::planning {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/planning/data";
constexpr double kPi = 3.14159265358979323846;

// A conveyor-like spec on the test plate: x amplitude and z phase free, 3x3 grid, 6 cycles.
const std::string kSpec =
    "scene: plate_point.yaml\n"
    "target: {type: conveyor, direction: [-1, 0], speed: 0.05}\n"
    "motion:\n"
    "  frequency: 30\n"
    "  dofs:\n"
    "    x: {amplitude: [2.0e-4, 1.2e-3], phase: 0}\n"
    "    z: {amplitude: 1.407e-4, phase: [-3.14159, 3.14159]}\n"
    "  max_vertical_acceleration: 9.0\n"
    "grid: {x: [-0.05, 0.05], y: [-0.05, 0.05], points: [3, 3]}\n"
    "cycles: 6\n"
    "average_cycles: 2\n";

std::string Error(const std::string& text) {
  try {
    ParseFieldDesignSpec(text, "bad.yaml", kData);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(FieldDesignSpec, ReadsTheDocumentedKeys) {
  const FieldDesignSpec s = ParseFieldDesignSpec(kSpec + "budget: 7\nseed: 9\n", "ok.yaml", kData);
  EXPECT_EQ(s.scene_path, kData + "/plate_point.yaml");
  EXPECT_EQ(s.target.type, TargetType::kConveyor);
  EXPECT_EQ(s.target.direction, Vector2d(-1, 0));
  ASSERT_EQ(s.dofs.size(), 2u);
  EXPECT_EQ(s.dofs[0].dof, "x");
  EXPECT_EQ(s.dofs[1].phase_lo, -3.14159);
  EXPECT_EQ(s.max_vertical_acceleration, 9.0);
  EXPECT_EQ(s.nx, 3);
  EXPECT_EQ(s.budget, 7);
  EXPECT_EQ(s.seed, 9u);
}

TEST(FieldDesignSpec, RejectsBadSpecsWithFileLine) {
  EXPECT_EQ(Error("scene: plate_point.yaml\ntarget: {type: spiral}\n")
                .rfind("bad.yaml:2: target.type: expected sink, source", 0),
            0u)
      << Error("scene: plate_point.yaml\ntarget: {type: spiral}\n");
  const std::string no_radius =
      Error("scene: plate_point.yaml\ntarget: {type: circle, center: [0, 0]}\nmotion: {}\n");
  EXPECT_NE(no_radius.find("bad.yaml:2: target.radius: expected the circle's radius"),
            std::string::npos)
      << no_radius;
  std::string s = kSpec;
  s.replace(s.find("phase: 0}"), 9, "phase: [1, 0]}");
  EXPECT_NE(Error(s).find("bad.yaml:6: motion.dofs.x.phase: expected [lo, hi] with lo <= hi"),
            std::string::npos)
      << Error(s);
  EXPECT_NE(Error(kSpec + "budget: -3\n").find("bad.yaml:12: budget: expected an integer"),
            std::string::npos)
      << Error(kSpec + "budget: -3\n");
  EXPECT_NE(Error(kSpec + "speed: 3\n").find("bad.yaml:12: speed: expected one of the keys"),
            std::string::npos);
  std::string dof = kSpec;
  dof.replace(dof.find("    z:"), 6, "    w:");
  EXPECT_NE(Error(dof).find("bad.yaml:7: motion.dofs.w: expected one of the keys"),
            std::string::npos)
      << Error(dof);
  EXPECT_NE(Error("scene: plate_point.yaml\ntarget: {type: conveyor}\n")
                .find("bad.yaml:2: target.direction: expected [dx, dy]"),
            std::string::npos);
  // A CSV target that does not fit the grid names the CSV line and the spec line.
  const std::string csv = Error(
      "scene: plate_point.yaml\ntarget: {csv: short.csv}\nmotion: {frequency: 30, dofs: {x: "
      "{amplitude: 1e-4}}}\ngrid: {x: [-0.05, 0.05], y: [-0.05, 0.05], points: [3, 3]}\n");
  EXPECT_NE(csv.find("bad.yaml:2: target.csv: "), std::string::npos) << csv;
  EXPECT_NE(csv.find("short.csv:2: rows: expected 9"), std::string::npos) << csv;
}

TEST(FieldDesignSpec, TargetFormulas) {
  FieldTarget t;
  t.center = Vector2d(0.1, 0.0);
  t.radius = 0.05;
  t.speed = 2.0;
  t.type = TargetType::kSink;
  EXPECT_TRUE(t.At(Vector2d(0.15, 0.0)).isApprox(Vector2d(-2.0, 0.0)));
  t.type = TargetType::kWhirlpool;
  EXPECT_TRUE(t.At(Vector2d(0.15, 0.0)).isApprox(Vector2d(0.0, 2.0)));
  // Circle v = s (ẑ × r + (1 − q)/(1 + q) r) / R, q = ρ²/R²: on the circle tangential at speed
  // s; at ρ = R/2 (q = 1/4) the ratio radial/tangential is +0.6 (outward), at ρ = 2R (q = 4) −0.6.
  t.type = TargetType::kCircle;
  EXPECT_TRUE(t.At(Vector2d(0.15, 0.0)).isApprox(Vector2d(0.0, 2.0)));
  EXPECT_TRUE(t.At(Vector2d(0.1, 0.05)).isApprox(Vector2d(-2.0, 0.0)));
  EXPECT_TRUE(t.At(Vector2d(0.125, 0.0)).isApprox(Vector2d(0.6, 1.0)));
  EXPECT_TRUE(t.At(Vector2d(0.2, 0.0)).isApprox(Vector2d(-2.4, 4.0)));
  EXPECT_EQ(t.At(Vector2d(0.1, 0.0)), Vector2d::Zero());  // smooth: 0 at the centre,
  const Vector2d small(1e-6, 2e-6);  // ≈ s (ẑ × r + r) / R near it (relative deviation 2q)
  EXPECT_TRUE(
      t.At(t.center + small).isApprox(2.0 * Vector2d(1e-6 - 2e-6, 2e-6 + 1e-6) / 0.05, 1e-8));
  // Inversion in the circle (ρ → R²/ρ) flips the radial/tangential ratio: drawn onto it equally
  // from inside and outside.
  for (const double rho : {0.01, 0.03, 0.045}) {
    const Vector2d in = t.At(t.center + Vector2d(rho, 0.0));
    const Vector2d out = t.At(t.center + Vector2d(0.05 * 0.05 / rho, 0.0));
    EXPECT_NEAR(in.x() / in.y(), -out.x() / out.y(), 1e-12) << rho;
  }
  t.clockwise = true;
  EXPECT_TRUE(t.At(Vector2d(0.125, 0.0)).isApprox(Vector2d(0.6, -1.0)));
  t.clockwise = false;
  t.type = TargetType::kSaddle;  // repelling along d = x, attracting along y
  EXPECT_GT(t.At(Vector2d(0.15, 0.0)).x(), 0.0);
  EXPECT_LT(t.At(Vector2d(0.1, 0.05)).y(), 0.0);
  t.direction = Vector2d(0.0, 1.0);  // the line x = 0.1; n = ẑ × d = −x̂
  t.type = TargetType::kLineSink;    // drawn onto the line, nothing along it
  EXPECT_TRUE(t.At(Vector2d(0.15, 0.3)).isApprox(Vector2d(-2.0, 0.0)));
  EXPECT_TRUE(t.At(Vector2d(0.05, -0.2)).isApprox(Vector2d(2.0, 0.0)));
  EXPECT_EQ(t.At(Vector2d(0.1, 0.7)), Vector2d::Zero());
  t.type = TargetType::kShear;  // along d, with the signed distance r·n from the line
  EXPECT_TRUE(t.At(Vector2d(0.15, 0.3)).isApprox(Vector2d(0.0, -2.0)));
  EXPECT_TRUE(t.At(Vector2d(0.05, -0.2)).isApprox(Vector2d(0.0, 2.0)));
  EXPECT_EQ(t.At(Vector2d(0.1, 0.7)), Vector2d::Zero());
}

TEST(FieldDesignSpec, AcceptsEveryTargetTypeOfTheIssue) {
  // Each type with the keys it takes (docs/planning.md).
  const std::pair<const char*, TargetType> types[] = {
      {"{type: sink, center: [0, 0], radius: 0.1}", TargetType::kSink},
      {"{type: source, radius: 0.1}", TargetType::kSource},
      {"{type: whirlpool, clockwise: true}", TargetType::kWhirlpool},
      {"{type: circle, radius: 0.05, clockwise: false}", TargetType::kCircle},
      {"{type: saddle, direction: [1, 0]}", TargetType::kSaddle},
      {"{type: line_sink, center: [0, 0.01], direction: [1, 1]}", TargetType::kLineSink},
      {"{type: line sink, direction: [0, 1]}", TargetType::kLineSink},
      {"{type: shear, radius: 0.1, direction: [1, 0]}", TargetType::kShear},
      {"{type: conveyor, direction: [1, 0]}", TargetType::kConveyor}};
  const std::string line = "{type: conveyor, direction: [-1, 0], speed: 0.05}";
  for (const auto& [target, type] : types) {
    std::string s = kSpec;
    s.replace(s.find(line), line.size(), target);
    SCOPED_TRACE(target);
    EXPECT_EQ(ParseFieldDesignSpec(s, "ok.yaml", kData).target.type, type);
  }
  std::string clockwise = kSpec;  // a key the type does not take is rejected at its line
  clockwise.replace(clockwise.find(line), line.size(), "{type: shear, clockwise: true}");
  EXPECT_NE(Error(clockwise).find("bad.yaml:2: target.clockwise: expected no 'clockwise' for a "
                                  "shear target"),
            std::string::npos)
      << Error(clockwise);
}

TEST(FieldError, ZeroForTheSameFieldAndClosedFormsUnderPerturbations) {
  const FieldDesignProblem problem(ParseFieldDesignSpec(kSpec, "ok.yaml", kData));
  VectorXd x(2);
  x << 8.443e-4, kPi / 2;
  const FieldEvaluation e = problem.Evaluate(x, 1);
  ASSERT_TRUE(e.feasible);
  ASSERT_EQ(e.bad_points, 0);
  std::vector<Vector2d> v;
  for (const auto& p : e.field.points) v.emplace_back(p.vx, p.vy);
  ASSERT_GT(v[0].norm(), 1e-3);  // the conveyor moves parts
  EXPECT_EQ(FieldError(e.field, v, false), 0.0);
  EXPECT_EQ(FieldError(e.field, v, true), 0.0);
  // Rotating every target vector by δ: shape error 2 sin(δ/2), growing with δ.
  for (const double delta : {0.05, 0.3, 1.0}) {
    std::vector<Vector2d> r;
    for (const Vector2d& t : v) r.push_back(Eigen::Rotation2Dd(delta) * t);
    EXPECT_NEAR(FieldError(e.field, r, false), 2 * std::sin(delta / 2), 1e-12);
  }
  // Scaling the target: the shape is unchanged, the absolute error is |1 − 1/k|.
  std::vector<Vector2d> twice;
  for (const Vector2d& t : v) twice.push_back(2.0 * t);
  EXPECT_NEAR(FieldError(e.field, twice, false), 0.0, 1e-14);
  EXPECT_NEAR(FieldError(e.field, twice, true), 0.5, 1e-14);
  // A point that left the plate is penalized and counted.
  sim::VelocityField left = e.field;
  left.points[4].left_plate = true;
  int bad = 0;
  EXPECT_GT(FieldError(left, v, false, &bad), 0.5);
  EXPECT_EQ(bad, 1);
}

// A field given as velocities (no simulation) on the 11×11 grid over [−0.1, 0.1]².
sim::VelocityField GridField(const std::vector<Vector2d>& v) {
  sim::VelocityField f;
  for (const Vector2d& u : v) {
    sim::FieldPoint p;
    p.vx = u.x();
    p.vy = u.y();
    f.points.push_back(p);
  }
  return f;
}

Vector2d Grid11(int k) { return {-0.1 + 0.02 * (k % 11), -0.1 + 0.02 * (k / 11)}; }

TEST(FieldError, RegionsAreScoredEachOnItsOwn) {
  // Two regions, the field equal to the target in one and rotated by δ in the other: each region
  // has its own RMS speeds, so e = √((0 + (2 sin(δ/2))²)/2) whatever the regions' speeds.
  std::vector<Vector2d> t, v;
  std::vector<int> regions;
  for (int k = 0; k < 10; ++k) {
    const bool second = k >= 4;
    const Vector2d u = (second ? 5.0 : 0.1) * Vector2d(std::cos(k), std::sin(2 * k) + 1.5);
    t.push_back(u);
    v.push_back(second ? Eigen::Rotation2Dd(0.4) * u * 3.0 : u * 0.2);
    regions.push_back(second ? 1 : 0);
  }
  const double rotated = 2 * std::sin(0.2);
  EXPECT_NEAR(FieldError(GridField(v), t, false, nullptr, regions), rotated / std::sqrt(2.0),
              1e-12);
  // One label is the plain error; a label list of the wrong size is rejected.
  EXPECT_EQ(FieldError(GridField(v), t, false, nullptr, std::vector<int>(10, 3)),
            FieldError(GridField(v), t, false));
  EXPECT_THROW(FieldError(GridField(v), t, false, nullptr, std::vector<int>(9, 0)),
               std::invalid_argument);
}

TEST(FieldError, TheCircleScoresTheInsideOfTheRing) {
  // The circle target (R = 5 cm on the specs' 11×11 grid) with its outward radial part removed
  // inside (parts spiral into the centre: no ring) is close to the target over the whole grid,
  // where the inside's small speeds hide it, but far from it inside: with the regions (inside,
  // outside scored each on its own) it no longer passes for a circle.
  FieldTarget circle;
  circle.type = TargetType::kCircle;
  circle.radius = 0.05;
  std::vector<Vector2d> t, no_ring;
  std::vector<int> regions;
  int inside = 0;
  for (int k = 0; k < 121; ++k) {
    const Vector2d p = Grid11(k);
    t.push_back(circle.At(p));
    regions.push_back(circle.Region(p));
    inside += regions.back() == 0;
    const Vector2d radial = p.squaredNorm() > 0 ? p.normalized() : Vector2d::Zero();
    const double vr = t.back().dot(radial);
    no_ring.push_back(t.back() - (vr > 0 ? 2.0 : 0.0) * vr * radial);  // inside: inward
  }
  EXPECT_EQ(inside, 21);  // ρ < R: 21 of the 121 points
  const double whole = FieldError(GridField(no_ring), t, false);
  const double by_region = FieldError(GridField(no_ring), t, false, nullptr, regions);
  EXPECT_LT(whole, 0.1);
  EXPECT_GT(by_region, 0.3);
  EXPECT_NEAR(FieldError(GridField(t), t, false, nullptr, regions), 0.0, 1e-12);
  // Every other target type has a single region.
  circle.type = TargetType::kWhirlpool;
  EXPECT_EQ(circle.Region(Vector2d(0.01, 0)), circle.Region(Vector2d(0.2, 0)));
}

TEST(FieldDesignProblem, ACircleNeedsTargetVelocitiesOnBothSides) {
  // On the 3×3 grid over [−0.05, 0.05]² a circle of radius 3 cm has only the centre inside, where
  // the target is 0: its inside cannot be scored on its own.
  std::string text = kSpec;
  const std::string conveyor = "{type: conveyor, direction: [-1, 0], speed: 0.05}";
  text.replace(text.find(conveyor), conveyor.size(), "{type: circle, radius: 0.03}");
  const FieldDesignSpec spec = ParseFieldDesignSpec(text, "ok.yaml", kData);
  try {
    const FieldDesignProblem problem(spec);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("ok.yaml: target: expected grid points with a nonzero "
                                         "target velocity on both sides of the circle"),
              std::string::npos)
        << e.what();
  }
  // Radius 6 cm: the corners are outside, the rest inside: two regions, both scored.
  text.replace(text.find("radius: 0.03"), 12, "radius: 0.06");
  const FieldDesignProblem two(ParseFieldDesignSpec(text, "ok.yaml", kData));
  ASSERT_EQ(two.regions().size(), 9u);
  EXPECT_EQ(two.regions()[0], 1);  // a corner
  EXPECT_EQ(two.regions()[4], 0);  // the centre
}

TEST(FieldError, ShapeOfAConveyorTargetFromTheSimulation) {
  // The bundled-style conveyor (z leads x by π/2) moves parts along −x: its field matches the
  // conveyor target toward −x closely and the opposite direction not at all.
  FieldDesignSpec spec = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  const FieldDesignProblem minus_x(spec);
  VectorXd x(2);
  x << 8.443e-4, kPi / 2;
  EXPECT_LT(minus_x.Evaluate(x, 2).error, 0.05);
  spec.target.direction = Vector2d(1, 0);
  const FieldDesignProblem plus_x(spec);
  EXPECT_GT(plus_x.Evaluate(x, 2).error, 1.9);
}

TEST(FieldDesignProblem, ActuatorLimitIsNotSimulated) {
  FieldDesignSpec spec = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  spec.max_vertical_acceleration = 4.0;  // (2π 30)² 1.407e-4 = 5.0 m/s²
  const FieldDesignProblem problem(spec);
  VectorXd x(2);
  x << 8.443e-4, kPi / 2;
  EXPECT_NEAR(problem.PeakVerticalAcceleration(x), std::pow(2 * kPi * 30, 2) * 1.407e-4, 1e-12);
  const FieldEvaluation e = problem.Evaluate(x, 1);
  EXPECT_FALSE(e.feasible);
  EXPECT_TRUE(e.field.points.empty());
  EXPECT_GT(e.error, kInfeasibleError);
  // The horizontal limit: x's peak (2π 30)² 8.443e-4 = 30.0 m/s² over 20 m/s² is not simulated,
  // its error is 10 + the relative excess 0.5.
  spec.max_vertical_acceleration = 9.0;
  spec.max_linear_acceleration = 20.0;
  const FieldDesignProblem linear(spec);
  EXPECT_NEAR(linear.PeakLinearAcceleration(x), std::pow(2 * kPi * 30, 2) * 8.443e-4, 1e-12);
  const FieldEvaluation l = linear.Evaluate(x, 1);
  EXPECT_FALSE(l.feasible);
  EXPECT_NEAR(l.error, kInfeasibleError + (l.peak_linear_acceleration - 20.0) / 20.0, 1e-12);
  spec.max_linear_acceleration = 31.0;  // within: simulated
  EXPECT_TRUE(FieldDesignProblem(spec).Evaluate(x, 1).feasible);
  EXPECT_EQ(ParseFieldDesignSpec(kSpec, "ok.yaml", kData).max_angular_acceleration,
            std::numeric_limits<double>::infinity());
}

// Recovery: the field of known parameters (x amplitude, z phase) is the target (absolute
// speeds); the search from the middle of the box finds parameters matching it to the tolerance.
TEST(DesignField, RecoversAFieldOfKnownParameters) {
  FieldDesignSpec spec = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  VectorXd truth(2);
  truth << 6.0e-4, 2.0;
  const FieldDesignProblem source(spec);
  const FieldEvaluation produced = source.Evaluate(truth, 2);
  ASSERT_EQ(produced.bad_points, 0);
  spec.target.type = TargetType::kCsv;
  spec.target.velocities.clear();
  for (const auto& p : produced.field.points) spec.target.velocities.emplace_back(p.vx, p.vy);
  spec.absolute = true;
  spec.tolerance = 0.05;
  const FieldDesignProblem problem(spec);
  EXPECT_GT(problem.Evaluate(problem.Start(), 1).error, 0.3);  // the start is far off
  FieldDesignOptions options;
  options.budget = 60;
  options.seed = 5;
  options.threads = 2;
  int calls = 0;
  options.on_evaluation = [&](const FieldEvaluation& e) { EXPECT_EQ(e.index, ++calls); };
  const FieldDesignResult r = DesignField(problem, options);
  EXPECT_TRUE(r.errors.empty());
  EXPECT_EQ(calls, r.evaluations);
  EXPECT_LE(r.evaluations, 60);
  EXPECT_TRUE(r.reached_tolerance) << "best error " << r.best.error;
  EXPECT_LE(r.best.error, 0.05);
  // The reported error is the simulated one.
  EXPECT_EQ(problem.Evaluate(r.best.x, 1).error, r.best.error);
}

// A written best scene gives back its free variables exactly, and the search started from them
// evaluates that motion first (budget 1: only it), with the same error.
TEST(FieldDesignProblem, ParametersFromAWrittenSceneRoundTrip) {
  const FieldDesignProblem problem(ParseFieldDesignSpec(kSpec, "ok.yaml", kData));
  VectorXd x(2);
  x << 7.123456789e-4, -1.2345678901;
  const std::string path = ::testing::TempDir() + "/field_design_start.yaml";
  {
    std::ofstream out(path);
    out << problem.SceneYaml(x);
  }
  const VectorXd back = problem.ParametersFromScene(path);
  ASSERT_EQ(back.size(), 2);
  EXPECT_EQ(back[0], x[0]);
  EXPECT_EQ(back[1], x[1]);
  FieldDesignOptions options;
  options.budget = 1;
  options.start = back;
  const FieldDesignResult r = DesignField(problem, options);
  ASSERT_EQ(r.evaluations, 1);
  EXPECT_EQ(r.best.x, x);
  EXPECT_EQ(r.best.error, problem.Evaluate(x, 1).error);
  // Outside the box, or a fixed value that differs from the spec's: rejected, naming it.
  const auto rejected = [&](const VectorXd& y, const FieldDesignProblem& p) {
    {
      std::ofstream out(path);
      out << problem.SceneYaml(y);
    }
    try {
      p.ParametersFromScene(path);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  VectorXd far = x;
  far[0] = 2e-3;  // bounds [2e-4, 1.2e-3]
  EXPECT_NE(rejected(far, problem).find("x.amplitude: expected a value in [0.0002"),
            std::string::npos)
      << rejected(far, problem);
  FieldDesignSpec other = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  other.dofs[1].amplitude_lo = other.dofs[1].amplitude_hi = 1.0e-4;  // z amplitude fixed apart
  const FieldDesignProblem fixed_apart(other);
  EXPECT_NE(rejected(x, fixed_apart).find("z.amplitude: expected 0.0001 (fixed by ok.yaml)"),
            std::string::npos)
      << rejected(x, fixed_apart);
  options.start = VectorXd::Constant(2, 5.0);
  EXPECT_THROW(DesignField(problem, options), std::invalid_argument);
}

// Several harmonics per DOF: the k-th harmonic of a DOF runs at k f in the written scene, its
// parameters are amplitude<i>/phase<i> (i its index in the DOF), the actuator bound weighs it by
// k², and a written scene gives its free variables back; a wrong family is rejected.
TEST(FieldDesignProblem, SeveralHarmonicsPerDof) {
  std::string text = kSpec;
  const std::string x_line = "    x: {amplitude: [2.0e-4, 1.2e-3], phase: 0}\n";
  const std::string z_line = "    z: {amplitude: 1.407e-4, phase: [-3.14159, 3.14159]}\n";
  text.replace(text.find(x_line), x_line.size(),
               "    x:\n"
               "      - {order: 1, amplitude: [2.0e-4, 1.2e-3], phase: 0}\n"
               "      - {order: 3, amplitude: [-2.0e-4, 2.0e-4], phase: [-3.14159, 3.14159]}\n");
  text.replace(text.find(z_line), z_line.size(),
               "    z: [{amplitude: 5.0e-5, phase: 1.0}, {order: 2, amplitude: [0, 2.0e-5]}]\n");
  const FieldDesignSpec spec = ParseFieldDesignSpec(text, "ok.yaml", kData);
  ASSERT_EQ(spec.dofs.size(), 4u);
  EXPECT_EQ(spec.dofs[1].dof, "x");
  EXPECT_EQ(spec.dofs[1].order, 3);
  EXPECT_EQ(spec.dofs[3].order, 2);
  const FieldDesignProblem problem(spec);
  const std::vector<std::string> names = {"motion.plate.x.amplitude0", "motion.plate.x.amplitude1",
                                          "motion.plate.x.phase1", "motion.plate.z.amplitude1"};
  EXPECT_EQ(problem.names(), names);
  VectorXd x(4);
  x << 7.5e-4, -1.5e-4, 0.75, 1.25e-5;
  const double w = 2 * kPi * 30;
  EXPECT_NEAR(problem.PeakVerticalAcceleration(x), w * w * 5.0e-5 + 4 * w * w * 1.25e-5, 1e-12);
  EXPECT_NEAR(problem.PeakLinearAcceleration(x), w * w * 7.5e-4 + 9 * w * w * 1.5e-4, 1e-12);
  EXPECT_EQ(problem.PeakAngularAcceleration(x), 0.0);
  const std::string path = ::testing::TempDir() + "/field_design_harmonics.yaml";
  {
    std::ofstream out(path);
    out << problem.SceneYaml(x);
  }
  const sim::Scene scene = sim::LoadSceneFile(path);
  const sim::DofMotion& mx = scene.bodies[0].motion.dofs[0];
  ASSERT_EQ(mx.harmonics.size(), 2u);
  EXPECT_DOUBLE_EQ(mx.harmonics[0].frequency, 30.0);
  EXPECT_DOUBLE_EQ(mx.harmonics[1].frequency, 90.0);
  EXPECT_EQ(mx.harmonics[1].amplitude, -1.5e-4);
  EXPECT_EQ(mx.harmonics[1].phase, 0.75);
  const sim::DofMotion& mz = scene.bodies[0].motion.dofs[2];
  ASSERT_EQ(mz.harmonics.size(), 2u);
  EXPECT_DOUBLE_EQ(mz.harmonics[1].frequency, 60.0);
  EXPECT_EQ(mz.harmonics[0].phase, 1.0);
  EXPECT_EQ(problem.ParametersFromScene(path), x);
  // The one-harmonic spec's problem rejects that scene (x has two harmonics), naming the DOF.
  const FieldDesignProblem one(ParseFieldDesignSpec(kSpec, "ok.yaml", kData));
  try {
    one.ParametersFromScene(path);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("x: expected 1 harmonic(s) at the spec's 30 Hz"),
              std::string::npos)
        << e.what();
  }
  // Orders must increase within a DOF; a second harmonic needs its order.
  std::string bad = text;
  bad.replace(bad.find("order: 3"), 8, "order: 1");
  EXPECT_NE(Error(bad).find("bad.yaml:8: motion.dofs.x[1].order: expected harmonic orders "
                            "strictly increasing within a DOF (> 1), got 1"),
            std::string::npos)
      << Error(bad);
  bad = text;
  bad.replace(bad.find("{order: 2, "), 11, "{");
  EXPECT_NE(Error(bad).find("bad.yaml:9: motion.dofs.z[1]: expected an 'order' (> 1)"),
            std::string::npos)
      << Error(bad);
}

// A full-circle phase is periodic in the local phase: a start near its bound is where the local
// search begins (NLopt's BOBYQA moves a start closer than its initial step to a bound).
TEST(DesignField, LocalSearchBeginsAtAStartNearAPhaseBound) {
  FieldDesignSpec spec = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  spec.dofs[1].phase_lo = -kPi;
  spec.dofs[1].phase_hi = kPi;
  spec.tolerance = 1e-30;
  const FieldDesignProblem problem(spec);
  FieldDesignOptions options;
  options.budget = 2;
  options.global_fraction = 0.0;
  options.start = VectorXd(2);
  options.start << 8.443e-4, -3.1;  // 0.007 of the range from the lower bound
  std::vector<VectorXd> xs;
  options.on_evaluation = [&](const FieldEvaluation& e) { xs.push_back(e.x); };
  DesignField(problem, options);
  ASSERT_EQ(xs.size(), 2u);
  EXPECT_NEAR(xs[1][1], -3.1, 1e-12);
  EXPECT_NEAR(xs[1][0], 8.443e-4, 1e-15);
}

TEST(DesignField, AnExceptionInTheCallbackStopsTheSearchAndIsReported) {
  const FieldDesignProblem problem(ParseFieldDesignSpec(kSpec, "ok.yaml", kData));
  FieldDesignOptions options;
  options.budget = 10;
  options.on_evaluation = [](const FieldEvaluation& e) {
    if (e.index == 2) throw std::runtime_error("disk full");
  };
  const FieldDesignResult r = DesignField(problem, options);
  EXPECT_EQ(r.evaluations, 2);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("disk full"), std::string::npos);
}

TEST(DesignField, IdenticalForAnyThreadCount) {
  FieldDesignSpec spec = ParseFieldDesignSpec(kSpec, "ok.yaml", kData);
  spec.tolerance = 1e-30;  // the whole budget runs
  const FieldDesignProblem problem(spec);
  std::vector<double> errors[2];
  for (const int threads : {1, 2}) {
    FieldDesignOptions options;
    options.budget = 6;
    options.seed = 11;
    options.threads = threads;
    options.on_evaluation = [&](const FieldEvaluation& e) {
      errors[threads - 1].push_back(e.error);
    };
    DesignField(problem, options);
  }
  ASSERT_EQ(errors[0].size(), 6u);
  EXPECT_EQ(errors[0], errors[1]);
}

TEST(FieldDesignSpec, ReadsACsvTargetOnTheGrid) {
  // A `vinci field`-style CSV (extra columns) with the grid's points in grid order.
  const std::string path = ::testing::TempDir() + "/field_design_target.csv";
  {
    std::ofstream out(path);
    out << "x,y,vx,vy,omega\n";
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i)
        out << -0.05 + 0.05 * i << "," << -0.05 + 0.05 * j << "," << i << "," << -j << ",0\n";
  }
  const FieldDesignSpec s =
      ParseFieldDesignSpec("scene: plate_point.yaml\ntarget: {csv: " + path +
                               "}\nmotion: {frequency: 30, dofs: {x: {amplitude: 1e-4}}}\n"
                               "grid: {x: [-0.05, 0.05], y: [-0.05, 0.05], points: [3, 3]}\n",
                           "ok.yaml", kData);
  ASSERT_EQ(s.target.type, TargetType::kCsv);
  ASSERT_EQ(s.target.velocities.size(), 9u);
  EXPECT_EQ(s.target.velocities[5], Vector2d(2, -1));
  // A row off the grid is named with its line.
  {
    std::ofstream out(path);
    out << "x,y,vx,vy\n-0.05,-0.05,1,0\n0.01,-0.05,1,0\n";
  }
  const std::string e = Error("scene: plate_point.yaml\ntarget: {csv: " + path +
                              "}\nmotion: {frequency: 30, dofs: {x: {amplitude: 1e-4}}}\n"
                              "grid: {x: [-0.05, 0.05], y: [-0.05, 0.05], points: [3, 3]}\n");
  EXPECT_NE(e.find("field_design_target.csv:3: x,y: expected the grid point (0, -0.05)"),
            std::string::npos)
      << e;
}

}  // namespace
}  // namespace vinci::planning
