// The units every level shares (model/sim/units): an issue port takes work back to
// back in the order it is reserved, and a result comes a latency after its last item.
#include <rtsim/model/sim/units/issue_port.h>
#include <rtsim/model/sim/units/raygen_unit.h>

#include <gtest/gtest.h>

namespace rtsim::sim {
namespace {

TEST(Units, AnIssuePortTakesWorkBackToBackAndItsResultComesALatencyAfterTheLastItem) {
  IssuePort port;
  // Three tests at 1000 ps each from t = 500, latency 8000: the last enters at 2500.
  const Issue a = port.reserve(500, 3, 1000, 8000);
  EXPECT_EQ(a.start, 500u);
  EXPECT_EQ(a.end, 3500u);
  EXPECT_EQ(a.ready, 10500u);
  // Work that arrives while the port is taken waits for it; work after it does not.
  const Issue b = port.reserve(1000, 1, 1000, 4000);
  EXPECT_EQ(b.start, 3500u);
  EXPECT_EQ(b.ready, 7500u);
  const Issue c = port.reserve(9000, 2, 500, 0);
  EXPECT_EQ(c.start, 9000u);
  EXPECT_EQ(c.end, 10000u);
  EXPECT_EQ(c.ready, 9500u);
  EXPECT_EQ(port.free_ps(), 10000u);
}

TEST(Units, IntervalsRoundToWholePicosecondsAndNeverReachZero) {
  EXPECT_EQ(issue_interval_ps(1.0, 667), 667u);
  EXPECT_EQ(issue_interval_ps(2.0, 667), 334u);  // 333.5 rounds up
  EXPECT_EQ(issue_interval_ps(0.5, 1000), 2000u);
  EXPECT_EQ(issue_interval_ps(64.0, 10), 1u);  // 0.16 ps: at least one
}

TEST(Units, RayGenerationIssuesAtItsRateAndNeverBeforeItIsAsked) {
  HardwareConfig config;
  config.clock_mhz = 1000;              // 1000 ps a cycle
  config.raygen_rays_per_cycle = 0.5;  // a ray every other cycle
  RayGenUnit raygen(config);
  EXPECT_EQ(raygen.earliest(0), 0u);
  EXPECT_EQ(raygen.issue(0), 0u);
  EXPECT_EQ(raygen.earliest(100), 2000u);
  EXPECT_EQ(raygen.issue(100), 2000u);
  EXPECT_EQ(raygen.issue(9000), 9000u);
  EXPECT_EQ(raygen.earliest(9000), 11000u);
}

}  // namespace
}  // namespace rtsim::sim
