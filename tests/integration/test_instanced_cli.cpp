// Two-level trees from the command line: `build --instanced --out` saves one,
// `simulate --instanced --bvh` replays it with the stats of a tree built in the
// run, the wrong form is refused saying which flag, and `table1 --instanced` runs
// the patent's comparison on the instanced scene (XFM and TLAS columns, rdh left out).
#include "integration/cli_runner.h"

#include <rtsim/reports/child_process.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

namespace fs = std::filesystem;
using rtsim::shell_quote;

fs::path fresh(const std::string& name) { return fresh_test_folder("rtsim_instanced_cli", name); }

CliResult run_in(const fs::path& cwd, const std::string& args) { return run_rtsim_in(cwd, args); }

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

const std::string kScene = "--scene forest_instanced";

TEST(InstancedCli, ASavedTwoLevelTreeReplaysWithTheStatsOfOneBuiltInTheRun) {
  const fs::path dir = fresh("replay");
  const CliResult build = run_in(dir, "build " + kScene + " --instanced --node-format bvh6-64q --out t.bvh --json");
  ASSERT_EQ(build.exit_code, 0) << build.output;
  const nlohmann::json report = nlohmann::json::parse(build.output.substr(build.output.find('{')));
  EXPECT_EQ(report.at("instanced"), true);
  const nlohmann::json& tree = report.at("trees").at(0);
  EXPECT_EQ(tree.at("valid"), true);
  EXPECT_EQ(tree.at("instances"), report.at("instances"));
  EXPECT_GT(tree.at("tlas_nodes").get<uint64_t>(), 0u);
  const std::string run = " --instanced --node-format bvh6-64q --fidelity functional --res 24x24";
  const CliResult saved = run_in(dir, "simulate " + kScene + run + " --bvh t.bvh --out-dir saved");
  ASSERT_EQ(saved.exit_code, 0) << saved.output;
  const CliResult built = run_in(dir, "simulate " + kScene + run + " --out-dir built");
  ASSERT_EQ(built.exit_code, 0) << built.output;
  const std::string a = read_text(dir / "saved" / "stats.json"), b = read_text(dir / "built" / "stats.json");
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, b);
  EXPECT_NE(a.find("xfm_ops"), std::string::npos);
  // trace draws where the rays enter instances; a flat trace has no such picture.
  ASSERT_EQ(run_in(dir, "trace " + kScene + " --instanced --res 16x16 --out-dir pic").exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "pic" / "xfm_heatmap.png"));
  ASSERT_EQ(run_in(dir, "trace --scene cornell --res 16x16 --out-dir flat").exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "flat" / "ops_heatmap.png"));
  EXPECT_FALSE(fs::exists(dir / "flat" / "xfm_heatmap.png"));
  fs::remove_all(dir);
}

TEST(InstancedCli, TheOtherFormsTreeIsRefusedNamingTheFlagToChange) {
  const fs::path dir = fresh("forms");
  ASSERT_EQ(run_in(dir, "build " + kScene + " --instanced --out two.bvh").exit_code, 0);
  const CliResult flat = run_in(dir, "simulate " + kScene + " --bvh two.bvh --fidelity functional --res 8x8 --out-dir o");
  EXPECT_EQ(flat.exit_code, 2) << flat.output;
  EXPECT_NE(flat.output.find("two.bvh: header.scene_hash"), std::string::npos) << flat.output;
  EXPECT_NE(flat.output.find("add --instanced"), std::string::npos) << flat.output;
  EXPECT_FALSE(fs::exists(dir / "o" / "stats.json"));
  const CliResult rdh = run_in(dir, "build " + kScene + " --instanced --builder rdh");
  EXPECT_EQ(rdh.exit_code, 2) << rdh.output;
  EXPECT_NE(rdh.output.find("builder: 'rdh'"), std::string::npos) << rdh.output;
  fs::remove_all(dir);
}

TEST(InstancedCli, Table1OnTheInstancedSceneShowsTheTransformsAndLeavesRdhOut) {
  const fs::path dir = fresh("table1");
  const CliResult r = run_in(dir, "table1 " + kScene + " --instanced --builders sah,rdh --res 12x12 --no-cycle "
                                  "--cameras view1 --out-dir t");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(read_text(dir / "t" / "table1.json"));
  EXPECT_EQ(j.at("instanced"), true);
  EXPECT_GT(j.at("instances").get<uint64_t>(), 0u);
  ASSERT_EQ(j.at("rows").size(), 1u) << j.at("rows").dump();  // sah only
  const nlohmann::json& combined = j.at("rows").at(0).at("combined");
  EXPECT_GT(combined.at("xfm_ops_per_ray").get<double>(), 0.0);
  EXPECT_GT(combined.at("tlas_trv_ops_per_ray").get<double>(), 0.0);
  EXPECT_LT(combined.at("tlas_trv_ops_per_ray").get<double>(), combined.at("trv_ops_per_ray").get<double>());
  const std::string md = read_text(dir / "t" / "table1.md");
  EXPECT_NE(md.find("XFM/ray"), std::string::npos);
  EXPECT_NE(md.find("Left out: rdh"), std::string::npos);
  // The new columns are the stats of the same rays simulated alone.
  const CliResult sim = run_in(dir, "simulate " + kScene + " --instanced --res 12x12 --camera view1 "
                                    "--fidelity functional --out-dir s");
  ASSERT_EQ(sim.exit_code, 0) << sim.output;
  const nlohmann::json stats = nlohmann::json::parse(read_text(dir / "s" / "stats.json"));
  EXPECT_DOUBLE_EQ(combined.at("xfm_ops_per_ray").get<double>(),
                   stats.at("ops").at("xfm_ops_per_ray").at("value").get<double>());
  EXPECT_DOUBLE_EQ(combined.at("tlas_trv_ops_per_ray").get<double>(),
                   stats.at("ops").at("tlas_trv_ops_per_ray").at("value").get<double>());
  EXPECT_DOUBLE_EQ(combined.at("ops_per_ray").get<double>(), stats.at("ops").at("per_ray").at("value").get<double>());
  fs::remove_all(dir);
}

}  // namespace
