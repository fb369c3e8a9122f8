// The design-spec loader's resource limits and input guards (issue 18, deliverable 3; found by
// fuzz/fuzz_design.cc): each a file:line rejection where the spec used to wrap, hang or run
// for years.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "vinci/design/spec.h"

namespace vinci::design {
namespace {

const std::string kData = VINCI_SOURCE_DIR "/tests/design/data/";
const std::string kHead =
    "scene: block_slide.yaml\nparameters: [{name: mu.default, lower: 0.01, upper: 1.0}]\n"
    "objective: {type: success, body: block, region: {min: [0.4, 0], max: [0.6, 0.1]}}\n";

std::string Error(const std::string& text) {
  try {
    ParseDesignSpec(text, "bad.yaml", kData);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(DesignSpecLimits, CountsAndBudgetsAreBoundedNotWrapped) {
  struct Case {
    std::string text, expected;
  };
  const std::string d = "duration: 1\n";
  const Case cases[] = {
      // 2^32 + 1 used to become validation_samples = 1 (int truncation).
      {kHead + d + "validation_samples: 4294967297\n",
       "bad.yaml:5: validation_samples: expected an integer in [1, 10000000]"},
      {kHead + d + "samples: 10000001\n", "bad.yaml:5: samples: expected an integer in [1, "},
      {kHead + d + "budget: 10000000000\n", "bad.yaml:5: budget: expected an integer in [1, "},
      // std::stoll read "1-2" as 1.
      {kHead + d + "budget: 1-2\n", "bad.yaml:5: budget: expected an integer in [1, "},
      {kHead + d + "screening: [{type: geometric, samples: 4294967296}]\n",
       "bad.yaml:5: screening[0].samples: expected an integer in [0, 10000000]"},
      // duration / dt (dt = 1e-3 in the scene) is the step count of every rollout.
      {kHead + "duration: 1e300\n", "bad.yaml:4: duration: expected duration / dt <= 1e+08"},
      {kHead + d + "screening: [{type: short, duration: 1, dt: 1e-12, min_success: 0.5}]\n",
       "bad.yaml:5: screening[0].dt: expected duration / dt <= 1e+08"},
  };
  for (const Case& c : cases) {
    const std::string e = Error(c.text);
    EXPECT_NE(e.find(c.expected), std::string::npos)
        << "got: " << e << "\nexpected: " << c.expected;
  }
  std::string stages = kHead + d + "screening:\n";
  for (int i = 0; i <= DesignLimits::kMaxScreeningStages; ++i) stages += "  - {type: geometric}\n";
  EXPECT_NE(Error(stages).find("bad.yaml:6: screening: expected at most 100 stages"),
            std::string::npos)
      << Error(stages);
}

// yaml-cpp 0.7's YAML::Load never returns on a stray top-level ',' (growing memory); a scene
// path naming a device was read forever.
TEST(DesignSpecLimits, InputsThatUsedToHang) {
  EXPECT_NE(Error(",").find("bad.yaml:1: YAML syntax error: unexpected ','"), std::string::npos)
      << Error(",");
  EXPECT_NE(Error("# spec\n, scene: x\n").find("bad.yaml:2: YAML syntax error"), std::string::npos);
  const std::string e =
      Error("scene: /dev/zero\n" + kHead.substr(kHead.find('\n') + 1) + "duration: 1\n");
  EXPECT_NE(e.find("bad.yaml:1: scene: expected a readable scene file"), std::string::npos) << e;
  EXPECT_NE(e.find("a device"), std::string::npos) << e;
}

}  // namespace
}  // namespace vinci::design
