// simulate | trace --trace-ray (model/sim/ray_probe.h): one ray's requests are the
// same sequence at every fidelity level and in `trace` (the core decides them);
// which level served each one and its latency are the levels' own; the ray's
// totals are its counters; bad coordinates, types and indexes are refused naming
// the flag.
#include "cli_runner.h"
#include "stats_support.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>

namespace {

using nlohmann::json;

json simulated(const std::string& level, const std::string& ray, const std::filesystem::path& dir) {
  const auto out = dir / level;
  const CliResult r = run_rtsim("simulate --scene interior --res 24x24 --config mobile-gpu --fidelity " + level +
                                " --trace-ray " + ray + " --out-dir " + out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("ray trace: "), std::string::npos) << r.output;
  std::ifstream in(out / "ray_trace.json");
  return json::parse(in);
}

json traced(const std::string& ray) {
  const CliResult r = run_rtsim_command(std::string(RTSIM_BINARY) +
                                        " trace --scene interior --res 24x24 --config mobile-gpu --json --trace-ray " +
                                        ray + " 2>/dev/null");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return json::parse(r.output).at("ray_trace");
}

// What the core decides: the requests, in order, and what they carry.
json sequence(const json& trace) {
  json out = json::array();
  for (const json& r : trace.at("requests"))
    out.push_back({r.at("step"), r.at("kind"), r.at("rw"), r.at("line"), r.at("bytes"), r.at("records")});
  return out;
}

class RayTrace : public testing::TestWithParam<std::string> {};

}  // namespace

TEST_P(RayTrace, IsTheSameSequenceAtEveryLevelWithTheLevelsOwnTimes) {
  const std::string ray = GetParam();
  const auto dir = scratch_folder("ray_trace", ray.substr(ray.rfind(',') + 1));
  const json functional = simulated("functional", ray, dir);
  const json lt = simulated("lt", ray, dir);
  const json cycle = simulated("cycle", ray, dir);
  const json trace = traced(ray);
  ASSERT_GT(functional.at("requests").size(), 3u) << functional.dump(1);
  EXPECT_EQ(sequence(lt), sequence(functional));
  EXPECT_EQ(sequence(cycle), sequence(functional));
  EXPECT_EQ(sequence(trace), sequence(functional));
  for (const char* total : {"requests", "steps", "trv_ops", "ist_ops", "node_fetches", "triangle_fetches", "fetch_bytes"})
    for (const json* t : {&lt, &cycle, &trace}) EXPECT_EQ(t->at("totals").at(total), functional.at("totals").at(total)) << total;
  // The requests are the ray's fetches: one node fetch a node step, each in one line here.
  size_t node_requests = 0;
  for (const json& r : functional.at("requests")) node_requests += r.at("kind") == "node";
  EXPECT_EQ(node_requests, functional.at("totals").at("node_fetches").get<size_t>());
  EXPECT_EQ(functional.at("totals").at("node_fetches"), functional.at("totals").at("trv_ops"));

  const std::set<std::string> untimed = {"L1 hit", "L1 write (posted)", "L2 hit", "DRAM"};
  for (const json& r : functional.at("requests")) {
    EXPECT_TRUE(untimed.count(r.at("served"))) << r.dump();
    EXPECT_FALSE(r.contains("latency_cycles"));
  }
  const std::set<std::string> timed = {"L1 hit",       "L1 MSHR merge", "L1 write (posted)", "L2 hit",
                                       "L2 MSHR merge", "DRAM row hit", "DRAM row miss",     "DRAM row conflict"};
  for (const json* t : {&lt, &cycle}) {
    int64_t previous = -1;
    for (const json& r : t->at("requests")) {
      EXPECT_TRUE(timed.count(r.at("served"))) << r.dump();
      // An L1 hit takes at least mobile-gpu's 20-cycle hit latency; no request goes out
      // before the one the ray sent before it.
      if (r.at("served") == "L1 hit" && r.at("rw") == "R") EXPECT_GE(r.at("latency_cycles").get<int64_t>(), 20);
      EXPECT_GE(r.at("cycle").get<int64_t>(), previous) << r.dump();
      previous = r.at("cycle");
    }
    EXPECT_GT(t->at("totals").at("cycles").get<int64_t>(), 0);
  }
  std::filesystem::remove_all(dir);
}

// A primary ray, and an AO ray that the levels spawn at different times.
INSTANTIATE_TEST_SUITE_P(Rays, RayTrace, testing::Values("12,13", "12,13,ao,2"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param.find("ao") == std::string::npos ? std::string("primary")
                                                                               : std::string("ao");
                         });

TEST(RayTrace, BadCoordinatesTypesAndIndexesAreRefusedNamingTheFlag) {
  const auto dir = scratch_folder("ray_trace", "bad");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"24,3", "--trace-ray X (the image is 24 pixels wide)"},
      {"3,24", "--trace-ray Y (the image is 24 pixels high)"},
      {"3", "--trace-ray: expected X,Y[,TYPE[,INDEX]]"},
      {"3,4,5,6,7", "--trace-ray: expected X,Y[,TYPE[,INDEX]]"},
      {"-1,4", "--trace-ray X"},
      {"03,4", "--trace-ray X"},
      {"3,4,sun", "--trace-ray TYPE: unknown ray type 'sun'"},
      {"3,4,ao,x", "--trace-ray INDEX"},
      {"3,4,ao,900", "--trace-ray: the frame has no ao ray 900 of pixel 3,4"},
      {"3,4,primary,1", "--trace-ray: the frame has no primary ray 1 of pixel 3,4"},
  };
  for (const auto& [ray, message] : cases) {
    for (const std::string command : {"simulate --out-dir " + (dir / "out").string(), std::string("trace")}) {
      const CliResult r = run_rtsim(command + " --scene interior --res 24x24 --trace-ray " + ray);
      EXPECT_EQ(r.exit_code, 2) << command << " " << ray << "\n" << r.output;
      EXPECT_NE(r.output.find(message), std::string::npos) << command << " " << ray << "\n" << r.output;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "out" / "ray_trace.json"));
  std::filesystem::remove_all(dir);
}
