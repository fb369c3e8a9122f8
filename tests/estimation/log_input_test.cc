// The log reader's input guards (issue 18): the file is read bounded (no devices, at most
// sim::kMaxInputFileBytes) and ParseEpisode reads the same text as ReadEpisode (the entry point
// of fuzz/fuzz_log.cc).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "estimation_test_util.h"
#include "vinci/estimation/log.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

TEST(EstimationLogInput, ADeviceIsRejectedNotReadForever) {
  const sim::Scene scene = sim::ParseScene(testing::kPlanarBlock, "block.yaml");
  try {
    ReadEpisode("/dev/zero", scene);
    FAIL() << "accepted /dev/zero";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/zero: cannot read the log file: expected a regular "
                                         "file, got a device"),
              std::string::npos)
        << e.what();
  }
}

TEST(EstimationLogInput, ParseEpisodeReadsWhatReadEpisodeReads) {
  const sim::Scene scene = sim::ParseScene(testing::kPlanarBlock, "block.yaml");
  const std::string text = "# log\nt,block.x,block.y,block.theta\n0,0,0.1,0\n0.01,0.01,0.1,0.02\n";
  const std::string path = testing::WriteFile("parse.csv", text);
  const Episode a = ReadEpisode(path, scene);
  const Episode b = ParseEpisode(text, path, scene);
  EXPECT_EQ(a.t, b.t);
  EXPECT_EQ(a.lines, b.lines);
  ASSERT_EQ(a.bodies.size(), 1u);
  ASSERT_EQ(b.bodies.size(), 1u);
  EXPECT_EQ(a.bodies[0].pose, b.bodies[0].pose);
  EXPECT_EQ(b.lines, (std::vector<int>{3, 4}));
}

}  // namespace
}  // namespace vinci::estimation
