// The planning specs' resource limits and input guards (issue 18, deliverable 3; found by
// fuzz/fuzz_field_design.cc and fuzz/fuzz_plan.cc): each a file:line rejection where the spec
// used to hang, read forever or overflow.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "vinci/planning/field_design_spec.h"
#include "vinci/planning/plan.h"
#include "vinci/planning/plan_spec.h"

namespace vinci::planning {
namespace {

const std::string kFieldData = VINCI_SOURCE_DIR "/tests/planning/data";
const std::string kPlanData = VINCI_SOURCE_DIR "/examples/plan";

template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

std::string FieldError(const std::string& text) {
  return ErrorOf([&] { ParseFieldDesignSpec(text, "bad.yaml", kFieldData); });
}
std::string PlanError(const std::string& text) {
  return ErrorOf([&] { (void)PlanProblem(ParsePlanSpec(text, "bad.yaml", kPlanData)); });
}

const std::string kPlanHead =
    "scene: plate_one_part.yaml\n"
    "plate_extent: {x: [-0.15, 0.15], y: [-0.15, 0.15]}\n"
    "goal: {part: {position: [0.04, 0.05]}}\n";
std::string Primitive(const std::string& name, double frequency) {
  return "  - {name: " + name + ", motion: {frequency: " + std::to_string(frequency) +
         ", x: {harmonics: [{order: 1, amplitude: 8.4e-4, phase: 0}]}}}\n";
}

// yaml-cpp 0.7's YAML::Load never returns on a stray top-level ',' (growing memory).
TEST(PlanningSpecLimits, StrayCommaIsASyntaxErrorNotAHang) {
  for (const std::string& text : {std::string(","), std::string("# spec\n, scene: x\n")}) {
    const std::string line = text == "," ? "1" : "2";
    EXPECT_NE(FieldError(text).find("bad.yaml:" + line + ": YAML syntax error"), std::string::npos)
        << FieldError(text);
    EXPECT_NE(PlanError(text).find("bad.yaml:" + line + ": YAML syntax error"), std::string::npos)
        << PlanError(text);
  }
}

// The target CSV was read with an unbounded stream: /dev/zero never ended.
TEST(PlanningSpecLimits, TargetCsvMustBeARegularFile) {
  const std::string e = FieldError(
      "scene: plate_point.yaml\ntarget: {csv: /dev/zero}\n"
      "motion: {frequency: 30, dofs: {x: {amplitude: [1e-4, 1e-3]}}}\n"
      "grid: {x: [-0.05, 0.05], y: [-0.05, 0.05], points: [3, 3]}\n");
  EXPECT_NE(e.find("bad.yaml:2: target.csv: /dev/zero: cannot read the target CSV: expected a "
                   "regular file, got a device"),
            std::string::npos)
      << e;
}

TEST(PlanningSpecLimits, PlanCountsAndTimesAreBounded) {
  const std::string prims = "primitives:\n" + Primitive("a", 30);
  EXPECT_NE(PlanError(kPlanHead + prims + "time_limit: 1e300\n")
                .find("bad.yaml:6: time_limit: expected a number of seconds in (0, 1e6]"),
            std::string::npos)
      << PlanError(kPlanHead + prims + "time_limit: 1e300\n");
  std::string many = "primitives:\n";
  for (int i = 0; i <= PlanLimits::kMaxPrimitives; ++i)
    many += Primitive("p" + std::to_string(i), 30);
  EXPECT_NE(PlanError(kPlanHead + many).find("bad.yaml:5: primitives: expected at most 1000"),
            std::string::npos);
  // 0.1 Hz at dt = T/160 of 30 Hz: 48,000 steps per cycle; × 100,000 settle cycles = 4.8e9 steps
  // (Resimulate's int step count overflowed).
  const std::string slow = "primitives:\n" + Primitive("slow", 0.1) + "settle_cycles: 100000\n";
  const std::string e = PlanError(kPlanHead + slow);
  EXPECT_NE(e.find("bad.yaml:5: primitives[0].motion ('slow'): expected at most 1000000000 time "
                   "steps per application"),
            std::string::npos)
      << e;
  EXPECT_EQ(PlanError(kPlanHead + "primitives:\n" + Primitive("ok", 30)), "(accepted)");
}

}  // namespace
}  // namespace vinci::planning
