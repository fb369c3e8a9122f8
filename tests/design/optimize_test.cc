// The design search on problems with known optima.
#include "vinci/design/optimize.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "vinci/design/spec.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";

// A block launched at v = 1 m/s stops after d = v²/(2 μ g) (Stewart–Trinkle, implicit step:
// d = v²/(2 μ g) − h v/2). The friction that stops it at 0.5 m is found to 1e-3.
TEST(DesignOptimize, BlockStoppingFrictionMatchesClosedForm) {
  const DesignSpec spec = LoadDesignSpec(kData + "block_distance.yaml");
  for (const std::string optimizer : {"direct-l+bobyqa", "crs2+sbplx"}) {
    JobOptions o;
    o.optimizer = optimizer;
    const DesignResult r = RunDesign(spec, o);
    ASSERT_TRUE(r.errors.empty()) << r.errors.front();
    const double g = 9.81, v = 1.0, d = 0.5, h = 1e-3;
    const double mu_continuous = v * v / (2 * g * d);
    const double mu_discrete = v * v / (2 * g * (d + h * v / 2));
    EXPECT_NEAR(r.best[0], mu_discrete, 1e-3) << optimizer;
    EXPECT_NEAR(r.best[0], mu_continuous, 1e-3) << optimizer;
    EXPECT_LT(r.best_search.objective, 2e-3) << optimizer;
    EXPECT_LE(r.evaluations, spec.budget / spec.samples + 2) << optimizer;
  }
}

}  // namespace
}  // namespace vinci::design
