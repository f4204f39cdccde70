// Every figure of a campaign report shows the stats it names (reports/scripts/
// campaign_plots.py writes what it drew beside each picture): a real campaign of
// builders x presets with an L2, a builder-parameter and a node-format sweep is run
// and reported, and every drawn bar, stacked segment sum and point is held to the
// run's stats.json in the database. The bars of stacked figures add up to the stat
// they show (DRAM bytes per ray by ray type and byte kind: every kind the model
// writes). Values equal to the preset's are the plain run, sweeps are sorted as
// numbers, and a one-builder campaign draws no builder comparison.
#include "cli_runner.h"
#include "stats_support.h"

#include <rtsim/reports/results_store.h>

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <set>

namespace {

using nlohmann::json;

const char* kCampaign = R"(
[campaign]
name = "figures"
[sweep]
scene = "interior"
builder = ["sah", "median"]
preset = ["mobile", "mobile-gpu"]
fidelity = "cycle"
resolution = "24x24"
[[group]]
name = "base"
[[group]]
name = "l2"
preset = "mobile"
# 524288 is mobile's own L2: that job is the plain mobile one.
set.l2.size_bytes = [1048576, 262144, 524288]
[[group]]
name = "leaf"
builder = "sah"
preset = "mobile"
build.max_leaf_size = [2, 4, 8]
[[group]]
name = "format"
builder = "sah"
preset = "mobile"
node_format = ["bvh2-64", "bvh4-128"]
)";

json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

// The stats of every run in the database by job key, as dotted keys.
std::map<std::string, std::map<std::string, double>> stats_by_key(const std::filesystem::path& db) {
  std::map<std::string, std::map<std::string, double>> out;
  rtsim::ResultsStore store(db, rtsim::ResultsStore::Access::ReadOnly);
  for (const json& row : store.rows(""))
    out[row.at("job_key")] = rtsim::flatten_stats(json::parse(row.at("stats_json").get<std::string>()));
  return out;
}

double stat_of(const std::map<std::string, double>& s, const std::string& stat) {
  const size_t slash = stat.find(" / ");
  if (slash != std::string::npos) return s.at(stat.substr(0, slash)) / s.at(stat.substr(slash + 3));
  return s.at(stat);
}

void expect_close(double drawn, double stat, const std::string& what) {
  EXPECT_NEAR(drawn, stat, 1e-9 * std::max(1.0, std::fabs(stat))) << what;
}

std::filesystem::path run_campaign(const std::filesystem::path& dir, const std::string& toml) {
  std::ofstream(dir / "c.toml") << toml;
  const CliResult run = run_rtsim("campaign run " + (dir / "c.toml").string() + " -j 2 --tree-cache " +
                                  (dir / "trees").string() + " --no-results-cache");
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const auto report = dir / "report";
  const CliResult r = run_rtsim("report " + (dir / "rtsim-campaigns" / "figures" / "results.sqlite").string() +
                                " --out-dir " + report.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return report;
}

// A campaign of one builder on interior at 16x16 on mobile, and `rest` of its sweep.
std::string one_builder_campaign(const std::string& rest) {
  return "[campaign]\nname = \"figures\"\n[sweep]\nscene = \"interior\"\nbuilder = \"sah\"\npreset = \"mobile\"\n"
         "resolution = \"16x16\"\n" + rest;
}

}  // namespace

TEST(ReportFigures, EveryDrawnValueIsTheStatItShows) {
  const auto dir = scratch_folder("report_figures", "all");
  const auto report = run_campaign(dir, kCampaign);
  const auto stats = stats_by_key(dir / "rtsim-campaigns" / "figures" / "results.sqlite");
  const json figures = read_json(report / "figures.json");
  std::set<std::string> names;
  size_t checked = 0, stacked = 0;
  for (const json& f : figures) {
    const std::string file = f.at("file");
    names.insert(file.substr(0, file.size() - 4));
    const json drawn = read_json(report / (file.substr(0, file.size() - 4) + ".data.json"));
    ASSERT_FALSE(drawn.at("drawn").empty()) << file << ": a figure that draws nothing";
    for (const json& d : drawn.at("drawn")) {
      const std::string what = file + " " + d.dump();
      const auto& s = stats.at(d.at("job_key"));
      expect_close(d.at("value").get<double>(), d.at("scale").get<double>() * stat_of(s, d.at("stat")), what);
      if (d.contains("parts")) {
        double sum = 0;
        for (const auto& [part, v] : d.at("parts").items()) sum += v.get<double>();
        expect_close(sum, d.at("value").get<double>(), what + ": the parts add up to the bar");
        ++stacked;
      }
      ++checked;
    }
  }
  for (const char* figure : {"dram_bytes_per_ray", "hit_rates", "cycles", "cycle_accounting", "ops_and_fetches",
                             "energy_per_ray", "sweep_l2_size_bytes", "sweep_build_max_leaf_size",
                             "sweep_node_format"})
    EXPECT_TRUE(names.count(figure)) << figure;
  EXPECT_GT(checked, 50u);
  EXPECT_GT(stacked, 20u);

  // The DRAM figure stacks every byte kind the model writes (stack traffic included when it has it).
  const json dram = read_json(report / "dram_bytes_per_ray.data.json");
  std::set<std::string> kinds;
  for (const json& d : dram.at("drawn"))
    for (const auto& [part, v] : d.at("parts").items()) kinds.insert(part.substr(part.find(", ") + 2));
  EXPECT_TRUE(kinds.count("prim_ref data")) << dram.dump();

  // The L2 sweep: mobile's own 512 KiB is the plain run, and the points go by value.
  const json sweep = read_json(report / "sweep_l2_size_bytes.data.json");
  std::map<std::string, std::vector<double>> xs;  // builder -> x of its DRAM points, in drawing order
  for (const json& d : sweep.at("drawn"))
    if (d.at("metric") == "DRAM bytes per ray") xs[d.at("builder")].push_back(d.at("x").get<double>());
  for (const auto& [builder, list] : xs)
    EXPECT_EQ(list, (std::vector<double>{262144, 524288, 1048576})) << builder;
  const json data = read_json(report / "report-data.json");
  size_t plain = 0;
  for (const json& r : data.at("runs")) plain += r.at("plain").get<bool>();
  EXPECT_EQ(plain, 4u) << "2 builders x 2 presets";

  // The table lists the swept values numerically too.
  std::ifstream md_in(report / "report.md");
  const std::string md((std::istreambuf_iterator<char>(md_in)), {});
  const size_t small = md.find("l2.size_bytes=262144"), large = md.find("l2.size_bytes=1048576");
  ASSERT_NE(small, std::string::npos);
  ASSERT_NE(large, std::string::npos);
  EXPECT_LT(small, large);
  std::filesystem::remove_all(dir);
}

TEST(ReportFigures, AOneBuilderCampaignDrawsNoBuilderComparison) {
  const auto dir = scratch_folder("report_figures", "one");
  const auto report = run_campaign(dir, one_builder_campaign("fidelity = \"lt\"\nset.l2.size_bytes = [262144, 524288]\n"));
  std::ifstream md_in(report / "report.md");
  const std::string md((std::istreambuf_iterator<char>(md_in)), {});
  EXPECT_EQ(md.find("| builder"), std::string::npos) << md;
  EXPECT_EQ(md.find("builders are sorted"), std::string::npos) << md;
  EXPECT_NE(md.find("Every run: scene interior, fidelity lt, preset mobile"), std::string::npos) << md;
  EXPECT_NE(md.find("builder sah"), std::string::npos) << md;
  const json figures = read_json(report / "figures.json");
  for (const json& f : figures) {
    const json drawn = read_json(report / (f.at("file").get<std::string>().substr(0, f.at("file").get<std::string>().size() - 4) + ".data.json"));
    EXPECT_FALSE(drawn.at("drawn").empty()) << f.dump();
  }
  std::filesystem::remove_all(dir);
}

// Diffuse bounces are a workload axis: the report sweeps them (cycles and DRAM bytes
// against the depth, each point the stat of its run), and 0 bounces is the plain run
// the main figures show, not whichever depth came last.
TEST(ReportFigures, DiffuseBouncesAreASweepAndNoBouncesIsThePlainRun) {
  const auto dir = scratch_folder("report_figures", "diffuse");
  const auto report = run_campaign(dir, one_builder_campaign("fidelity = \"cycle\"\ndiffuse_bounces = [2, 0]\n"));
  const auto stats = stats_by_key(dir / "rtsim-campaigns" / "figures" / "results.sqlite");
  const json data = read_json(report / "report-data.json");
  std::string plain_key;
  for (const json& r : data.at("runs"))
    if (r.at("plain").get<bool>()) {
      EXPECT_TRUE(plain_key.empty()) << "one plain run";
      plain_key = r.at("job_key");
      EXPECT_EQ(r.at("coordinates").at("diffuse_bounces"), 0) << r.dump();
    }
  ASSERT_FALSE(plain_key.empty());
  EXPECT_EQ(stats.at(plain_key).count("per_type.diffuse1.rays"), 0u) << "the plain run has no diffuse rays";
  const json dram = read_json(report / "dram_bytes_per_ray.data.json");
  for (const json& d : dram.at("drawn")) EXPECT_EQ(d.at("job_key"), plain_key) << d.dump();

  const json sweep = read_json(report / "sweep_diffuse_bounces.data.json");
  std::vector<double> xs;
  for (const json& d : sweep.at("drawn")) {
    expect_close(d.at("value").get<double>(),
                 d.at("scale").get<double>() * stat_of(stats.at(d.at("job_key")), d.at("stat")), d.dump());
    if (d.at("metric") == "DRAM bytes per ray") xs.push_back(d.at("x").get<double>());
  }
  EXPECT_EQ(xs, (std::vector<double>{0, 2}));
  std::filesystem::remove_all(dir);
}

// Every workload axis a campaign sweeps is a coordinate (AO rays, and the resolution as
// its pixel count), and the plain run is the one at simulate's default or, where no job
// has it, at the smallest value: one plain run, where before every run was plain and the
// main figures showed whichever came last.
TEST(ReportFigures, SweptWorkloadAxesHaveOnePlainRun) {
  const auto dir = scratch_folder("report_figures", "workload");
  const auto report = run_campaign(dir, one_builder_campaign("fidelity = \"functional\"\nao = [4, 0]\n"
                                                             "[[group]]\nname = \"small\"\n"
                                                             "[[group]]\nname = \"large\"\nresolution = \"24x24\"\n"));
  const auto stats = stats_by_key(dir / "rtsim-campaigns" / "figures" / "results.sqlite");
  const json data = read_json(report / "report-data.json");
  ASSERT_EQ(data.at("runs").size(), 4u);
  std::string plain_key;
  for (const json& r : data.at("runs"))
    if (r.at("plain").get<bool>()) {
      EXPECT_TRUE(plain_key.empty()) << "one plain run: " << data.at("runs").dump();
      plain_key = r.at("job_key");
      EXPECT_EQ(r.at("coordinates").at("ao"), 0) << r.dump();
      EXPECT_EQ(r.at("coordinates").at("resolution"), 16 * 16) << r.dump();
    }
  ASSERT_FALSE(plain_key.empty());
  // Held in a local: a range-for over a member of a temporary reads freed memory.
  const json dram_figure = read_json(report / "dram_bytes_per_ray.data.json");
  for (const json& d : dram_figure.at("drawn"))
    EXPECT_EQ(d.at("job_key"), plain_key) << d.dump();
  for (const char* axis : {"ao", "resolution"}) {
    const json sweep = read_json(report / (std::string("sweep_") + axis + ".data.json"));
    std::set<double> xs;
    for (const json& d : sweep.at("drawn")) {
      expect_close(d.at("value").get<double>(),
                   d.at("scale").get<double>() * stat_of(stats.at(d.at("job_key")), d.at("stat")), d.dump());
      xs.insert(d.at("x").get<double>());
    }
    EXPECT_EQ(xs, (std::string(axis) == "ao" ? std::set<double>{0, 4} : std::set<double>{256, 576})) << axis;
  }
  std::filesystem::remove_all(dir);
}
