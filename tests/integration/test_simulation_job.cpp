// The one way rtsim runs a simulation in a child: a typed job, its arguments spelt
// in one place, a runner that returns typed results or says why it failed.
#include <rtsim/reports/simulation_job.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include <unistd.h>

using namespace rtsim;

namespace {
bool has(const std::vector<std::string>& words, const std::string& word) {
  return std::find(words.begin(), words.end(), word) != words.end();
}
std::filesystem::path scratch(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("rtsim_job_" + std::to_string(getpid()) + "_" + name);
  std::filesystem::remove_all(dir);
  return dir;
}
}  // namespace

TEST(SimulationJob, ArgumentsNameEverySetFieldAndNothingElse) {
  SimulationJob job;
  job.scene = "cornell";
  job.fidelity = "cycle";
  job.out_dir = "out";
  job.overrides = {{"cores", "4"}};
  job.build_settings = {{"max_leaf_size", "8"}};
  std::vector<std::string> a = job.arguments();
  EXPECT_EQ(a.front(), "simulate");
  EXPECT_TRUE(has(a, "--set") && has(a, "cores=4"));
  EXPECT_TRUE(has(a, "--build-set") && has(a, "max_leaf_size=8"));
  EXPECT_FALSE(has(a, "--camera") || has(a, "--res") || has(a, "--frames") || has(a, "--ao"));
  // A saved tree carries its builder parameters: no --build-set beside --bvh.
  job.bvh = "tree.bvh";
  a = job.arguments();
  EXPECT_TRUE(has(a, "--bvh") && has(a, "tree.bvh"));
  EXPECT_FALSE(has(a, "--build-set"));
  BuildJob build;
  build.scene = "cornell";
  build.out = "t.bvh";
  build.build_settings = {{"seed", "3"}, {"camera", "view2"}, {"max_leaf_size", "4"}};
  build.camera = "view2";
  const auto b = build.arguments();
  EXPECT_EQ(b.front(), "build");
  EXPECT_EQ(std::count(b.begin(), b.end(), "--camera"), 1);  // its own flag, once
  EXPECT_FALSE(has(b, "seed=3"));
  EXPECT_TRUE(has(b, "max_leaf_size=4"));
}

TEST(SimulationJob, TheRunnerReturnsTheChildsResultsOrItsReason) {
  const JobRunner runner(RTSIM_BINARY);
  SimulationJob job;
  job.scene = "cornell";
  job.resolution = "16x16";
  job.fidelity = "lt";
  job.out_dir = scratch("ok");
  const SimulationOutcome out = runner.simulate(job, job.out_dir / "log.txt");
  EXPECT_GT(out.stats.at("rays").at("total").at("value").get<double>(), 256);
  EXPECT_EQ(out.config.at("fidelity").get<std::string>(), "lt");
  EXPECT_GT(out.host.at("cpu_seconds").at("value").get<double>(), 0);
  job.scene = "no-such-scene";
  job.out_dir = scratch("bad");
  try {
    runner.simulate(job, job.out_dir / "log.txt");
    FAIL() << "an unknown scene ran";
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("exit code 2"), std::string::npos) << what;
    EXPECT_NE(what.find("no-such-scene"), std::string::npos) << what;
    EXPECT_NE(what.find("log.txt"), std::string::npos) << what;
  }
  std::filesystem::remove_all(scratch("ok"));
  std::filesystem::remove_all(scratch("bad"));
}
