// The log reader: `vinci simulate`-style columns accepted, bad logs rejected with file:line.
#include "vinci/estimation/log.h"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "estimation_test_util.h"
#include "vinci/sim/model/scene_file.h"

namespace vinci::estimation {
namespace {

using testing::WriteFile;

sim::Scene PlanarScene() { return sim::ParseScene(testing::kPlanarBlock, "block.yaml"); }
sim::Scene SpatialScene() { return sim::ParseScene(testing::kSpatialBox, "box.yaml"); }

// The message of the std::invalid_argument reading `text` throws, or "(accepted)".
std::string Error(const std::string& name, const std::string& text, const sim::Scene& scene) {
  const std::string path = WriteFile(name, text);
  try {
    ReadEpisode(path, scene);
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    // Every message starts with the file name.
    EXPECT_EQ(msg.rfind(path, 0), 0u) << msg;
    return msg.substr(path.size());
  }
  return "(accepted)";
}

TEST(EstimationLog, ReadsSimulateOutputWithReportColumnsAndComments) {
  const sim::Scene scene = PlanarScene();
  const std::string path = WriteFile(
      "sim.csv",
      "# a comment\n"
      "step,t,floor.x,floor.y,floor.theta,floor.vx,floor.vy,floor.omega,block.x,block.y,"
      "block.theta,block.vx,block.vy,block.omega,contacts,solver_iterations,residual,min_gap,"
      "status\n"
      "0,0,0,0,0,0,0,0,0,0.1,0,1.5,0,0,2,3,0,0,ok\n"
      "\n"
      "# another\n"
      "1,0.002,0,0,0,0,0,0,0.003,0.1,0,1.49,0,0,2,3,0,0,ok\n"
      "2,0.005,0,0,0,0,0,0,0.0074,0.1,0,1.48,0,0,2,3,0,0,ok\n");
  const Episode ep = ReadEpisode(path, scene);
  ASSERT_EQ(ep.num_samples(), 3);
  EXPECT_EQ(ep.t[2], 0.005);  // irregular sampling is fine
  EXPECT_EQ(ep.lines[0], 3);
  EXPECT_EQ(ep.lines[1], 6);
  ASSERT_EQ(ep.bodies.size(), 2u);
  EXPECT_FALSE(ep.bodies[0].dynamic);  // floor: read, not fitted
  EXPECT_TRUE(ep.bodies[1].dynamic);
  EXPECT_TRUE(ep.bodies[1].has_orientation);
  EXPECT_EQ(ep.bodies[1].pose(2, 0), 0.0074);
  EXPECT_EQ(ep.bodies[1].velocity(1, 0), 1.49);
  EXPECT_EQ(ResidualsPerSample(ep, scene.dim), 3);  // x, y, theta of the block only
}

TEST(EstimationLog, PositionsOnlyAndSpatialQuaternions) {
  const Episode p = ReadEpisode(WriteFile("pos.csv", "t,block.x,block.y\n0,0,0.1\n0.01,0.01,0.1\n"),
                                PlanarScene());
  EXPECT_FALSE(p.bodies[0].has_orientation);
  EXPECT_EQ(p.bodies[0].velocity.rows(), 0);
  const Episode s = ReadEpisode(WriteFile("q.csv",
                                          "t,box.x,box.y,box.z,box.qw,box.qx,box.qy,box.qz\n"
                                          "0,0,0,0.05,1,0,0,0\n0.01,0.01,0,0.05,0.9999999,0,0,0\n"),
                                SpatialScene());
  EXPECT_TRUE(s.bodies[0].has_orientation);
  EXPECT_NEAR(s.bodies[0].pose(1, 3), 1.0, 1e-15);  // renormalized
}

TEST(EstimationLog, RejectsBadLogsWithFileAndLine) {
  const sim::Scene planar = PlanarScene();
  const std::string h = "t,block.x,block.y,block.theta\n";
  EXPECT_EQ(Error("dup_t.csv", h + "0,0,0.1,0\n# c\n0.01,0,0.1,0\n0.01,0,0.1,0\n", planar)
                .rfind(":5: duplicated time", 0),
            0u);
  EXPECT_EQ(Error("mono.csv", h + "0,0,0.1,0\n0.02,0,0.1,0\n0.01,0,0.1,0\n", planar)
                .rfind(":4: non-monotone time", 0),
            0u);
  EXPECT_EQ(
      Error("nan.csv", h + "0,0,0.1,0\n0.01,nan,0.1,0\n", planar).rfind(":3: column 'block.x'", 0),
      0u);
  EXPECT_NE(Error("inf.csv", h + "0,0,inf,0\n", planar).find(":2: column 'block.y': inf"),
            std::string::npos);
  EXPECT_NE(Error("text.csv", h + "0,0,abc,0\n", planar).find("'abc' is not a number"),
            std::string::npos);
  EXPECT_EQ(Error("unknown.csv", "t,block.x,block.y,block.speed\n0,0,0,0\n", planar)
                .rfind(":1: unknown column 'block.speed'", 0),
            0u);
  EXPECT_EQ(Error("nodot.csv", "t,foo,block.x,block.y\n0,0,0,0\n", planar)
                .rfind(":1: unknown column 'foo'", 0),
            0u);
  EXPECT_EQ(Error("body.csv", "# header next\nt,cube.x,cube.y\n0,0,0\n", planar)
                .rfind(":2: column 'cube.x': body 'cube' is not in the scene", 0),
            0u);
  // A spatial component in a planar scene is an unknown column.
  EXPECT_EQ(Error("z.csv", "t,block.x,block.y,block.z\n0,0,0,0\n", planar)
                .rfind(":1: unknown column 'block.z'", 0),
            0u);
  EXPECT_EQ(Error("fields.csv", h + "0,0,0.1\n", planar).rfind(":2: 3 fields", 0), 0u);
  EXPECT_EQ(
      Error("not.csv", "x,block.x,block.y\n0,0,0\n", planar).rfind(":1: unknown column 'x'", 0),
      0u);
  EXPECT_EQ(Error("not2.csv", "block.x,block.y\n0,0\n", planar).rfind(":1: no 't' column", 0), 0u);
  EXPECT_EQ(Error("empty.csv", h, planar).rfind(":1: the log has no samples", 0), 0u);
  EXPECT_EQ(Error("static.csv", "t,floor.x,floor.y\n0,0,0\n", planar)
                .rfind(":1: the log observes no dynamic body", 0),
            0u);
  EXPECT_NE(Error("pos.csv", "t,block.x\n0,0\n", planar).find(":1: body 'block' has no 'block.y'"),
            std::string::npos);

  const sim::Scene spatial = SpatialScene();
  const std::string hs = "t,box.x,box.y,box.z,box.qw,box.qx,box.qy,box.qz\n";
  EXPECT_EQ(Error("quat.csv", hs + "0,0,0,0.05,1,0,0,0\n0.01,0,0,0.05,0.9,0,0,0\n", spatial)
                .rfind(":3: body 'box': quaternion norm 0.9", 0),
            0u);
  EXPECT_NE(Error("partq.csv", "t,box.x,box.y,box.z,box.qw\n0,0,0,0,1\n", spatial)
                .find(":1: body 'box' has only some of its quaternion columns"),
            std::string::npos);
}

TEST(EstimationLog, TooFewSamplesForTheUnknowns) {
  const sim::Scene scene = PlanarScene();
  Log log;
  log.episodes.push_back(
      ReadEpisode(WriteFile("few.csv", "t,block.x,block.y\n0,0,0.1\n0.1,0.1,0.1\n# end\n"), scene));
  // 2 samples × 2 residuals = 4 < 6 initial-state unknowns.
  try {
    CheckEnoughSamples(log, scene.dim, 1, {6});
    FAIL() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("few.csv:3: fewer samples than unknowns"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(CheckEnoughSamples(log, scene.dim, 1, {0}));
  EXPECT_THROW(CheckEnoughSamples(log, scene.dim, 5, {0}), std::invalid_argument);
}

}  // namespace
}  // namespace vinci::estimation
