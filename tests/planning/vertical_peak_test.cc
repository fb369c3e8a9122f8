// The vertical actuator limit's two estimates (docs/planning.md, "The objective"): the default
// bound adds the DOFs' peaks; `vertical_peak: exact` takes the peak of the plate's normal
// acceleration over the grid itself.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "vinci/planning/field_design.h"
#include "vinci/planning/field_design_spec.h"

namespace vinci::planning {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/planning/data";
constexpr double kPi = 3.14159265358979323846;
constexpr double kTilt = 1.0e-3;  // rad

// A wobble (roll and pitch in quadrature, angular acceleration ω² kTilt) with a free vertical
// amplitude, on a grid over [−0.1, 0.1] × [−0.05, 0.05].
std::string Spec(const std::string& extra) {
  return "scene: plate_point.yaml\n"
         "target: {type: whirlpool}\n"
         "motion:\n"
         "  frequency: 30\n"
         "  dofs:\n"
         "    z: {amplitude: [0, 1.0e-4], phase: 0.3}\n"
         "    roll: {amplitude: 1.0e-3, phase: 0}\n"
         "    pitch: {amplitude: 1.0e-3, phase: 1.5707963267948966}\n"
         "  max_vertical_acceleration: 9.0\n" +
         extra + "grid: {x: [-0.1, 0.1], y: [-0.05, 0.05], points: [3, 3]}\ncycles: 2\n";
}

std::string Error(const std::string& text) {
  try {
    ParseFieldDesignSpec(text, "bad.yaml", kData);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(VerticalPeak, ReadsTheKeyAndRejectsOtherValues) {
  EXPECT_FALSE(ParseFieldDesignSpec(Spec(""), "ok.yaml", kData).exact_vertical_peak);
  EXPECT_FALSE(
      ParseFieldDesignSpec(Spec("  vertical_peak: bound\n"), "ok.yaml", kData).exact_vertical_peak);
  EXPECT_TRUE(
      ParseFieldDesignSpec(Spec("  vertical_peak: exact\n"), "ok.yaml", kData).exact_vertical_peak);
  const std::string e = Error(Spec("  vertical_peak: sampled\n"));
  EXPECT_NE(e.find("bad.yaml:10"), std::string::npos) << e;
  EXPECT_NE(e.find("bound or exact"), std::string::npos) << e;
}

TEST(VerticalPeak, TheWobblesPeakIsItsAccelerationTimesTheCornersDistance) {
  const double w2 = std::pow(2 * kPi * 30, 2);
  const FieldDesignProblem bound(ParseFieldDesignSpec(Spec(""), "ok.yaml", kData));
  const FieldDesignProblem exact(
      ParseFieldDesignSpec(Spec("  vertical_peak: exact\n"), "ok.yaml", kData));
  VectorXd none(1), some(1);
  none << 0.0;
  some << 5.0e-5;
  // The wobble alone: a_n = −ω² kTilt (y sin ωt − x cos ωt), |a_n| ≤ ω² kTilt |p|: at the corner
  // |p| = √(0.1² + 0.05²); the bound adds max|y| and max|x|.
  EXPECT_NEAR(bound.PeakVerticalAcceleration(none), w2 * kTilt * (0.1 + 0.05), 1e-12);
  const double corner = w2 * kTilt * std::hypot(0.1, 0.05);
  EXPECT_NEAR(exact.PeakVerticalAcceleration(none), corner, 1e-6 * corner);
  EXPECT_LT(exact.PeakVerticalAcceleration(none), bound.PeakVerticalAcceleration(none));
  // With z: every harmonic at f, so the peak at a corner p is ω² |A_z e^{iφ_z} + kTilt (y − i x)|
  // (phasors of sin(ωt + φ): roll's y at 0, pitch's −x at π/2), the largest over the corners.
  double expected = 0.0;
  for (const double x : {-0.1, 0.1})
    for (const double y : {-0.05, 0.05}) {
      const double re = 5.0e-5 * std::cos(0.3) + kTilt * y;
      const double im = 5.0e-5 * std::sin(0.3) - kTilt * x;
      expected = std::max(expected, w2 * std::hypot(re, im));
    }
  EXPECT_NEAR(exact.PeakVerticalAcceleration(some), expected, 1e-6 * expected);
  EXPECT_NEAR(bound.PeakVerticalAcceleration(some), w2 * (5.0e-5 + kTilt * 0.15), 1e-12);
}

}  // namespace
}  // namespace vinci::planning
