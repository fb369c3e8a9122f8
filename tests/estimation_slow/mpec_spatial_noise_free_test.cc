// The MPEC estimator (mpec_estimator.h) on a spatial scene: a noise-free log of a box sliding to
// rest on a plane (4 corner contacts, 8 friction directions; positions and quaternions logged
// every 6 steps, every third gap 7) gives the true μ with both complementarity treatments.
// The standard error is not asserted: the Laplace s.e. is not stable on noise-free logs
// (measured: the penalty treatment's was finite in one run, NaN in the next; bench/README.md).
// Slow: ~70 s of CPU on the loaded shared machine (225 steps of ~60 step unknowns, two
// homotopies).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "../estimation/estimation_test_util.h"
#include "vinci/estimation/mpec_estimator.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

TEST(MpecSpatialSlow, SlidingBoxNoiseFreeRecoversMu) {
  const sim::Simulator sim(sim::ParseScene(testing::kSpatialBox, "box.yaml"));
  const std::string path =
      testing::SyntheticLog(sim, "box", 0.3, 0.45, 6, 0.0, 1, "mpec_box_exact.csv");
  const Log log = ReadLog({path}, sim.scene());
  for (const ComplementarityMethod method :
       {ComplementarityMethod::kScholtes, ComplementarityMethod::kPenalty}) {
    MpecOptions o;
    o.params = {"mu.default"};
    o.noise_sigma = 1e-3;
    o.solver.method = method;
    const MpecEstimateResult r = EstimateMpec(sim, log, o);
    EXPECT_TRUE(r.converged) << ToString(method) << ": " << r.reason;
    EXPECT_NEAR(r.estimates[0], 0.3, 1e-4) << ToString(method) << ": " << r.reason;
    EXPECT_LE(r.complementarity_violation, 1e-8) << ToString(method);
    EXPECT_LE(r.equality_violation, 1e-8) << ToString(method);
    EXPECT_LT(r.episodes[0].rms_residual, 1e-6) << ToString(method);
  }
}

}  // namespace
}  // namespace vinci::estimation
