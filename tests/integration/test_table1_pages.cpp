// table1's pages say what they measured and nothing they did not: no column or
// panel that holds a builder against itself or draws nothing, the patent's Table 1
// once (on the page above several tables, not on each), and the hardware the
// cycle-level runs used, in the terminal, the Markdown and the JSON.
#include "integration/cli_runner.h"
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/child_process.h>
#include <rtsim/workloads/files.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <set>
#include <string>

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using rtsim::shell_quote;
using rtsim::test::fresh_folder;

CliResult run_in(const fs::path& cwd, const std::string& args) {
  return run_rtsim_command("cd " + shell_quote(cwd.string()) + " && RTSIM_NO_PROGRESS=1 timeout 300 " +
                           shell_quote(RTSIM_BINARY) + " " + args + " 2>&1");
}

std::string read(const fs::path& p) { return rtsim::read_input_file(p, 1 << 22); }

size_t count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

const char* kPatentHeading = "The patent's Table 1";

}  // namespace

// One builder, two node formats, cycle level on a preset that is not the default.
TEST(Table1Pages, OneBuilderByFormatShowsNoSelfComparisonThePatentOnceAndThePreset) {
  const fs::path dir = fresh_folder("table1-pages-one");
  const CliResult r = run_in(dir, "table1 --scene cornell --res 16x16 --builders sah --config desktop "
                                  "--node-formats bvh2-64 bvh4-128 --out-dir t");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // The terminal: the preset named, the patent's table once, no "vs SAH" column.
  EXPECT_NE(r.output.find("hardware preset 'desktop'"), std::string::npos) << r.output;
  EXPECT_EQ(count(r.output, kPatentHeading), 1u) << r.output;
  EXPECT_EQ(r.output.find("vs SAH"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("vs SBVH"), std::string::npos) << r.output;

  const std::string formats = read(dir / "t" / "formats.md");
  EXPECT_EQ(count(formats, kPatentHeading), 1u) << formats;
  EXPECT_NE(formats.find("hardware preset 'desktop'"), std::string::npos) << formats;
  EXPECT_EQ(formats.find("vs SAH"), std::string::npos) << formats;
  EXPECT_EQ(formats.find("Reductions:"), std::string::npos) << formats;

  std::map<std::string, double> ops;  // "format camera" -> ops/ray in that format's table1.json
  for (const char* f : {"bvh2-64", "bvh4-128"}) {
    const fs::path page = dir / "t" / f;
    const std::string md = read(page / "table1.md");
    EXPECT_EQ(md.find("## The patent's Table 1"), std::string::npos) << f << ": shown once, in formats.md";
    EXPECT_NE(md.find("[../formats.md](../formats.md)"), std::string::npos) << md;
    EXPECT_NE(md.find("hardware preset 'desktop'"), std::string::npos) << md;
    EXPECT_EQ(md.find("vs SAH"), std::string::npos) << md;
    EXPECT_EQ(md.find("vs median"), std::string::npos) << md;
    EXPECT_EQ(md.find("table1_reductions.png"), std::string::npos) << md;
    EXPECT_FALSE(fs::exists(page / "table1_reductions.png")) << "a figure of SAH against itself";
    EXPECT_TRUE(fs::exists(page / "table1_heatmaps.png"));
    const json table = json::parse(read(page / "table1.json"));
    EXPECT_EQ(table["cycle_level"]["hardware"], "desktop");
    EXPECT_EQ(table["cycle_level"]["kind"], "preset");
    EXPECT_EQ(table["figures"], json::array({"table1_heatmaps.png"}));
    for (const json& row : table["rows"]) {
      EXPECT_GT(row["cycles"].get<double>(), 0) << "the cycle level ran";
      ops[std::string(f) + " " + row["camera"].get<std::string>()] = row["combined"]["ops_per_ray"];
    }
  }
  // The formats figure: every panel draws something, none a builder against itself,
  // and every bar is the ops/ray of its format's table.
  const json drawn = json::parse(read(dir / "t" / "table1_formats.data.json"))["drawn"];
  ASSERT_FALSE(drawn.empty());
  std::set<std::string> panels;
  for (const json& d : drawn) {
    panels.insert(d["panel"]);
    const std::string panel = d["panel"];
    EXPECT_NE(panel, "reduction_vs_" + d["builder"].get<std::string>()) << d.dump();
    ASSERT_TRUE(d["value"].is_number()) << d.dump();
    EXPECT_TRUE(std::isfinite(d["value"].get<double>())) << d.dump();
    EXPECT_EQ(d["value"].get<double>(), ops.at(d["format"].get<std::string>() + " " + d["camera"].get<std::string>()))
        << d.dump();
  }
  EXPECT_EQ(panels, (std::set<std::string>{"ops_per_ray"})) << "SAH alone: no reduction panels";
  EXPECT_EQ(drawn.size(), 4u) << "1 builder x 2 formats x 2 cameras";
  fs::remove_all(dir);
}

// Two builders: the comparison is there, SAH's own bar is not; without cycle-level
// runs the DRAM and cycle columns go and the page says why.
TEST(Table1Pages, TwoBuildersCompareAndNoCycleLevelDropsItsColumns) {
  const fs::path dir = fresh_folder("table1-pages-two");
  const CliResult r = run_in(dir, "table1 --scene cornell --res 16x16 --builders sah sbvh --no-cycle --out-dir t");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("vs SAH"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("vs median"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("DRAM B/ray"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("No cycle-level runs (--no-cycle)"), std::string::npos) << r.output;
  EXPECT_EQ(count(r.output, kPatentHeading), 1u) << r.output;
  const std::string md = read(dir / "t" / "table1.md");
  EXPECT_EQ(count(md, "## The patent's Table 1"), 1u) << md;
  EXPECT_NE(md.find("red. vs SAH"), std::string::npos) << md;
  EXPECT_EQ(md.find("cycles |"), std::string::npos) << md;
  const json table = json::parse(read(dir / "t" / "table1.json"));
  EXPECT_TRUE(table["cycle_level"].is_null());
  EXPECT_EQ(table["figures"], json::array({"table1_reductions.png", "table1_heatmaps.png"}));
  const json drawn = json::parse(read(dir / "t" / "table1_reductions.data.json"))["drawn"];
  ASSERT_EQ(drawn.size(), 2u) << drawn.dump() << ": SBVH against SAH on each camera, nothing else";
  for (const json& d : drawn) {
    EXPECT_EQ(d["builder"], "sbvh");
    EXPECT_EQ(d["baseline"], "sah");
  }
  fs::remove_all(dir);
}

// Diffuse bounces as a ray mix: their rays are a column of their own (all depths),
// counted in the combined figures, and the cycle level counts them alike; without
// them the page has no such column and the JSON says 0.
TEST(Table1Pages, DiffuseBouncesAreAColumnAndCountInTheCombinedFigures) {
  const fs::path dir = fresh_folder("table1-pages-diffuse");
  const CliResult r =
      run_in(dir, "table1 --scene cornell --res 16x16 --builders sah --diffuse-bounces 2 --frames 1 --out-dir t");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string md = read(dir / "t" / "table1.md");
  EXPECT_NE(md.find("diffuse ops/ray"), std::string::npos) << md;
  const json table = json::parse(read(dir / "t" / "table1.json"));
  EXPECT_EQ(table["diffuse_bounces"], 2);
  for (const json& row : table["rows"]) {
    const uint64_t primary = row["primary"]["rays"], ao = row["ao"]["rays"], diffuse = row["diffuse"]["rays"];
    EXPECT_GT(diffuse, 0u) << row.dump();
    EXPECT_LE(diffuse, 2 * primary) << "one depth-1 ray per primary hit, one depth-2 ray per depth-1 hit";
    // cornell's lights and mirror add shadow and reflection rays to the combined figures.
    EXPECT_GE(uint64_t(row["combined"]["rays"]), primary + ao + diffuse) << row.dump();
    EXPECT_TRUE(row["counts_match_cycle_level"].get<bool>()) << row.dump();
    // The diffuse rays and their DRAM bytes are those of the run's diffuse1 and diffuse2 rays.
    const json stats = json::parse(read(dir / "t" / "runs" / (row["camera"].get<std::string>() + "-sah") / "stats.json"));
    EXPECT_EQ(uint64_t(row["combined"]["rays"]), stats["rays"]["total"]["value"].get<uint64_t>());
    double bytes = 0;
    uint64_t rays = 0;
    for (const char* type : {"diffuse1", "diffuse2"}) {
      rays += stats["per_type"][type]["rays"]["value"].get<uint64_t>();
      for (const auto& [kind, v] : stats["dram"]["bytes_by_type"][type].items()) bytes += v["value"].get<double>();
    }
    EXPECT_EQ(diffuse, rays);
    EXPECT_NEAR(row["diffuse"]["dram_bytes_per_ray"].get<double>() * double(diffuse), bytes, 1e-6 * (1 + bytes));
  }
  const CliResult plain = run_in(dir, "table1 --scene cornell --res 16x16 --builders sah --no-cycle --out-dir p");
  ASSERT_EQ(plain.exit_code, 0) << plain.output;
  EXPECT_EQ(read(dir / "p" / "table1.md").find("diffuse ops/ray"), std::string::npos);
  EXPECT_EQ(json::parse(read(dir / "p" / "table1.json"))["diffuse_bounces"], 0);
  EXPECT_NE(run_in(dir, "table1 --diffuse-bounces 9 --out-dir q").exit_code, 0);
  fs::remove_all(dir);
}

namespace {

// --all-scenes with no fetched scene (an empty cache): the default scene only; a
// relation whose trees are not all in the table decides nothing ("-", not
// "holds"); with --instanced the flat default is left out, said so, and the
// generated instanced forest is run instead.
TEST(Table1AllScenes, MissingTreesDecideNothingAndInstancedRunsOnlyScenesWithInstances) {
  const fs::path dir = fresh_folder("table1-all-scenes");
  fs::create_directories(dir / "cache");
  const std::string run = "RTSIM_CACHE=" + shell_quote((dir / "cache").string()) + " RTSIM_NO_PROGRESS=1 " +
                          shell_quote(RTSIM_BINARY) + " table1 --all-scenes --builders sah aobvh --no-cycle "
                                                      "--res 8x8 --build-seeds 2 --cameras view1 ";
  const CliResult flat = run_rtsim_command("cd " + shell_quote(dir.string()) + " && " + run + "--out-dir flat 2>&1");
  ASSERT_EQ(flat.exit_code, 0) << flat.output;
  const std::string csv = rtsim::read_input_file(dir / "flat" / "summary.csv", 1 << 20);
  EXPECT_NE(csv.find("interior"), std::string::npos) << csv;
  EXPECT_EQ(csv.find("yes"), std::string::npos) << csv;  // no relation has its trees here
  const size_t row = flat.output.find("\ninterior");
  ASSERT_NE(row, std::string::npos) << flat.output;
  const std::string line = flat.output.substr(row + 1, flat.output.find('\n', row + 1) - row - 1);
  EXPECT_NE(line.find("- | -"), std::string::npos) << line;
  const CliResult inst =
      run_rtsim_command("cd " + shell_quote(dir.string()) + " && " + run + "--instanced --out-dir inst 2>&1");
  ASSERT_EQ(inst.exit_code, 0) << inst.output;
  EXPECT_NE(inst.output.find("interior has no instances; left out"), std::string::npos) << inst.output;
  EXPECT_NE(inst.output.find("\nforest_instanced"), std::string::npos) << inst.output;
  EXPECT_TRUE(fs::exists(dir / "inst" / "forest_instanced" / "table1.json"));
  fs::remove_all(dir);
}

}  // namespace
