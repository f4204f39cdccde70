// rtsim claim: the quick map runs end to end, every verdict follows from its
// interval, a second run resumes (no job runs twice, same cells), bad input is
// named; and the statistics it rests on (t quantiles, Spearman with ties).
#include "integration/cli_runner.h"
#include "integration/test_campaign_fake.h"

#include <rtsim/reports/campaign.h>
#include <rtsim/reports/claim.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <map>

namespace rtsim {
namespace {

using nlohmann::json;

json read_json(const std::filesystem::path& p) {
  std::ifstream in(p);
  return json::parse(in);
}

TEST(Claim, QuickMapGivesVerdictsThatFollowFromTheIntervalsAndResumes) {
  const auto dir = test::fresh_folder("claim");
  const std::string args = "claim --quick --out-dir " + (dir / "out").string() + " --tree-cache " +
                           (dir / "trees").string();
  const CliResult first = run_rtsim(args);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const json claim = read_json(dir / "out" / "claim.json");
  // cornell, 2 cameras, 3 replicates: 5 conditions (the default, leaf, format,
  // cutoff, diffuse) x 5 builders + rdh at the default, osah and rdh traced from the
  // camera they were not built for, and rdh from surface AO rays.
  EXPECT_EQ(claim.at("jobs").get<size_t>(), (5u * 5u + 1u + 2u + 1u) * 2u * 3u);
  EXPECT_EQ(claim.at("jobs_missing_or_failed").get<size_t>(), 0u);
  size_t cells = 0, median_cells = 0;
  for (const json& c : claim.at("cells")) {
    ++cells;
    if (c.at("relation") == "all<median") ++median_cells;
    const std::string v = c.at("verdict");
    if (c.at("ci_lo_pct").is_null()) {
      EXPECT_EQ(v, "n/a");
      continue;
    }
    const double lo = c.at("ci_lo_pct"), hi = c.at("ci_hi_pct"), mean = c.at("mean_pct");
    EXPECT_EQ(c.at("n").get<int>(), 3);
    EXPECT_LE(lo, mean);
    EXPECT_GE(hi, mean);
    if (v == "holds") EXPECT_LT(hi, 0) << c.dump();
    if (v == "reverses") EXPECT_GT(lo, 0) << c.dump();
    if (v == "noise" && c.at("relation") != "all<median") EXPECT_TRUE(lo <= 0 && hi >= 0) << c.dump();
  }
  EXPECT_GT(cells, 0u);
  EXPECT_GT(median_cells, 0u);
  ASSERT_FALSE(claim.at("sentences").empty());
  ASSERT_FALSE(claim.at("cost_model_correlations").empty());
  for (const json& c : claim.at("cost_model_correlations")) {
    EXPECT_GE(c.at("points").get<int>(), 3);
    if (!c.at("sah_cost").is_null()) EXPECT_LE(std::abs(c.at("sah_cost").get<double>()), 1.0);
  }
  // On the camera it did not sample, rdh traces the other camera's tree, and from
  // surface AO rays a tree of no camera: other figures than its own camera's tree.
  std::map<std::string, json> rows;  // camera/builder/trees -> row
  for (const json& r : claim.at("default_condition"))
    rows[r.at("camera").get<std::string>() + "/" + r.at("builder").get<std::string>() + "/" +
         r.at("trees").get<std::string>()] = r;
  for (const char* camera : {"view1", "view2"}) {
    const std::string c = camera;
    ASSERT_TRUE(rows.count(c + "/rdh/unseen") && rows.count(c + "/osah/unseen") && rows.count(c + "/rdh/surfaces"))
        << c;
    EXPECT_FALSE(rows.count(c + "/sah/unseen") || rows.count(c + "/osah/surfaces"));
    for (const char* trees : {"/rdh/unseen", "/rdh/surfaces"})
      EXPECT_NE(rows.at(c + trees).at("ops_per_ray_ao"), rows.at(c + "/rdh/default").at("ops_per_ray_ao")) << trees;
  }
  // A tree-only condition has cells only for relations with a tree it rebuilt (AO-BVH
  // < SAH there would be the default's cell again).
  bool unseen_cells = false;
  for (const json& c : claim.at("cells")) {
    unseen_cells = unseen_cells || (c.at("condition") == "camera=unseen" && c.at("relation") == "rdh<sah");
    const std::string condition = c.at("condition"), relation = c.at("relation");
    if (condition == "camera=unseen" || condition == "rdh-rays=surfaces")
      EXPECT_TRUE(relation != "aobvh<sah" && relation != "aobvh<sbvh") << c.dump();
  }
  EXPECT_TRUE(unseen_cells);
  // Diffuse rays are a mix of their own where the condition traces them, and only there.
  size_t diffuse_cells = 0;
  for (const json& c : claim.at("cells"))
    if (c.at("mix") == "diffuse") {
      ++diffuse_cells;
      EXPECT_EQ(c.at("condition"), "diffuse=1") << c.dump();
      // cornell fits the caches: its DRAM bytes are ~0 and have no interval.
      if (c.at("metric") != "dram_bytes") EXPECT_FALSE(c.at("ci_lo_pct").is_null()) << c.dump();
    }
  EXPECT_GT(diffuse_cells, 0u);
  for (const char* f : {"claim.md", "claim.csv", "claim-campaign.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / f)) << f;

  const CliResult second = run_rtsim(args + " --json");
  ASSERT_EQ(second.exit_code, 0) << second.output;
  const json again = read_json(dir / "out" / "claim.json");
  EXPECT_EQ(again.at("jobs_run_now").get<size_t>(), 0u);  // resumed: nothing ran twice
  EXPECT_EQ(again.at("cells"), claim.at("cells"));
}

// The alpha factor's off level runs --opaque, and only on the scenes it changes.
TEST(Claim, TheAlphaFactorRunsOpaqueOnlyWhereMaterialsAreAlphaTested) {
  ClaimOptions o;
  o.scenes = {"cornell", "foliage_alpha"};
  o.factors = {{"leaf", {"4", "8"}, "4"}, {"alpha", {"on", "off"}, "on"}};
  const json doc = json::parse(claim_campaign_json(o));
  size_t opaque_groups = 0;
  for (const json& g : doc.at("group")) {
    if (!g.contains("opaque")) continue;
    ++opaque_groups;
    EXPECT_TRUE(g.at("opaque").get<bool>());
    EXPECT_EQ(g.at("scene"), json::array({"foliage_alpha"})) << g.dump();
    EXPECT_NE(g.at("name").get<std::string>().find("alpha=off"), std::string::npos) << g.dump();
  }
  EXPECT_GE(opaque_groups, 1u);
  // The campaign it makes expands: the off level's jobs are foliage_alpha's, with --opaque.
  const Campaign campaign = parse_campaign(doc, "/tmp/claim-alpha.json", "test");
  size_t opaque_jobs = 0;
  for (const CampaignJob& j : campaign.jobs) {
    if (!j.opaque) continue;
    ++opaque_jobs;
    EXPECT_EQ(j.scene, "foliage_alpha");
    const auto args = j.simulate_arguments("/o");
    EXPECT_EQ(std::count(args.begin(), args.end(), "--opaque"), 1);
  }
  EXPECT_GT(opaque_jobs, 0u);
  o.scenes = {"cornell"};  // nothing alpha-tested: no off level at all
  const json plain = json::parse(claim_campaign_json(o));  // kept: the loop reads into it
  for (const json& g : plain.at("group")) EXPECT_FALSE(g.contains("opaque")) << g.dump();
}

TEST(Claim, TheInstancedFactorRunsTwoLevelTreesOnlyWhereScenesHaveInstances) {
  ClaimOptions o;
  o.scenes = {"cornell", "forest_instanced"};
  o.factors = {{"leaf", {"4", "8"}, "4"}, {"instanced", {"off", "on"}, "off"}};
  const json doc = json::parse(claim_campaign_json(o));
  size_t instanced_groups = 0;
  for (const json& g : doc.at("group")) {
    if (!g.contains("instanced")) continue;
    ++instanced_groups;
    EXPECT_EQ(g.at("scene"), json::array({"forest_instanced"})) << g.dump();
    EXPECT_NE(g.at("name").get<std::string>().find("instanced=on"), std::string::npos) << g.dump();
  }
  EXPECT_GE(instanced_groups, 1u);
  const Campaign campaign = parse_campaign(doc, "/tmp/claim-instanced.json", "test");
  size_t instanced_jobs = 0;
  for (const CampaignJob& j : campaign.jobs) {
    if (!j.instanced) continue;
    ++instanced_jobs;
    EXPECT_EQ(j.scene, "forest_instanced");
    const auto args = j.simulate_arguments("/o");
    EXPECT_EQ(std::count(args.begin(), args.end(), "--instanced"), 1);
  }
  EXPECT_GT(instanced_jobs, 0u);
  o.scenes = {"cornell"};  // flat: no on level at all
  const json plain = json::parse(claim_campaign_json(o));
  for (const json& g : plain.at("group")) EXPECT_FALSE(g.contains("instanced")) << g.dump();
}

TEST(Claim, BadInputIsNamed) {
  const CliResult r = run_rtsim("claim --replicates 1 --out-dir /tmp/rtsim-claim-bad");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--replicates"), std::string::npos) << r.output;
  const CliResult other = run_rtsim("claim --quick --rtsim " + std::string(RTSIM_BINARY) +
                                    " --out-dir /tmp/rtsim-claim-bad");
  EXPECT_EQ(other.exit_code, 2) << other.output;
  EXPECT_NE(other.output.find("--tree-cache"), std::string::npos) << other.output;
}

TEST(ClaimStatistics, TQuantilesAndSpearmanWithTies) {
  EXPECT_NEAR(t_quantile_975(1), 12.706, 1e-3);
  EXPECT_NEAR(t_quantile_975(4), 2.776, 1e-3);
  EXPECT_NEAR(t_quantile_975(45), 2.014, 3e-3);
  EXPECT_NEAR(t_quantile_975(120), 1.980, 1e-3);
  EXPECT_NEAR(t_quantile_975(100000), 1.960, 1e-3);
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {10, 20, 25, 100}), 1.0, 1e-12);
  EXPECT_NEAR(spearman({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0, 1e-12);
  // Ranks (1, 2.5, 2.5, 4) against (1, 2, 3, 4): 4.5 / sqrt(4.5 * 5).
  EXPECT_NEAR(spearman({1, 2, 2, 3}, {1, 2, 3, 4}), 4.5 / std::sqrt(4.5 * 5.0), 1e-12);
  EXPECT_TRUE(std::isnan(spearman({1, 1, 1}, {1, 2, 3})));
  EXPECT_TRUE(std::isnan(spearman({1, 2}, {1, 2})));
}

}  // namespace
}  // namespace rtsim
